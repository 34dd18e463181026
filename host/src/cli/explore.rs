//! `skin explore`: kinematic self-exploration of a simulated robot.
//!
//! The simulator builds the robot (the built-in HRP-2-like upper body, or
//! any URDF) and its skin; the host explores it through the `Robot` trait
//! and the sample stream only. Ground truth is read afterwards, for the
//! `truth` section alone.

use std::io::Write;
use std::process::ExitCode;
use std::time::Instant;

use super::structure_args::StructureArgs;
use super::world::SimArgs;
use clap::ValueEnum;
use indicatif::{ProgressBar, ProgressStyle};
use serde_json::{json, Value};
use skin_host::explore::check::{check, TruthReport};
use skin_host::explore::smm::Evaluation;
use skin_host::explore::{explore, Basis, Exploration, ExploreConfig, ExploreError, SmmConfig, StructureConfig};
use skin_host::robot::SimRobot;

/// The exploration the paper timed on HRP-2, for comparison.
const PAPER_STRUCTURE_S: f64 = 70.0;

/// Arguments of `skin explore`.
#[derive(clap::Args)]
pub struct Args {
    #[command(flatten)]
    sim: SimArgs,
    /// The paper's structural timing (0.5 s settling, 1.0 s averaging, two runs) instead of the fast default.
    #[arg(long)]
    paper: bool,
    #[command(flatten)]
    structure: StructureArgs,
    /// How sensory-motor weights are read from the pattern's accelerations.
    #[arg(long, value_enum, default_value_t = SmmEvaluation::Regression)]
    smm: SmmEvaluation,
    /// One JSON object on stdout instead of the human summary.
    #[arg(long)]
    json: bool,
}

#[derive(Clone, Copy, ValueEnum)]
enum SmmEvaluation {
    /// Equations (10)-(12) of the paper: peak-to-peak amplitude shares.
    Amplitudes,
    /// Least squares on the DoF's motion: the tangential term alone.
    Regression,
}

pub fn run(args: Args) -> Result<ExitCode, Box<dyn std::error::Error>> {
    let structure =
        args.structure.apply(if args.paper { StructureConfig::paper() } else { StructureConfig::default() })?;
    let world = args.sim.world()?;
    super::world::warn_clearance(&world, args.structure.declared_m());
    let name = world.robot().name().to_owned();
    let mut rig = SimRobot::new(world);
    let evaluation = match args.smm {
        SmmEvaluation::Amplitudes => Evaluation::Amplitudes,
        SmmEvaluation::Regression => Evaluation::Regression,
    };
    let cfg =
        ExploreConfig { structure, smm: SmmConfig { evaluation, ..SmmConfig::default() }, ..ExploreConfig::default() };

    let bar = ProgressBar::new(0).with_style(
        ProgressStyle::with_template("{msg} [{bar:30}] {pos}/{len} DoF measurements")
            .expect("a valid template")
            .progress_chars("=> "),
    );
    bar.set_message("exploring");
    let wall = Instant::now();
    let result = explore(&mut rig, &cfg, &mut |p| {
        bar.set_length(p.total as u64);
        bar.set_position(p.done as u64);
    });
    let wall_time_s = wall.elapsed().as_secs_f64();
    bar.finish_and_clear();

    match result {
        Ok(found) => {
            let truth = check(&found, rig.world());
            let speed = Speed::of(rig.world(), found.exploration_time_s(), wall_time_s);
            let text = if args.json {
                let mut report = report(&name, &found, &truth, wall_time_s);
                report["mujoco"] = super::world::mujoco_json(rig.world());
                report["speed"] = speed.json();
                report.to_string()
            } else {
                summary(&name, &found, &truth, &speed)
            };
            write_stdout(&text)?;
            Ok(ExitCode::SUCCESS)
        }
        Err(e) => {
            if args.json {
                let dofs: Vec<String> = rig.world().robot().dofs().iter().map(|d| d.name.clone()).collect();
                let links: Value =
                    rig.world().skin().cells().iter().map(|c| (c.id.0.to_string(), json!(c.link))).collect();
                let undecided: Vec<Value> = match &e {
                    ExploreError::Undecided(entries) => {
                        entries.iter().map(|u| json!({"cell": u.cell.0, "dof": u.dof, "reason": u.reason})).collect()
                    }
                    _ => Vec::new(),
                };
                println!(
                    "{:#}",
                    json!({"robot": name, "dofs": dofs, "error": e.to_string(), "undecided": undecided, "truth": {"cell_links": links}})
                );
                Ok(ExitCode::FAILURE)
            } else {
                Err(explain(e).into())
            }
        }
    }
}

/// The failure with a hint when it is the skin rather than the method.
fn explain(e: ExploreError) -> String {
    match e {
        ExploreError::NotATree(_) | ExploreError::Undecided(_) => {
            format!(
                "{e}\n(the skin decides what can be learned: every body part needs a cell, every DoF must move one)"
            )
        }
        other => other.to_string(),
    }
}

fn report(name: &str, found: &Exploration, truth: &TruthReport, wall_time_s: f64) -> Value {
    let tree = &found.tree;
    let names = |dofs: &[usize]| dofs.iter().map(|&d| found.dof_names[d].clone()).collect::<Vec<_>>();
    json!({
        "robot": name,
        "dofs": found.dof_names,
        "cells": found.cells.len(),
        "exploration_time_s": found.exploration_time_s(),
        "structure_time_s": found.structure_time_s,
        "smm_time_s": found.smm_time_s,
        "wall_time_s": wall_time_s,
        "body_parts": tree.body_parts().iter().enumerate().map(|(id, p)| json!({
            "id": id,
            "cells": p.cells.iter().map(|c| c.0).collect::<Vec<_>>(),
        })).collect::<Vec<_>>(),
        "root_body_part": tree.root(),
        "joints": tree.joints().iter().enumerate().map(|(id, j)| json!({
            "id": id,
            "dofs": names(&j.dofs),
            "parent_body_part": j.parent,
            "child_body_part": j.child,
        })).collect::<Vec<_>>(),
        "dof_kinds": found.dof_kinds.iter().map(|k| format!("{k:?}").to_lowercase()).collect::<Vec<_>>(),
        "postures": found.postures,
        "evidence": evidence(found),
        "leaves": tree.leaves(),
        "inner_nodes": tree.inner_nodes(),
        "limbs": tree.limbs(),
        "warnings": found.warnings,
        "assumed": found.assumed,
        "levers": levers(found),
        "truth": {
            "cell_links": truth.cell_links.iter().map(|(id, l)| (id.to_string(), json!(l))).collect::<serde_json::Map<_, _>>(),
            "tree_correct": truth.tree_correct,
            "wrong_entries": truth.wrong_entries,
            "smm_mean_abs_error": truth.smm_mean_abs_error,
            "smm_mean_abs_error_moved": truth.smm_mean_abs_error_moved,
        },
    })
}

/// How many activity entries each kind of evidence decided.
fn evidence(found: &Exploration) -> Value {
    let (mut by_static, mut dynamic, mut tree, mut clearance) = (0, 0, 0, 0);
    for u in 0..found.activity.cells() {
        for d in 0..found.activity.dofs() {
            match found.activity.basis(u, d) {
                Some(Basis::Static { .. }) => by_static += 1,
                Some(Basis::Dynamic { .. }) => dynamic += 1,
                Some(Basis::Tree) => tree += 1,
                Some(Basis::Clearance) => clearance += 1,
                None => {}
            }
        }
    }
    json!({"static": by_static, "dynamic": dynamic, "tree": tree, "clearance": clearance})
}

/// What the evidence could see at every entry: the smallest lever it
/// would have decided as a movement, m (rows: cells, columns: DoFs; null
/// where the motion saturated), and its largest over the entries near an
/// axis, where gravity did not tell.
pub(super) fn levers(found: &Exploration) -> Value {
    json!({
        "seen_m": found.levers.rows(),
        "near_axis_entries": found.levers.near_axis_entries(),
        "smallest_decided_m": found.levers.smallest_decided_m(),
    })
}

/// The line of the human summary on the levers the evidence decided.
pub(super) fn levers_line(found: &Exploration) -> Option<String> {
    let smallest = found.levers.smallest_decided_m()?;
    Some(format!(
        "levers: at the {} entries near an axis where gravity did not tell, evidence decides any lever of {:.2} mm or more{}",
        found.levers.near_axis_entries(),
        smallest * 1e3,
        if found.assumed.is_empty() { "" } else { "; below it, the entries assumed rest on the clearance" }
    ))
}

/// Writes `text` and a newline to stdout; a reader that went away (a
/// closed pipe) is not an error.
fn write_stdout(text: &str) -> std::io::Result<()> {
    match writeln!(std::io::stdout().lock(), "{text}") {
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => Ok(()),
        other => other,
    }
}

/// How fast the run went against robot time, and where its wall time went:
/// the world's engine (the built-in kinematics or MuJoCo), its sensor
/// models, and the host (the exploration itself).
struct Speed {
    robot_s: f64,
    wall_s: f64,
    engine: &'static str,
    engine_s: f64,
    sensor_models_s: f64,
}

impl Speed {
    fn of(world: &skin_sim::world::World, robot_s: f64, wall_s: f64) -> Speed {
        let (engine, step) = (world.engine_time(), world.step_time());
        Speed {
            robot_s,
            wall_s,
            engine: super::world::engine_name(world),
            engine_s: engine.as_secs_f64(),
            sensor_models_s: step.saturating_sub(engine).as_secs_f64(),
        }
    }

    fn host_s(&self) -> f64 {
        (self.wall_s - self.engine_s - self.sensor_models_s).max(0.0)
    }

    fn real_time(&self) -> f64 {
        self.robot_s / self.wall_s.max(f64::MIN_POSITIVE)
    }

    fn json(&self) -> Value {
        json!({
            "real_time_factor": self.real_time(),
            "engine": self.engine,
            "engine_s": self.engine_s,
            "sensor_models_s": self.sensor_models_s,
            "host_s": self.host_s(),
        })
    }

    fn line(&self) -> String {
        format!(
            "wall time {:.2} s, {:.1}x real time ({} {:.2} s, sensor models {:.2} s, host {:.2} s)",
            self.wall_s,
            self.real_time(),
            self.engine,
            self.engine_s,
            self.sensor_models_s,
            self.host_s()
        )
    }
}

fn summary(name: &str, found: &Exploration, truth: &TruthReport, speed: &Speed) -> String {
    let mut s = format!("robot {name}: {} DoFs, {} cells\n\n", found.dof_names.len(), found.cells.len());
    s += &found.tree.draw();
    let limbs: Vec<String> = found.tree.limbs().iter().map(|l| format!("{l:?}")).collect();
    s += &format!("\nlimbs (joints): {}\n", limbs.join(" "));
    s += "\nmerged activity matrix, sorted strictly lower triangular (rows: body parts, columns: joints):\n";
    for (part, row) in found.tree.lower_triangular().iter().enumerate() {
        let marks: String = row.iter().map(|&m| if m { '1' } else { '.' }).collect();
        s += &format!("{part:>4} {marks}\n");
    }
    s += "\n";
    let tilted = found.postures.len() - 1;
    if tilted > 0 {
        s += &format!("postures chosen to tilt gravity-aligned axes: {tilted}\n");
    }
    s += &format!(
        "robot time: structure {:.1} s (the paper: about {PAPER_STRUCTURE_S:.0} s) + sensory-motor map {:.1} s = {:.1} s; {}\n",
        found.structure_time_s,
        found.smm_time_s,
        found.exploration_time_s(),
        speed.line()
    );
    s += &format!(
        "truth: tree {}, {} wrong activity entries, sensory-motor map mean |w - w_true| {:.3} ({:.3} where the DoF moves the cell)",
        if truth.tree_correct { "correct" } else { "WRONG" },
        truth.wrong_entries,
        truth.smm_mean_abs_error,
        truth.smm_mean_abs_error_moved
    );
    if let Some(line) = levers_line(found) {
        s += &format!("\n{line}");
    }
    for w in &found.warnings {
        s += &format!("\nwarning: {w}");
    }
    s
}
