//! `skin-sim`: the simulated world of the skin, from the command line.
//!
//! `skin-sim network ...` runs a skin network: it self-organizes, carries
//! sensor traffic under a stimulus, suffers the faults asked for, and
//! reports latency, losses and capacity (`--json` for one JSON object).

use std::io::Write;
use std::net::SocketAddr;
use std::process::ExitCode;

use clap::{Args, Parser, Subcommand, ValueEnum};
use indicatif::{ProgressBar, ProgressStyle};
use skin_protocol::message::TrafficMode;
use skin_sim::network::fault::{Fault, FaultSpec};
use skin_sim::network::scenario::{time_s, MAX_TIME_S};
use skin_sim::network::stimulus::StimulusKind;
use skin_sim::network::transport::Transport;
use skin_sim::network::{NetworkConfig, NetworkError, Scenario, Topology};

#[derive(Parser)]
#[command(name = "skin-sim", version, about = "The simulated world of the robot skin")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Simulate a skin network: self-organization, traffic, faults, capacity.
    Network(NetworkArgs),
}

#[derive(Clone, Copy, ValueEnum)]
enum Traffic {
    /// Every sample at the sampling rate.
    Clock,
    /// Send-on-delta samples and tactile level events.
    Event,
}

#[derive(Clone, Copy, ValueEnum)]
enum Stimulus {
    /// Nothing touches the skin.
    Quiet,
    /// A fingertip slides across the skin.
    Touch,
    /// A large object is grasped with the whole arm.
    Grasp,
}

#[derive(Args)]
struct NetworkArgs {
    /// `hex:ROWSxCOLS` (join patches with `+`), `chain:CELLS`, `hrp2`, or a .toml/.json graph file.
    #[arg(long)]
    topology: String,
    /// Interface ports in all; those the topology lacks go on free boundary
    /// ports [default: the topology's own, or 1].
    #[arg(long)]
    interfaces: Option<usize>,
    /// Sampling rate of every cell, in Hz.
    #[arg(long, default_value_t = 250.0)]
    rate: f32,
    /// How cells send their samples.
    #[arg(long, value_enum, default_value = "clock")]
    traffic: Traffic,
    /// What the skin feels.
    #[arg(long, value_enum, default_value = "quiet")]
    stimulus: Stimulus,
    /// Virtual seconds of traffic after self-organization.
    #[arg(long)]
    duration: f64,
    /// A fault: cut:CELL.PORT@S, dead:CELL@S, reboot:CELL@S, interface:K@S
    /// (S seconds after self-organization) or ber:RATE. Repeatable.
    #[arg(long = "fault")]
    faults: Vec<FaultSpec>,
    /// A send-on-delta threshold the host sets on every cell, as
    /// CHANNEL=COUNTS; channels: proximity, force0, force1, force2, ax, ay,
    /// az, temperature. Repeatable.
    #[arg(long = "delta", value_parser = parse_delta)]
    deltas: Vec<(u8, u16)>,
    /// Keep-alive period of settled links, in ms: probes on ports that sent
    /// nothing else, beacon waves on spare links; such a link is given up
    /// after 3.5 periods of silence.
    #[arg(long, default_value_t = 100.0)]
    keepalive_ms: f64,
    /// Period of the beacon waves of the interface ports, in ms; a cell
    /// whose wave is 1.5 periods late asks its neighbours for the next one,
    /// and gives up its route and the link to its parent after 3.5.
    #[arg(long, default_value_t = 10.0)]
    beacon_ms: f64,
    /// Seed of everything random.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Virtual seconds self-organization may take.
    #[arg(long, default_value_t = 30.0)]
    organize_timeout: f64,
    /// Send the interface's datagrams to a host program at this loopback
    /// address (and take its answers) instead of the built-in host; the
    /// run then paces itself to the wall clock.
    #[arg(long)]
    udp: Option<SocketAddr>,
    /// Local address of the UDP socket.
    #[arg(long, default_value = "127.0.0.1:0")]
    bind: SocketAddr,
    /// Print one JSON object instead of a summary.
    #[arg(long)]
    json: bool,
}

/// Sample channels in the order of `Sample::channels`.
const CHANNELS: [&str; 8] = ["proximity", "force0", "force1", "force2", "ax", "ay", "az", "temperature"];

fn parse_delta(s: &str) -> Result<(u8, u16), String> {
    let usage = || format!("`{s}`: write CHANNEL=COUNTS, CHANNEL one of {}", CHANNELS.join(", "));
    let (name, counts) = s.split_once('=').ok_or_else(usage)?;
    let channel = CHANNELS.iter().position(|c| *c == name).ok_or_else(usage)?;
    let counts = counts.parse().map_err(|_| usage())?;
    Ok((channel as u8, counts))
}

/// A period flag in ms as whole microseconds (a later check bounds it
/// further; this one keeps the microseconds in a `u64`).
fn period_us(flag: &str, ms: f64) -> Result<u64, NetworkError> {
    if !(ms > 0.0 && ms <= MAX_TIME_S) {
        return Err(NetworkError::Flag(format!("{flag} {ms}: give a period in ms, e.g. {flag} 100")));
    }
    Ok((ms * 1e3).round() as u64)
}

fn network(args: NetworkArgs) -> Result<(), NetworkError> {
    let mut topology = Topology::parse(&args.topology)?;
    let have = topology.interfaces().len();
    let want = args.interfaces.unwrap_or(have.max(1));
    if want < have {
        return Err(NetworkError::Flag(format!(
            "--interfaces {want}: the topology already has {have} interface ports"
        )));
    }
    topology = topology.with_interfaces(want - have)?;
    let mut config = NetworkConfig {
        rate_hz: args.rate,
        traffic: match args.traffic {
            Traffic::Clock => TrafficMode::Clock,
            Traffic::Event => TrafficMode::Event,
        },
        stimulus: match args.stimulus {
            Stimulus::Quiet => StimulusKind::Quiet,
            Stimulus::Touch => StimulusKind::Touch,
            Stimulus::Grasp => StimulusKind::Grasp,
        },
        seed: args.seed,
        ..NetworkConfig::default()
    }
    .with_periods(period_us("--keepalive-ms", args.keepalive_ms)?, period_us("--beacon-ms", args.beacon_ms)?)?;
    for (channel, counts) in args.deltas {
        config.delta_counts[usize::from(channel)] = Some(counts);
    }
    let mut faults: Vec<Fault> = Vec::new();
    for f in args.faults {
        match f {
            FaultSpec::At(f) => faults.push(f),
            FaultSpec::BitErrorRate(ber) => config.bit_error_rate = ber,
        }
    }
    let duration_s = time_s("--duration", args.duration)?;
    let organize_timeout_s = time_s("--organize-timeout", args.organize_timeout)?;
    if organize_timeout_s == 0.0 {
        return Err(NetworkError::Flag("--organize-timeout: give a time > 0 s".into()));
    }
    let scenario = Scenario { topology, config, duration_s, faults, organize_timeout_s };
    let mut transport = match args.udp {
        Some(host) => Transport::udp(host, args.bind)?,
        None => Transport::memory(),
    };
    let bar = ProgressBar::new(1000);
    bar.set_style(
        ProgressStyle::with_template("{spinner} simulating [{bar:40}] {percent}% ({elapsed})")
            .expect("a valid template")
            .progress_chars("=> "),
    );
    let report = scenario.run(&mut transport, &mut |f| bar.set_position((f * 1000.0) as u64))?;
    bar.finish_and_clear();
    let text =
        if args.json { serde_json::to_string_pretty(&report).expect("a report serializes") } else { report.summary() };
    // A closed pipe (`| head`) is the reader's choice, not an error.
    let _ = writeln!(std::io::stdout().lock(), "{text}");
    Ok(())
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Network(args) => network(args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("skin-sim: {e}");
            ExitCode::FAILURE
        }
    }
}
