//! Automatic kinematic self-exploration (section 4).
//!
//! The robot learns its own body from the accelerometers in its skin, with
//! no model: it steps each DoF and watches which cells move ([`structure`],
//! [`activity`]),
//! merges cells into body parts and DoFs into joints ([`merge`]), finds the
//! kinematic tree ([`tree`]) and then explores how each DoF moves each cell
//! along its normal ([`smm`]). Everything goes through the [`Robot`] and
//! [`SampleSource`] traits; `check` (the `sim` feature) compares a result
//! with the simulator's ground truth and is never used by the exploration
//! itself.

pub mod activity;
#[cfg(feature = "sim")]
pub mod check;
mod fit;
pub mod lowpass;
pub mod merge;
mod rocking;
pub(crate) mod session;
pub mod smm;
pub mod structure;
pub mod tree;

use skin_protocol::message::AccelRange;
use skin_protocol::Address;

pub use activity::{Activity, ActivityMatrix, Basis, Doubt};
pub use smm::{SensoryMotorMap, SmmConfig, Tile};
pub use structure::{Clearance, StructureConfig};
pub use tree::{KinematicTree, TreeError};

use crate::robot::{DofKind, Robot, RobotError, SampleSource};
use session::Session;

/// Everything the exploration needs to know.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ExploreConfig {
    /// The structural exploration.
    pub structure: StructureConfig,
    /// The sensory-motor exploration.
    pub smm: SmmConfig,
    /// The accelerometer range the cells are configured to.
    pub range: AccelRange,
}

impl Default for ExploreConfig {
    fn default() -> Self {
        ExploreConfig { structure: StructureConfig::default(), smm: SmmConfig::default(), range: AccelRange::G2 }
    }
}

/// Why the exploration failed.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ExploreError {
    /// No cell sent a sample.
    #[error("no skin cell sent a sample: is the skin connected and configured?")]
    NoCells,
    /// The robot or skin failed.
    #[error(transparent)]
    Robot(#[from] RobotError),
    /// A cell went silent during a measurement.
    #[error("{0} sent (almost) no samples during a measuring window")]
    Silent(Address),
    /// A DoF did not follow its commands in either direction.
    #[error("DoF {0} does not move when commanded (limits, brakes or wiring?)")]
    Stuck(String),
    /// A move to a pose stopped short of it.
    #[error("DoF {dof} stopped {short:.3} short of the pose it was sent to (blocked by a collision, a load beyond its force, or a limit?)")]
    Blocked {
        /// The DoF furthest from the pose.
        dof: String,
        /// How far it is from the pose, rad (m for a slide).
        short: f64,
    },
    /// Entries of the activity matrix that no reachable posture decided
    /// within the robot-time budget, each with the reason.
    #[error("{} activity entries stay undecided: {}", .0.len(), describe(.0))]
    Undecided(Vec<Undecided>),
    /// The activity matrix is not a kinematic tree.
    #[error("the activity matrix is not a kinematic tree: {0}")]
    NotATree(#[from] TreeError),
    /// A configuration value out of range.
    #[error("bad exploration setting: {0}")]
    Config(String),
}

/// An entry of the activity matrix that no reachable posture decided.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Undecided {
    /// The cell.
    pub cell: Address,
    /// The DoF's name.
    pub dof: String,
    /// Why, in words: what was tried and what the evidence allows.
    pub reason: String,
}

/// The undecided entries grouped by DoF and reason, cells listed.
fn describe(undecided: &[Undecided]) -> String {
    let mut groups: Vec<(&str, &str, Vec<String>)> = Vec::new();
    for e in undecided {
        match groups.iter_mut().find(|(d, r, _)| *d == e.dof && *r == e.reason) {
            Some((_, _, cells)) => cells.push(e.cell.0.to_string()),
            None => groups.push((&e.dof, &e.reason, vec![e.cell.0.to_string()])),
        }
    }
    groups
        .iter()
        .map(|(dof, reason, cells)| {
            let shown = cells.iter().take(12).cloned().collect::<Vec<_>>().join(", ");
            let more = if cells.len() > 12 { format!(" and {} more", cells.len() - 12) } else { String::new() };
            format!("cells {shown}{more} / DoF {dof}: {reason}")
        })
        .collect::<Vec<_>>()
        .join("; ")
}

/// An entry of the activity matrix decided on a mounting clearance, not
/// on evidence alone: the DoF showed no lever at the cell, down to
/// `lever_bound_m`, so by the clearance it does not move the cell.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Assumed {
    /// The cell.
    pub cell: Address,
    /// The DoF's name.
    pub dof: String,
    /// The assumption, in words (declared, or the default and whence).
    pub assumption: String,
    /// The evidence bounds the cell's lever to the DoF below this, m: the
    /// smallest lever it could have seen there.
    pub lever_bound_m: f64,
}

/// What the evidence could see at each entry of the activity matrix: the
/// smallest lever to the DoF it would have decided as a movement, given
/// the sensors' noise and quantization (the lever's own margin) and the
/// base's rocking (the still cells' floor). 0 where the gravity test had
/// power or the DoF is prismatic: a moved cell shows it wherever it sits.
#[derive(Clone, Debug, PartialEq)]
pub struct Levers {
    dofs: usize,
    /// Per entry (cell-major), m.
    seen_m: Vec<f64>,
    /// Per entry: its DoF's axis stood aligned with gravity, or the DoF
    /// is coupled, and one step showed no lever that decided it: the cell
    /// sits near the axis or is still, and pooled levers, a tilt, the
    /// tree or the clearance decided it.
    near_axis: Vec<bool>,
}

impl Levers {
    /// The smallest lever to DoF `d` that cell `u`'s evidence would have
    /// decided as a movement, m (infinite where its motion saturated).
    pub fn seen_m(&self, u: usize, d: usize) -> f64 {
        self.seen_m[u * self.dofs + d]
    }

    /// Cell `u` sat near DoF `d`'s axis or still, where gravity did not tell.
    pub fn near_axis(&self, u: usize, d: usize) -> bool {
        self.near_axis[u * self.dofs + d]
    }

    /// The entries near an axis, where gravity did not tell.
    pub fn near_axis_entries(&self) -> usize {
        self.near_axis.iter().filter(|&&b| b).count()
    }

    /// The smallest lever decided: at every entry near an axis where
    /// gravity did not tell, a lever this large or larger would have been
    /// decided by evidence, m (`None`: there was no such entry).
    pub fn smallest_decided_m(&self) -> Option<f64> {
        self.seen_m.iter().zip(&self.near_axis).filter(|(_, &b)| b).map(|(&s, _)| s).reduce(f64::max)
    }

    /// One row per cell of [`Levers::seen_m`], m.
    pub fn rows(&self) -> Vec<Vec<f64>> {
        self.seen_m.chunks(self.dofs.max(1)).map(<[f64]>::to_vec).collect()
    }
}

/// Where the exploration is, for progress bars.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Progress {
    /// DoF measurements done.
    pub done: usize,
    /// DoF measurements planned.
    pub total: usize,
}

/// What the robot learned about itself.
#[derive(Clone, Debug)]
pub struct Exploration {
    /// Cells, in the row order of the activity matrix (sorted by ID).
    pub cells: Vec<Address>,
    /// DoF names, interface order.
    pub dof_names: Vec<String>,
    /// DoF kinds, interface order.
    pub dof_kinds: Vec<DofKind>,
    /// Every posture the structure was measured in (DoF positions, the
    /// start first); [`Basis`] entries refer to them by index.
    pub postures: Vec<Vec<f64>>,
    /// The or-ed activity matrix, with what decided each entry.
    pub activity: ActivityMatrix,
    /// The kinematic tree.
    pub tree: KinematicTree,
    /// The sensory-motor map, one tile at the start pose.
    pub smm: SensoryMotorMap,
    /// Robot time of the structural exploration, s.
    pub structure_time_s: f64,
    /// Robot time of the sensory-motor exploration, s.
    pub smm_time_s: f64,
    /// Things the user should know, e.g. DoFs whose axis stayed vertical.
    pub warnings: Vec<String>,
    /// Entries decided on a mounting clearance, each with its lever bound.
    pub assumed: Vec<Assumed>,
    /// What the evidence could see at every entry.
    pub levers: Levers,
    /// The structural exploration's still windows with their postures:
    /// the calibration's gravity fit starts from them.
    pub(crate) stills: Vec<(Vec<f64>, session::Window)>,
}

impl Exploration {
    /// Total robot time spent moving and sampling, s.
    pub fn exploration_time_s(&self) -> f64 {
        self.structure_time_s + self.smm_time_s
    }
}

/// Explores the robot from its current pose, to which it returns.
pub fn explore<R: Robot + SampleSource>(
    rig: &mut R,
    cfg: &ExploreConfig,
    progress: &mut dyn FnMut(Progress),
) -> Result<Exploration, ExploreError> {
    cfg.structure.check()?;
    cfg.smm.check(rig.tick_s())?;
    let dof_names = rig.dof_names();
    let dof_kinds = rig.dof_kinds();
    if dof_kinds.len() != dof_names.len() {
        return Err(ExploreError::Config(format!("{} DoF kinds for {} DoFs", dof_kinds.len(), dof_names.len())));
    }
    let start = rig.positions();
    let mut session = Session::discover(rig, cfg.range)?;
    let dofs = session.dofs();
    let outcome = structure::explore(&mut session, &cfg.structure, &dof_kinds, &mut |done, total| {
        progress(Progress { done, total: total + dofs })
    })?;
    session.move_to(&start, cfg.smm.move_speed_rad_s, cfg.smm.pose_tolerance_rad, 30.0)?;
    let structure_time_s = session.elapsed_s();

    let cells = session.cells().to_vec();
    let undecided: Vec<Undecided> = outcome
        .activity
        .undecided()
        .into_iter()
        .map(|(u, d)| Undecided {
            cell: cells[u],
            dof: dof_names[d].clone(),
            reason: reason(&outcome, &cfg.structure, &dof_names, u, d),
        })
        .collect();
    if !undecided.is_empty() {
        return Err(ExploreError::Undecided(undecided));
    }
    let (assumed, warnings) = assumptions(&outcome, &cfg.structure, &cells, &dof_names);
    let levers = Levers {
        dofs: dof_names.len(),
        seen_m: outcome.seen.clone(),
        near_axis: outcome.lever_bounds.iter().map(|b| b.is_finite()).collect(),
    };
    let structure::Outcome { activity, postures, stills, .. } = outcome;
    let merged = merge::merge(&activity.rows());
    let tree = KinematicTree::new(&merged, &cells, &dof_names)?;

    let done = outcome.measurements;
    let total = done + dofs;
    let smm =
        SensoryMotorMap::explore(&mut session, activity.clone(), &dof_kinds, cfg.range, cfg.smm, &start, &mut |d| {
            progress(Progress { done: done + d + 1, total })
        })?;
    let smm_time_s = session.elapsed_s() - structure_time_s;
    Ok(Exploration {
        cells,
        dof_names,
        dof_kinds,
        postures,
        activity,
        tree,
        smm,
        structure_time_s,
        smm_time_s,
        warnings,
        assumed,
        levers,
        stills,
    })
}

/// The entries decided on the mounting clearance, and one warning line per
/// DoF and doubt naming the cells, the assumption and the lever bound the
/// evidence reached (the largest of theirs).
fn assumptions(
    outcome: &structure::Outcome,
    cfg: &StructureConfig,
    cells: &[Address],
    names: &[String],
) -> (Vec<Assumed>, Vec<String>) {
    let Some(clearance) = cfg.clearance() else { return (Vec::new(), Vec::new()) };
    let assumption = clearance.describe(cfg.cell_pitch_m);
    let dofs = names.len();
    let (mut assumed, mut warnings) = (Vec::new(), Vec::new());
    for (d, name) in names.iter().enumerate() {
        for coupled in [false, true] {
            let entries: Vec<usize> = (0..cells.len())
                .filter(|&u| outcome.activity.basis(u, d) == Some(Basis::Clearance))
                .filter(|&u| (outcome.doubts[u * dofs + d] == Some(Doubt::Coupled)) == coupled)
                .collect();
            if entries.is_empty() {
                continue;
            }
            let bound = |u: usize| outcome.lever_bounds[u * dofs + d];
            let worst = entries.iter().map(|&u| bound(u)).fold(0.0, f64::max);
            let ids: Vec<String> = entries.iter().map(|&u| cells[u].0.to_string()).collect();
            let shown = if ids.len() > 12 {
                format!("{} and {} more", ids[..12].join(", "), ids.len() - 12)
            } else {
                ids.join(", ")
            };
            let what = if coupled {
                "no gravity change and no lever from the coupled (mimic) joints it drives"
            } else {
                "no lever to its gravity-aligned axis, which no posture tilted"
            };
            let hint = if clearance.declared {
                ""
            } else {
                "; --strict refuses instead, --axis-clearance declares the skin's own"
            };
            warnings.push(format!(
                "DoF {name}: {} cells ({shown}) showed {what}, their levers bounded below {:.2} mm by the evidence, and are taken as still on {assumption}{hint}",
                entries.len(),
                worst * 1e3
            ));
            assumed.extend(entries.into_iter().map(|u| Assumed {
                cell: cells[u],
                dof: name.clone(),
                assumption: assumption.clone(),
                lever_bound_m: bound(u),
            }));
        }
    }
    (assumed, warnings)
}

/// How far entry `i`'s lever bound stayed from the mounting clearance
/// that would settle it, in words.
fn short_of_clearance(outcome: &structure::Outcome, cfg: &StructureConfig, u: usize, d: usize) -> String {
    // The cells of one DoF share one line: the bound the evidence reached
    // on all of its undecided ones.
    let dofs = outcome.activity.dofs();
    let bound = (0..outcome.activity.cells())
        .filter(|&v| {
            outcome.activity.get(v, d) == Activity::Unknown
                && outcome.doubts[v * dofs + d] == outcome.doubts[u * dofs + d]
        })
        .map(|v| outcome.lever_bounds[v * dofs + d])
        .fold(0.0, f64::max);
    let reached = if bound.is_finite() {
        format!("its lever is bounded only below {:.2} mm", bound * 1e3)
    } else {
        "no bound on its lever was reached".to_owned()
    };
    match cfg.clearance() {
        Some(c) => format!(
            "{reached}, not below {} within the robot-time budget of {:.0} s: the cell is still or that close to the axis",
            c.describe(cfg.cell_pitch_m),
            cfg.budget_s
        ),
        None => format!(
            "{reached}: the cell is still or that close to the axis, and --strict assumes no mounting clearance; declare the skin's (--axis-clearance) if no cell sits that close"
        ),
    }
}

/// Why entry (`u`, `d`) stayed undecided, in words.
fn reason(outcome: &structure::Outcome, cfg: &StructureConfig, names: &[String], u: usize, d: usize) -> String {
    let dofs = names.len();
    let activity = &outcome.activity;
    if !(0..activity.cells()).any(|v| activity.is_moved(v, d)) {
        return format!(
            "the DoF moved no cell in any of the {} postures tried: it carries no skin, or its axis stays aligned with gravity and its cells sit on it",
            outcome.postures.len()
        );
    }
    match outcome.doubts[u * dofs + d] {
        Some(Doubt::NearAxis) => {
            let tilts = &outcome.tilted_by[d];
            let tried = if tilts.is_empty() {
                "no DoF was found that carries it and could tilt it: it comes first from the base".to_owned()
            } else {
                let turned: Vec<&str> = tilts.iter().map(|&p| names[p].as_str()).collect();
                format!("turning {} did not tilt it", turned.join(", "))
            };
            let why = format!("no lever to its axis, which stayed within about 6 degrees of gravity ({tried})");
            format!("{why}, {}", short_of_clearance(outcome, cfg, u, d))
        }
        Some(Doubt::Noise) if outcome.repeats[d] > 0 => format!(
            "its axis stayed within about 6 degrees of gravity, and the lever stays within the noise after {} pooled repeats of the step (robot-time budget {:.0} s)",
            outcome.repeats[d] + 1,
            cfg.budget_s
        ),
        Some(Doubt::Noise) => format!(
            "the evidence stays within the noise after steps averaged up to {:.1} s (robot-time budget {:.0} s)",
            outcome.longest_average_s, cfg.budget_s
        ),
        Some(Doubt::Saturated) => "the accelerometer saturated in every measurement (use a larger range)".to_owned(),
        Some(Doubt::Coupled) => format!(
            "the DoF turns the cells it moves by different rotations (coupled or mimic joints), so a cell that shows no gravity change may still move with it, and over {} pooled repeats of the step {} (a floor that more repeats do not lower is the base rocking with the step)",
            outcome.repeats[d] + 1,
            short_of_clearance(outcome, cfg, u, d)
        ),
        None => format!("not measured again: the robot-time budget of {:.0} s is spent", cfg.budget_s),
    }
}
