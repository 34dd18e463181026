//! `skin grasp`: the simulated grasping experiment of section 6.5.
//!
//! The grasping part of `skin demo` on its own, without the report: the
//! experiment's robot and skin served on loopback UDP organize and explore
//! themselves, a simulated person teaches the key poses by proximity
//! guidance, then the robot grasps objects of Figure 16 (or nothing) with
//! one parameter set, each launched and released by a pat on the
//! shoulder, going home between grasps.

use std::io::Write;
use std::path::PathBuf;
use std::process::ExitCode;

use skin_host::control::grasp::State;
use skin_host::control::params::Params;
use skin_host::grasping::{GraspRun, Taught};
use skin_host::report::check_folder;
use skin_host::report::traces::write_traces;

use super::demo::{serve_experiment, teach_and_grasp};
use super::lab::LabArgs;
use super::{job, objects};

/// Arguments of `skin grasp`.
#[derive(clap::Args)]
pub struct Args {
    #[command(flatten)]
    objects: objects::ObjectArgs,
    /// Grasp parameters (TOML, like host/config/grasp.toml) instead of Table 4.
    #[arg(long, value_name = "FILE")]
    config: Option<PathBuf>,
    /// Seed of everything random: cell IDs, sensor errors, noise, sway.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Write each grasp's force and proximity trace (CSV) and plot (SVG) into this directory.
    #[arg(long, value_name = "DIR")]
    traces: Option<PathBuf>,
    /// One JSON array on stdout, one object per grasp, instead of the human summary.
    #[arg(long)]
    json: bool,
    #[command(flatten)]
    lab: LabArgs,
}

pub fn run(args: Args) -> Result<ExitCode, Box<dyn std::error::Error>> {
    let params = match &args.config {
        Some(path) => Params::read(path)?,
        None => Params::default(),
    };
    let chosen = args.objects.chosen()?;
    if let Some(dir) = &args.traces {
        check_folder(dir)?;
    }
    let (mut endpoint, mut remote, steps) = serve_experiment(args.seed, &args.lab)?;
    let found = job::run(&mut remote, &steps)?;
    let exploration_s = found.exploration.exploration_time_s();
    let (taught, runs) = teach_and_grasp(&mut remote, &mut endpoint, found.exploration.smm, &params, &chosen)?;
    endpoint.stop()?;
    let written = match &args.traces {
        Some(dir) => write_traces(dir, &runs)?,
        None => Vec::new(),
    };
    let text =
        if args.json { serde_json::to_string_pretty(&runs)? } else { summary(exploration_s, &taught, &runs, &written) };
    match writeln!(std::io::stdout().lock(), "{text}") {
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => {}
        other => other?,
    }
    // An object not held, or nothing that was not cancelled, is a failure.
    let as_expected =
        runs.iter().all(|r| if r.object == "none" { r.controller_state == State::Cancelled } else { r.succeeded });
    Ok(if as_expected { ExitCode::SUCCESS } else { ExitCode::FAILURE })
}

fn summary(exploration_s: f64, taught: &Taught, runs: &[GraspRun], written: &[PathBuf]) -> String {
    let mut s = format!("self-exploration: {exploration_s:.1} s robot time\n");
    for l in &taught.lessons {
        s += &format!(
            "taught \"{}\" by proximity in {:.1} s (cells within {:.1} / {:.1} cm of the picture, right / left)\n",
            l.pose,
            l.time_s,
            l.error_m[0] * 100.0,
            l.error_m[1] * 100.0
        );
    }
    s += &format!(
        "\n{:<14} {:<20} {:<10} {:>7} {:>7} {:>7} {:>7} {:>5}\n",
        "object", "placement", "verdict", "ctrl", "time s", "grip N", "pats N", "pain"
    );
    for r in runs {
        let verdict = match (r.object.as_str(), r.reason) {
            (_, None) => "held",
            ("none", Some(_)) if r.controller_state == State::Cancelled => "cancelled",
            (_, Some(why)) => why.name(),
        };
        let placement = r
            .placement
            .map_or(String::new(), |p| format!("{:+.3},{:+.3} {:+.2}", p.offset_m[0], p.offset_m[1], p.yaw_rad));
        s += &format!(
            "{:<14} {:<20} {:<10} {:>7} {:>7.1} {:>7.2} {:>7.2} {:>5}\n",
            r.object,
            placement,
            verdict,
            r.controller_state.name(),
            r.time_s,
            r.grip_force_max_n,
            r.hand_force_max_n,
            r.pain_events
        );
    }
    for r in runs {
        if let (Some(why), Some(failed)) = (r.reason, r.failed) {
            s += &format!("{}: {} {failed}\n", r.object, why.name());
        }
    }
    for f in written {
        s += &format!("wrote {}\n", f.display());
    }
    s.trim_end().to_owned()
}
