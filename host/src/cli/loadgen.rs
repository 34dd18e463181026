//! `skin loadgen`: a simulated skin that sends real interface datagrams to
//! a host, to measure the interface or to watch `skin monitor` without
//! hardware.

use std::net::SocketAddr;
use std::process::ExitCode;
use std::time::{Duration, Instant};

use indicatif::{ProgressBar, ProgressStyle};
use skin_host::config::Traffic;
use skin_host::interface::loadgen::{LoadGen, LoadSpec, Pace};

use super::seconds;

/// Arguments of `skin loadgen`.
#[derive(clap::Args)]
pub struct Args {
    /// Where the host listens.
    #[arg(long, value_name = "ADDR", default_value = "127.0.0.1:7700")]
    to: SocketAddr,
    /// Number of cells (IDs 1..=N), split evenly over the ports.
    #[arg(long, default_value_t = 400)]
    cells: u16,
    /// Number of interface ports (0..P), each its own socket and patch.
    #[arg(long, default_value_t = 5)]
    ports: u8,
    /// Sampling rate of every cell in Hz.
    #[arg(long, default_value_t = 250.0)]
    rate: f64,
    /// Each port sends what it gathered every this many microseconds (0: one datagram per frame).
    #[arg(long, default_value_t = 1000, value_parser = clap::value_parser!(u64).range(0..=1_000_000))]
    flush_us: u64,
    /// Clock-driven (every sample) or event-driven (send-on-delta and level events).
    #[arg(long, value_enum, default_value_t = Traffic::Clock)]
    traffic: Traffic,
    /// A fingertip circling, pressing and lifting over the first patch.
    #[arg(long)]
    touch: bool,
    /// Seconds to send.
    #[arg(long, default_value_t = 10.0)]
    duration: f64,
    /// Send as fast as possible instead of on the sampling clock.
    #[arg(long)]
    flat_out: bool,
    /// Period of every cell's neighbour-table heartbeat in seconds.
    #[arg(long, default_value_t = 4.0)]
    report_period: f64,
    /// Seed of the sensor noise.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// One JSON object on stdout instead of the human summary.
    #[arg(long)]
    json: bool,
}

/// Why `skin loadgen` could not run.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// A flag value out of range.
    #[error("{0}")]
    Flag(String),
    /// The sockets could not be opened.
    #[error("cannot open the generator's sockets toward {to}: {source}")]
    Socket {
        /// The host address.
        to: SocketAddr,
        /// What the OS said.
        source: std::io::Error,
    },
}

pub fn run(args: Args) -> Result<ExitCode, Box<dyn std::error::Error>> {
    let duration = seconds::duration("--duration", args.duration)?;
    let spec = LoadSpec {
        cells: args.cells,
        ports: args.ports,
        rate_hz: args.rate,
        flush_us: args.flush_us,
        traffic: args.traffic,
        touch: args.touch,
        report_period_s: args.report_period,
        seed: args.seed,
    };
    spec.validate().map_err(Error::Flag)?;
    let mut generator = LoadGen::new(spec.clone(), args.to).map_err(|source| Error::Socket { to: args.to, source })?;
    let pace = if args.flat_out { Pace::FlatOut } else { Pace::RealTime };
    let bar = ProgressBar::new((args.duration * 1000.0) as u64)
        .with_style(ProgressStyle::with_template("{bar:40} {msg}").unwrap_or_else(|_| ProgressStyle::default_bar()));
    if args.json {
        bar.set_draw_target(indicatif::ProgressDrawTarget::hidden());
    }
    let mut last_draw = Instant::now();
    let report = generator.run(duration, pace, |r| {
        if last_draw.elapsed() >= Duration::from_millis(100) {
            last_draw = Instant::now();
            let done_s = if args.flat_out { r.wall_time_s } else { r.skin_time_s };
            bar.set_position((done_s * 1000.0) as u64);
            bar.set_message(format!("{} frames, {} datagrams", r.frames, r.datagrams));
        }
    });
    bar.finish_and_clear();
    if args.json {
        let json = serde_json::json!({
            "to": args.to.to_string(),
            "cells": spec.cells,
            "ports": spec.ports,
            "rate_hz": spec.rate_hz,
            "flush_us": spec.flush_us,
            "report": report,
            "frames_per_s": report.frames as f64 / report.wall_time_s.max(1e-9),
        });
        println!("{}", serde_json::to_string_pretty(&json)?);
    } else {
        println!(
            "sent {} frames in {} datagrams to {} over {:.2} s ({:.0} frames/s) from {} cells on {} ports; \
             {} send errors, {} configuration writes applied, at worst {} us behind the sampling clock",
            report.frames,
            report.datagrams,
            args.to,
            report.wall_time_s,
            report.frames as f64 / report.wall_time_s.max(1e-9),
            spec.cells,
            spec.ports,
            report.send_errors,
            report.writes_applied,
            report.behind_max_us
        );
    }
    Ok(ExitCode::SUCCESS)
}
