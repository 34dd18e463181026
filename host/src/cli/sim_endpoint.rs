//! `skin sim-endpoint`: the built-in simulated HRP-2-like robot and its
//! skin served on loopback UDP, for `skin run` (or `skin monitor`) in
//! another terminal: the robot on the robot link, each of the five
//! interface ports sending to the host's interface address.

use std::io::Write;
use std::net::SocketAddr;
use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Duration;

use clap::ValueEnum;
use skin_sim::endpoint::{Endpoint, EndpointConfig, Pacing};
use skin_sim::network::NetworkConfig;

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
    /// Stop after this many wall-clock seconds [default: run until killed].
    #[arg(long, value_name = "S")]
    duration: Option<f64>,
}

#[derive(Clone, Copy, ValueEnum)]
enum Pace {
    /// One control period per velocity command: as fast as the host goes.
    Lockstep,
    /// On the wall clock, as a real robot (the skin runs without commands; the arms stop when commands cease).
    Realtime,
}

/// Why `skin sim-endpoint` could not run.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// A negative or non-finite --duration.
    #[error("--duration must be a number of seconds > 0, not {0}")]
    Duration(f64),
}

pub fn run(args: Args) -> Result<ExitCode, Box<dyn std::error::Error>> {
    if let Some(d) = args.duration {
        if !(d.is_finite() && d > 0.0) {
            return Err(Error::Duration(d).into());
        }
    }
    let pacing = match args.pace {
        Pace::Lockstep => Pacing::Lockstep,
        Pace::Realtime => Pacing::RealTime,
    };
    let network = NetworkConfig { seed: args.seed, ..NetworkConfig::default() };
    let mut endpoint =
        Endpoint::hrp2(args.seed, EndpointConfig { robot: args.robot, host: args.host, pacing, network })?;
    let ports: Vec<String> = endpoint.interface_addrs()?.iter().map(ToString::to_string).collect();
    // Announced on stdout, so a script can wait for it.
    writeln!(
        std::io::stdout().lock(),
        "serving the simulated robot on {} ({:?}); interface ports {} send to {}",
        endpoint.robot_addr()?,
        pacing,
        ports.join(", "),
        args.host
    )?;
    let stop = Arc::new(AtomicBool::new(false));
    if let Some(d) = args.duration {
        let stop = stop.clone();
        std::thread::spawn(move || {
            std::thread::sleep(Duration::from_secs_f64(d));
            stop.store(true, Ordering::Relaxed);
        });
    }
    let served = endpoint.serve(&stop)?;
    eprintln!(
        "served {} control periods, {} datagrams up; refused {} commands, rejected {} datagrams",
        served.ticks, served.datagrams_up, served.refused, served.rejected
    );
    Ok(ExitCode::SUCCESS)
}
