//! `skin grasp`: the simulated grasping experiment of section 6.5.
//!
//! Explores the built-in HRP-2-like robot, lets a simulated person teach
//! the key poses by proximity guidance, then grasps objects of Figure 16
//! (or nothing) with one parameter set, each launched and released by a
//! pat on the shoulder.

use std::io::Write;
use std::path::PathBuf;
use std::process::ExitCode;

use indicatif::{ProgressBar, ProgressStyle};
use skin_host::control::grasp::State;
use skin_host::control::params::Params;
use skin_host::grasping::{grasp, learn, objects, write_traces, GraspRun, Taught};

/// Arguments of `skin grasp`.
#[derive(clap::Args)]
pub struct Args {
    /// The object: trash_bin, sponge_rock, moving_box, box_lid, delivery_box, all, or none.
    #[arg(long, default_value = "all")]
    object: String,
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
}

pub fn run(args: Args) -> Result<ExitCode, Box<dyn std::error::Error>> {
    let params = match &args.config {
        Some(path) => Params::read(path)?,
        None => Params::default(),
    };
    let chosen = objects(&args.object)?;
    let bar = ProgressBar::new((4 + chosen.len()) as u64).with_style(
        ProgressStyle::with_template("{msg:40} [{bar:30}] {pos}/{len}")
            .expect("a valid template")
            .progress_chars("=> "),
    );
    let taught = learn(args.seed, &params, &mut |step| {
        bar.set_message(step.to_owned());
        if step.starts_with("teaching") || step.starts_with("self") {
            bar.inc(1);
        }
    })?;
    let mut runs = Vec::new();
    for object in &chosen {
        bar.set_message(format!("grasping {}", object.as_ref().map_or("nothing", |o| o.name)));
        runs.push(grasp(&taught, object.as_ref(), &params)?);
        bar.inc(1);
    }
    bar.finish_and_clear();
    let written = match &args.traces {
        Some(dir) => write_traces(dir, &runs)?,
        None => Vec::new(),
    };
    let text = if args.json { serde_json::to_string_pretty(&runs)? } else { summary(&taught, &runs, &written) };
    match writeln!(std::io::stdout().lock(), "{text}") {
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => {}
        other => other?,
    }
    // An object not grasped, or nothing that was not cancelled, is a failure.
    let as_expected =
        runs.iter().all(|r| if r.object == "none" { r.final_state == State::Cancelled } else { r.succeeded });
    Ok(if as_expected { ExitCode::SUCCESS } else { ExitCode::FAILURE })
}

fn summary(taught: &Taught, runs: &[GraspRun], written: &[PathBuf]) -> String {
    let mut s = format!("self-exploration: {:.1} s robot time\n", taught.exploration_s);
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
        "\n{:<14} {:<10} {:<11} {:>8} {:>12} {:>6}\n",
        "object", "result", "final", "time s", "max force N", "pain"
    );
    for r in runs {
        let result = match (r.object.as_str(), r.succeeded) {
            ("none", _) if r.final_state == State::Cancelled => "cancelled",
            (_, true) => "grasped",
            _ => "FAILED",
        };
        s += &format!(
            "{:<14} {:<10} {:<11} {:>8.1} {:>12.2} {:>6}\n",
            r.object,
            result,
            r.final_state.name(),
            r.time_s,
            r.max_cell_force_n,
            r.pain_events
        );
    }
    for f in written {
        s += &format!("wrote {}\n", f.display());
    }
    s.trim_end().to_owned()
}
