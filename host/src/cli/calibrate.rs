//! `skin calibrate`: every cell's pose on its link, in simulation.
//!
//! The simulator builds the robot and its skin; the host explores it and
//! then calibrates the skin on its own copy of the description, through
//! the `Robot` trait and the sample stream only. Ground truth is read
//! afterwards, for the `truth` section alone.

use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;

use indicatif::{ProgressBar, ProgressStyle};
use nalgebra::{Isometry3, Point3};
use serde_json::{json, Value};
use skin_host::calibrate::check::{check, CalibrationTruth};
#[cfg(feature = "mujoco")]
use skin_host::calibrate::export::skin_frames;
use skin_host::calibrate::export::{picture, skin_toml, urdf_with_skin};
use skin_host::calibrate::neighbours::{resolve, NeighbourConfig, Resolved};
use skin_host::calibrate::{calibrate, CalibrateConfig, Calibration};
use skin_host::explore::{explore, Exploration, ExploreConfig, Progress, StructureConfig};
use skin_host::report::check_folder;
use skin_host::report::figures::{skin_views, SkinViews};
use skin_host::robot::SimRobot;
use skin_model::robot::kinematics::{self, BodyState, DofMotion};
use skin_model::robot::Robot as Model;
use skin_sim::world::World;

use super::cells_json::cells_json;
use super::structure_args::StructureArgs;
use super::world::{Base, SimArgs};

/// Arguments of `skin calibrate`.
#[derive(clap::Args)]
pub struct Args {
    #[command(flatten)]
    sim: SimArgs,
    /// Still postures for the accelerometer frames, the start included.
    #[arg(long, value_name = "N", default_value_t = CalibrateConfig::default().postures, value_parser = clap::builder::RangedU64ValueParser::<usize>::new().range(2..=1000))]
    postures: usize,
    /// Excitation periods per DoF for the positions (1 Hz each).
    #[arg(long, value_name = "N", default_value_t = CalibrateConfig::default().excitation_periods, value_parser = clap::value_parser!(u32).range(1..=1000))]
    periods: u32,
    #[command(flatten)]
    structure: StructureArgs,
    /// Folder for skin.toml, robot_with_skin.urdf (or, with --mujoco, robot_with_skin.xml), calibration.json and calibration.svg.
    #[arg(long, value_name = "DIR")]
    out: Option<PathBuf>,
    /// One JSON object on stdout instead of the human summary.
    #[arg(long)]
    json: bool,
}

/// Why `skin calibrate` could not run.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// The base lies: the calibration takes the description's root upright.
    #[error(
        "skin calibrate takes the robot's root upright (z up, as the description has it): use --base standing or rigid"
    )]
    Lying,
}

pub fn run(args: Args) -> Result<ExitCode, Box<dyn std::error::Error>> {
    if args.sim.base == Base::Lying {
        return Err(Error::Lying.into());
    }
    let structure = args.structure.apply(StructureConfig::default())?;
    let cfg = CalibrateConfig {
        postures: args.postures,
        excitation_periods: args.periods,
        seed: args.sim.seed,
        ..CalibrateConfig::default()
    };
    cfg.check()?;
    // The user's description, to write again wearing the calibrated skin.
    let description = match &args.sim.mujoco {
        Some(path) => Description::Mujoco(path.clone()),
        None => Description::Urdf(args.sim.urdf_text()?),
    };
    // The host's own copy of the description, as on a real robot.
    let model = args.sim.robot()?;
    let world = args.sim.world()?;
    super::world::warn_clearance(&world, args.structure.declared_m());
    // Only once every input is accepted: a refused one leaves no folder behind.
    if let Some(dir) = &args.out {
        check_folder(dir)?;
    }
    let name = world.robot().name().to_owned();
    let mut rig = SimRobot::new(world);

    let bar = ProgressBar::new(0).with_style(
        ProgressStyle::with_template("{msg} [{bar:30}] {pos}/{len}").expect("a valid template").progress_chars("=> "),
    );
    let show = |msg: &'static str| {
        let bar = bar.clone();
        move |p: Progress| {
            bar.set_message(msg);
            bar.set_length(p.total as u64);
            bar.set_position(p.done as u64);
        }
    };
    let wall = Instant::now();
    let explore_cfg = ExploreConfig { structure, ..ExploreConfig::default() };
    // The simulated skin's neighbour tables (IDs and ports, as its
    // self-organization reports them; none unless laid in patches).
    let tables = rig.world().skin().neighbour_tables();
    let found = explore(&mut rig, &explore_cfg, &mut show("exploring"))?;
    let mut calibration = calibrate(&mut rig, &model, &found, &cfg, &mut show("calibrating"))?;
    let neighbours =
        resolve(&mut calibration.cells, &model, &calibration.description_start, &tables, &NeighbourConfig::default());
    let wall_time_s = wall.elapsed().as_secs_f64();
    bar.finish_and_clear();

    let truth = check(&calibration, rig.world());
    let mut report = report(&name, &calibration, &neighbours, &truth, &found, wall_time_s);
    // The exploration's own verdict, as `skin explore` gives it: a table
    // over many robots then needs one run per robot, not two.
    let explored = skin_host::explore::check::check(&found, rig.world());
    report["exploration_truth"] =
        json!({ "tree_correct": explored.tree_correct, "wrong_entries": explored.wrong_entries });
    report["mujoco"] = super::world::mujoco_json(rig.world());
    if let Some(dir) = &args.out {
        write_files(dir, &description, &model, &calibration, rig.world(), &report)?;
    }
    let text = if args.json {
        format!("{report:#}")
    } else {
        summary(&name, &calibration, &neighbours, &truth, &found, wall_time_s)
    };
    println!("{text}");
    Ok(ExitCode::SUCCESS)
}

fn report(
    name: &str,
    c: &Calibration,
    neighbours: &Resolved,
    truth: &CalibrationTruth,
    found: &Exploration,
    wall_time_s: f64,
) -> Value {
    let cells = cells_json(c);
    let exploration_s = found.exploration_time_s();
    json!({
        "robot": name,
        "dofs": found.dof_names,
        "cells": cells,
        "postures": c.postures,
        "reused_stills": c.reused_stills,
        "excited": c.excited,
        "delays_ms": c.delays_ms,
        "skipped": c.skipped.iter().map(|(d, why)| json!({"dof": d, "reason": why})).collect::<Vec<_>>(),
        "robot_time_s": { "exploration": exploration_s, "calibration": c.robot_time_s, "total": exploration_s + c.robot_time_s },
        "wall_time_s": wall_time_s,
        "warnings": c.warnings,
        "exploration_warnings": found.warnings,
        "assumed": found.assumed,
        "levers": super::explore::levers(found),
        "neighbours": neighbours,
        "truth": truth,
    })
}

fn summary(
    name: &str,
    c: &Calibration,
    n: &Resolved,
    t: &CalibrationTruth,
    found: &Exploration,
    wall_time_s: f64,
) -> String {
    let exploration_s = found.exploration_time_s();
    let full = c.cells.iter().filter(|p| p.unobservable.is_empty()).count();
    let none = c.cells.iter().filter(|p| p.unobservable.len() == 3).count();
    let mut s = format!("robot {name}: {} cells calibrated on its description\n", c.cells.len());
    s += &format!(
        "  moves: {} still postures (and {} still windows of the exploration reused), excitations of {}\n",
        c.postures.len(),
        c.reused_stills,
        if c.excited.is_empty() { "no DoF".to_owned() } else { c.excited.join(", ") }
    );
    for (dof, why) in &c.skipped {
        s += &format!("  not excited: {dof}: {why}\n");
    }
    if let (Some(lo), Some(hi)) =
        (c.delays_ms.iter().copied().reduce(f64::min), c.delays_ms.iter().copied().reduce(f64::max))
    {
        s += &format!("  skin samples behind the joint feedback by {lo:.1} to {hi:.1} ms (found per excitation)\n");
    }
    s += &format!(
        "  positions: {full} in 3D, {} in part (along a lone joint axis unobservable), {none} unobservable (on the fixed base, on a link that only turns about a vertical axis, or on a doubted body)\n",
        c.cells.len() - full - none
    );
    if n.wires + n.ambiguous + n.dropped + n.one_sided > 0 {
        s += &format!(
            "  neighbours: {} cells in 3D with the along-axis part from {} wires (error {:.2} mm mean, {:.2} mm max); {} wires of undecided sign, {} dropped, {} one-sided\n",
            n.cells,
            n.wires,
            t.from_neighbours_m.mean * 1e3,
            t.from_neighbours_m.max * 1e3,
            n.ambiguous,
            n.dropped,
            n.one_sided
        );
    }
    let frames = c.cells.iter().filter(|p| p.orientation_observable).count();
    s += &format!(
        "  frames: {frames} known, {} not (a link gravity always meets the same way)\n",
        c.cells.len() - frames
    );
    s += &format!(
        "  robot time: exploration {exploration_s:.1} s + calibration {:.1} s; wall time {wall_time_s:.2} s\n",
        c.robot_time_s
    );
    if let Some(line) = super::explore::levers_line(found) {
        s += &format!("{line}\n");
    }
    for w in found.warnings.iter().chain(&c.warnings) {
        s += &format!("warning: {w}\n");
    }
    s += &format!(
        "truth: position error mean {:.2} mm, p95 {:.2} mm, max {:.2} mm over {} cells; frame error mean {:.2} deg, p95 {:.2} deg, max {:.2} deg over {} cells; {} on a wrong link, {} confidently wrong",
        t.position_m.mean * 1e3,
        t.position_m.p95 * 1e3,
        t.position_m.max * 1e3,
        t.position_m.cells,
        t.orientation_deg.mean,
        t.orientation_deg.p95,
        t.orientation_deg.max,
        t.orientation_deg.cells,
        t.wrong_link,
        t.overconfident
    );
    s
}

/// The robot's description as the user gave it.
enum Description {
    /// URDF text (the built-in robot's, or `--urdf`'s).
    Urdf(String),
    /// A model file MuJoCo reads (`--mujoco`).
    Mujoco(PathBuf),
}

fn write_files(
    dir: &Path,
    description: &Description,
    model: &Model,
    c: &Calibration,
    world: &World,
    report: &Value,
) -> Result<(), Box<dyn std::error::Error>> {
    let write = |file: &str, text: &str| {
        let path = dir.join(file);
        std::fs::write(&path, text).map_err(|e| format!("cannot write {}: {e}", path.display()))
    };
    write("skin.toml", &skin_toml(model, c))?;
    match description {
        Description::Urdf(urdf) => write("robot_with_skin.urdf", &urdf_with_skin(urdf, model, c)?)?,
        Description::Mujoco(path) => write("robot_with_skin.xml", &mujoco_with_skin(path, model, c)?)?,
    }
    write("calibration.json", &format!("{report:#}"))?;
    // The picture, in the start posture, with the truth beside the estimate.
    let mut picture = picture(model, c, &c.description_start);
    let real = world.skin().cells();
    let zero = vec![0.0; model.dofs().len()];
    let mut states = Vec::new();
    let base = BodyState::at_rest(Isometry3::identity());
    kinematics::forward(model, &base, DofMotion { q: model.home(), qd: &zero, qdd: &zero }, &mut states);
    let truth: Vec<[f64; 3]> = c
        .cells
        .iter()
        .filter_map(|p| real.iter().find(|r| r.id == p.id))
        .map(|r| (states[r.body].pose * Point3::from(r.pose.translation.vector)).coords.into())
        .collect();
    if truth.len() == picture.cells.len() {
        picture.truth = truth;
    }
    let title = "calibrated skin (blue: estimate and its z axis; red ring: truth)";
    let views = SkinViews { title, bones: &picture.bones, cells: &picture.cells, truth: &picture.truth };
    skin_views(&dir.join("calibration.svg"), &views)?;
    Ok(())
}

/// The MuJoCo model at `path` wearing the calibrated cells (MuJoCo parses
/// and writes it); what differs besides the cells is said on stderr.
#[cfg(feature = "mujoco")]
fn mujoco_with_skin(path: &Path, model: &Model, c: &Calibration) -> Result<String, Box<dyn std::error::Error>> {
    let cells: Vec<_> = skin_frames(model, c)
        .into_iter()
        .map(|f| skin_sim::mujoco::CellSite { name: f.name, body: f.link, pose: f.pose })
        .collect();
    let written = skin_sim::mujoco::model_with_skin(path, &cells)?;
    for note in &written.notes {
        eprintln!("robot_with_skin.xml: {note}");
    }
    Ok(written.xml)
}

/// Without MuJoCo in the build, `--mujoco` says how to get it (it is
/// refused before the run already).
#[cfg(not(feature = "mujoco"))]
fn mujoco_with_skin(_: &Path, _: &Model, _: &Calibration) -> Result<String, Box<dyn std::error::Error>> {
    Err(super::world::Error::NoMujoco.into())
}
