//! Automatic kinematic self-exploration (section 4).
//!
//! The robot learns its own body from the accelerometers in its skin, with
//! no model: it steps each DoF and watches which cells move ([`structure`],
//! [`activity`]),
//! merges cells into body parts and DoFs into joints ([`merge`]), finds the
//! kinematic tree ([`tree`]) and then explores how each DoF moves each cell
//! along its normal ([`smm`]). Everything goes through the [`Robot`] and
//! [`SampleSource`] traits; [`check`] compares a result with the
//! simulator's ground truth and is never used by the exploration itself.

pub mod activity;
pub mod check;
mod fit;
pub mod lowpass;
pub mod merge;
mod session;
pub mod smm;
pub mod structure;
pub mod tree;

use skin_protocol::message::AccelRange;
use skin_protocol::Address;

pub use activity::{Activity, ActivityMatrix};
pub use smm::{SensoryMotorMap, SmmConfig, Tile};
pub use structure::StructureConfig;
pub use tree::{KinematicTree, TreeError};

use crate::robot::{Robot, RobotError, SampleSource};
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
    /// Entries of the activity matrix that stayed undecided after every retry.
    #[error(
        "{} activity entries stay undecided (noise, saturation, or a cell close to a gravity-aligned axis), e.g. {}: average longer, step further, or tilt the base",
        .0.len(),
        .0.iter().take(5).map(|(c, d)| format!("{c} / {d}")).collect::<Vec<_>>().join(", ")
    )]
    Undecided(Vec<(Address, String)>),
    /// The activity matrix is not a kinematic tree.
    #[error("the activity matrix is not a kinematic tree: {0}")]
    NotATree(#[from] TreeError),
    /// A configuration value out of range.
    #[error("bad exploration setting: {0}")]
    Config(String),
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
    /// The or-ed activity matrix.
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
    let start = rig.positions();
    let mut session = Session::discover(rig, cfg.range)?;
    let dofs = session.dofs();
    let total = (cfg.structure.runs + 1) * dofs;
    let structure::Outcome { activity, blind } =
        structure::explore(&mut session, &cfg.structure, &dof_names, &mut |done| progress(Progress { done, total }))?;
    session.move_to(&start, cfg.smm.move_speed_rad_s, cfg.smm.pose_tolerance_rad, 30.0)?;
    let structure_time_s = session.elapsed_s();

    let cells = session.cells().to_vec();
    let undecided: Vec<(Address, String)> =
        activity.undecided().into_iter().map(|(u, d)| (cells[u], dof_names[d].clone())).collect();
    if !undecided.is_empty() {
        return Err(ExploreError::Undecided(undecided));
    }
    let merged = merge::merge(&activity.rows());
    let tree = KinematicTree::new(&merged, &cells, &dof_names)?;
    let warnings = blind
        .iter()
        .map(|&d| {
            format!(
                "DoF {}: axis within about 6 degrees of gravity in every posture tried; its cells were found from dynamic accelerations only, so a cell closer than {} m to this axis could not be seen",
                dof_names[d], cfg.structure.lever_threshold_m
            )
        })
        .collect();

    let done = cfg.structure.runs * dofs;
    let smm = SensoryMotorMap::explore(&mut session, activity.clone(), cfg.range, cfg.smm, &start, &mut |d| {
        progress(Progress { done: done + d + 1, total })
    })?;
    let smm_time_s = session.elapsed_s() - structure_time_s;
    Ok(Exploration { cells, dof_names, activity, tree, smm, structure_time_s, smm_time_s, warnings })
}
