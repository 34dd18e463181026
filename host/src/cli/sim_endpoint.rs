//! `skin sim-endpoint`: the built-in simulated HRP-2-like robot and its
//! skin served on loopback UDP, for `skin run` (or `skin monitor`) in
//! another terminal: the robot on the robot link, each of the five
//! interface ports (or, with `--patches`, one per wired group of cells)
//! sending to the host's interface address.

use std::io::Write;
use std::net::SocketAddr;
use std::process::ExitCode;
use std::time::{Duration, Instant};

use clap::ValueEnum;
use skin_sim::endpoint::{Batching, Endpoint, EndpointConfig, Pacing, Running};
use skin_sim::network::sensor_fault::SensorFault;
use skin_sim::network::{NetworkConfig, NetworkError, UpdateSetup};

use super::seconds;
use super::world::SimArgs;

/// Arguments of `skin sim-endpoint`.
#[derive(clap::Args)]
pub struct Args {
    /// Where the host listens for the skin (`skin run --interface`).
    #[arg(long, value_name = "ADDR", default_value = "127.0.0.1:7700")]
    host: SocketAddr,
    /// The robot-link address to serve on (`skin run --robot`).
    #[arg(long, value_name = "ADDR", default_value = "127.0.0.1:7800")]
    robot: SocketAddr,
    /// How simulated time advances.
    #[arg(long, value_enum, default_value_t = Pace::Lockstep)]
    pace: Pace,
    /// Seed of everything random: skin placement, boot order, sensor errors, noise, sway.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Lay the skin in wired patches one cell pitch apart and wire the network as laid (one
    /// interface port per wired group), so the neighbour tables follow the geometry (`skin run
    /// --urdf F --cell-pitch 0.025`); the host then needs as many ports as the line printed names.
    #[arg(long)]
    patches: bool,
    /// Serve this model (MJCF or URDF) run in MuJoCo instead of the built-in robot, its skin laid
    /// in wired patches on its collision geometry; without FILE, the built-in robot and its own
    /// 74-cell skin on the five ports, moved by MuJoCo (a build with the `mujoco` feature).
    #[arg(long, value_name = "FILE", num_args = 0..=1, conflicts_with = "patches")]
    mujoco: Option<Option<std::path::PathBuf>>,
    /// Cells on every body of the --mujoco FILE model with geometry or mass [default: 4].
    #[arg(long, value_name = "N", requires = "mujoco", value_parser = clap::builder::RangedU64ValueParser::<usize>::new().range(1..=1000))]
    cells_per_link: Option<usize>,
    /// Stop after this many wall-clock seconds [default: run until killed].
    #[arg(long, value_name = "S")]
    duration: Option<f64>,
    /// Cells take firmware updates signed with the secret half of this public key (`skin keygen`), for `skin flash`.
    #[arg(long, value_name = "FILE")]
    update_key: Option<std::path::PathBuf>,
    /// The firmware version the cells run at power-up (with --update-key).
    #[arg(long, default_value_t = 1, requires = "update_key")]
    firmware_version: u32,
    /// Most frames an interface port puts in one datagram (1..=72; 1 sends every frame alone).
    #[arg(long, value_name = "N", default_value_t = Batching::default().max_frames)]
    batch_frames: usize,
    /// A broken sensor, for testing the host's screening: `accel-saturated:CELL`, `accel-stuck:CELL`,
    /// `accel-axis:CELL.AXIS`, `accel-weak:CELL`, `proximity-rail:CELL` or `force-rail:CELL.CHANNEL`
    /// (CELL: the network's cell index, from 0); repeatable.
    #[arg(long, value_name = "KIND:CELL")]
    sensor_fault: Vec<SensorFault>,
    /// Longest a frame waits at its interface port for others, microseconds of robot time.
    #[arg(long, value_name = "US", default_value_t = Batching::default().max_wait_ns / 1000, value_parser = clap::value_parser!(u64).range(0..=1_000_000))]
    batch_us: u64,
}

#[derive(Clone, Copy, ValueEnum)]
enum Pace {
    /// One control period per velocity command: as fast as the host goes.
    Lockstep,
    /// On the wall clock, as a real robot (the skin runs without commands; the arms stop when commands cease).
    Realtime,
}

/// How often the main thread looks whether the serving thread ended.
const WATCH: Duration = Duration::from_millis(20);

pub fn run(args: Args) -> Result<ExitCode, Box<dyn std::error::Error>> {
    let duration = args.duration.map(|s| seconds::duration("--duration", s)).transpose()?;
    let pacing = match args.pace {
        Pace::Lockstep => Pacing::Lockstep,
        Pace::Realtime => Pacing::RealTime,
    };
    let update = match &args.update_key {
        Some(path) => {
            let key = skin_host::update::keys::load_public(path)?;
            Some(UpdateSetup { key: *key, version: args.firmware_version })
        }
        None => None,
    };
    // A cell's update reports ride on its sampling pulse: no cell rests.
    let network =
        NetworkConfig { seed: args.seed, update, skip_resting_cells: update.is_none(), ..NetworkConfig::default() };
    let batching = Batching { max_frames: args.batch_frames, max_wait_ns: args.batch_us.saturating_mul(1000) };
    let config = EndpointConfig { robot: args.robot, host: args.host, pacing, batching, network };
    // Served on a thread of its own, watched from here: when it fails or
    // panics, the process ends with its error instead of serving nothing.
    let (seed, patches, faults) = (args.seed, args.patches, args.sensor_fault);
    let mujoco = match (args.mujoco, args.cells_per_link) {
        (Some(None), Some(_)) => {
            return Err("--cells-per-link lays a skin on a --mujoco FILE; the built-in robot wears its own".into())
        }
        (Some(file), cells) => Some(file.map(|path| SimArgs::mujoco_patches(path, cells.unwrap_or(4), seed))),
        (None, _) => None,
    };
    let what = if mujoco.is_some() { "the MuJoCo robot" } else { "the simulated robot" };
    let engine = if mujoco.is_some() { "MuJoCo" } else { "kinematics" };
    let endpoint = Running::spawn(move || {
        let mut endpoint = match mujoco {
            // Built on the serving thread, which owns the world; an unusable
            // model is a bad --mujoco value.
            Some(Some(sim)) => Endpoint::wired(sim.world().map_err(|e| NetworkError::Flag(e.to_string()))?, config),
            Some(None) => built_in_mujoco(seed, config),
            None if patches => Endpoint::patches(seed, config),
            None => Endpoint::hrp2(seed, config),
        }?;
        faults.into_iter().try_for_each(|f| endpoint.break_sensor(f))?;
        Ok(endpoint)
    })?;
    let ports: Vec<String> = endpoint.interfaces.iter().map(ToString::to_string).collect();
    // Announced on stdout, so a script can wait for it.
    writeln!(
        std::io::stdout().lock(),
        "serving {what} on {} ({:?}); interface ports {} send to {}",
        endpoint.robot,
        pacing,
        ports.join(", "),
        args.host
    )?;
    let started = Instant::now();
    let deadline = duration.map(|d| started + d);
    while !endpoint.is_finished() && deadline.is_none_or(|d| Instant::now() < d) {
        std::thread::sleep(WATCH);
    }
    let served = endpoint.stop()?.served;
    let wall = started.elapsed();
    eprintln!(
        "served {} control periods, {} datagrams up; refused {} commands, rejected {} datagrams, refused {} requests from other hosts",
        served.ticks, served.datagrams_up, served.refused, served.rejected, served.other_hosts
    );
    // Where the time went while serving (every endpoint runs the default
    // 4 ms period): the world (its engine, then its sensor models), the
    // cell network, the sockets, and the host between an answer and its
    // next request.
    let robot_s = served.ticks as f64 * skin_sim::world::WorldConfig::default().tick_s;
    let serving = served.serving_time;
    let parts = served.world_time + served.network_time + served.socket_time + served.host_time;
    eprintln!(
        "time: {robot_s:.1} s of robot time in {:.2} s of serving ({:.1}x real time; {:.1} s of wall time in all): {engine} {:.2} s, sensor models {:.2} s, cell network {:.2} s, sockets {:.2} s, the host {:.2} s (its work and the robot link's way), other {:.2} s",
        serving.as_secs_f64(),
        robot_s / serving.as_secs_f64().max(f64::MIN_POSITIVE),
        wall.as_secs_f64(),
        served.engine_time.as_secs_f64(),
        served.world_time.saturating_sub(served.engine_time).as_secs_f64(),
        served.network_time.as_secs_f64(),
        served.socket_time.as_secs_f64(),
        served.host_time.as_secs_f64(),
        serving.saturating_sub(parts).as_secs_f64(),
    );
    Ok(ExitCode::SUCCESS)
}

/// The built-in robot and its own skin moved by MuJoCo (`--mujoco` without a file).
#[cfg(feature = "mujoco")]
fn built_in_mujoco(seed: u64, config: EndpointConfig) -> Result<Endpoint, NetworkError> {
    Endpoint::hrp2_mujoco(None, seed, config)
}

/// Without MuJoCo in the build, `--mujoco` says how to get it.
#[cfg(not(feature = "mujoco"))]
fn built_in_mujoco(_: u64, _: EndpointConfig) -> Result<Endpoint, NetworkError> {
    Err(NetworkError::Flag(super::world::Error::NoMujoco.to_string()))
}
