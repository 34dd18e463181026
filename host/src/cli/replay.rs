//! `skin replay`: a recording (`skin run --record`, `skin demo`) fed to
//! the host instead of the network. `--explore` runs the exploration
//! again on the recorded samples and robot states and prints what it
//! learned: the same as the live run that recorded it; `--calibrate
//! ROBOT.urdf` also runs the skin calibration that followed it.

use std::io::Write;
use std::path::PathBuf;
use std::process::ExitCode;

use skin_host::calibrate::export::skin_toml;
use skin_host::calibrate::{calibrate, CalibrateConfig};
use skin_host::explore::{explore, Exploration, ExploreConfig};
use skin_host::recording::{Record, Recording};
use skin_host::replay::Replay;
use skin_host::report::ExplorationSection;
use skin_model::robot::Robot;
use skin_protocol::message::AccelRange;

/// Arguments of `skin replay`.
#[derive(clap::Args)]
pub struct Args {
    /// The MCAP recording.
    #[arg(value_name = "FILE.mcap")]
    file: PathBuf,
    /// Run the recorded exploration again and print its result.
    #[arg(long)]
    explore: bool,
    /// Run the recorded exploration and the skin calibration that followed it (`skin run --urdf`)
    /// again, on this description, and print the calibrated skin description (TOML) as the run wrote it.
    #[arg(long, value_name = "ROBOT.urdf", conflicts_with = "explore")]
    calibrate: Option<PathBuf>,
    /// Print JSON instead of the human summary (with --explore: the report's exploration section;
    /// with --calibrate: every cell's pose).
    #[arg(long)]
    json: bool,
}

/// Why the replay stopped.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// The recorded accelerometer range is none the cells have.
    #[error("the recording's accelerometer range of {0} g is none the cells have (2, 8, 16)")]
    Range(u8),
}

pub fn run(args: Args) -> Result<ExitCode, Box<dyn std::error::Error>> {
    let recording = Recording::open(&args.file)?;
    let text = if let Some(urdf) = &args.calibrate {
        let model = Robot::from_urdf_file(urdf)?;
        let (mut replay, range, exploration) = explore_again(recording)?;
        let cfg = CalibrateConfig { range, ..CalibrateConfig::default() };
        let c = calibrate(&mut replay, &model, &exploration, &cfg, &mut |_| {})?;
        if args.json {
            serde_json::to_string_pretty(&super::cells_json::cells_json(&c))?
        } else {
            skin_toml(&model, &c)
        }
    } else if args.explore {
        let (replay, _, exploration) = explore_again(recording)?;
        let section = ExplorationSection::new(&exploration);
        if args.json {
            serde_json::to_string_pretty(&section)?
        } else {
            format!(
                "replayed exploration of {} cells and {} DoFs: {} body parts, {} joints, {} limbs ({} datagrams accepted)",
                section.cells.len(),
                section.dofs.len(),
                section.body_parts.len(),
                section.joints.len(),
                section.limbs.len(),
                replay.ingest().counters().datagrams.accepted
            )
        }
    } else {
        let count = |f: fn(&Record) -> bool| recording.records.iter().filter(|r| f(r)).count();
        let datagrams = count(|r| matches!(r, Record::Datagram { .. }));
        let commands = count(|r| matches!(r, Record::Command(_)));
        let explored = count(|r| matches!(r, Record::ExploreStart(_))) > 0;
        if args.json {
            serde_json::json!({ "datagrams": datagrams, "commands": commands, "exploration": explored }).to_string()
        } else {
            format!(
                "{}: {datagrams} interface datagrams, {commands} robot commands, {} (replay it with --explore)",
                args.file.display(),
                if explored { "an exploration" } else { "no exploration" }
            )
        }
    };
    match writeln!(std::io::stdout().lock(), "{text}") {
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => {}
        other => other?,
    }
    Ok(ExitCode::SUCCESS)
}

/// The recorded exploration run again: the replay (to go on with), the
/// accelerometer range it was recorded in, and what it learned.
fn explore_again(recording: Recording) -> Result<(Replay, AccelRange, Exploration), Box<dyn std::error::Error>> {
    let mut replay = Replay::explore(recording)?;
    let start = replay.start().clone();
    let range = start.accel_range().ok_or(Error::Range(start.accel_range_g))?;
    let exploration = explore(&mut replay, &ExploreConfig { range, ..ExploreConfig::default() }, &mut |_| {})?;
    Ok((replay, range, exploration))
}
