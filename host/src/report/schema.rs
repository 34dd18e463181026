//! What `report.json` holds: the data of every figure, section by section.

use serde::Serialize;

#[cfg(feature = "sim")]
use super::sim::{GraspSection, LatencySection, TruthSection};
use crate::calibrate::export::Picture;
use crate::calibrate::Calibration;
use crate::explore::{Assumed, Exploration};
use crate::interface::InterfaceCounters;
use crate::pipeline::Organized;

/// The robot as it described itself on the robot link.
#[derive(Clone, Debug, Serialize)]
pub struct RobotSection {
    /// What was driven, e.g. the built-in simulated robot or an address.
    pub source: String,
    /// DoF names, command order.
    pub dof_names: Vec<String>,
    /// Control period, s.
    pub period_s: f64,
    /// One period per command (a simulator) rather than real time.
    pub lockstep: bool,
}

/// How long each step took, on the wall clock and on the robot's clock.
#[derive(Clone, Debug, Default, Serialize)]
pub struct Timing {
    /// Everything, from the start until the report's files were written, wall clock, s.
    pub total_wall_s: f64,
    /// Self-organization, wall clock, s.
    pub organize_wall_s: f64,
    /// Structural and sensory-motor exploration, wall clock, s.
    pub explore_wall_s: f64,
    /// Teaching and grasping, wall clock, s.
    pub grasp_wall_s: f64,
    /// Self-organization, robot time, s.
    pub organize_robot_s: f64,
    /// Structural exploration, robot time, s.
    pub structure_robot_s: f64,
    /// Sensory-motor exploration, robot time, s.
    pub smm_robot_s: f64,
}

/// The robot link's trouble.
#[derive(Clone, Copy, Debug, Default, Serialize)]
pub struct LinkSection {
    /// Requests sent again.
    pub retries: u64,
    /// Datagrams that were not the answer awaited.
    pub ignored: u64,
}

/// One joint of the learned tree.
#[derive(Clone, Debug, Serialize)]
pub struct JointSection {
    /// Its DoFs by name.
    pub dofs: Vec<String>,
    /// The body part it is mounted on.
    pub parent_body_part: usize,
    /// The body part it moves.
    pub child_body_part: usize,
}

/// What the exploration learned.
#[derive(Clone, Debug, Serialize)]
pub struct ExplorationSection {
    /// Cell IDs, the rows of `activity` and `smm_weights`.
    pub cells: Vec<u16>,
    /// DoF names, their columns.
    pub dofs: Vec<String>,
    /// The activity matrix before merging: does DoF d move cell u.
    pub activity: Vec<Vec<bool>>,
    /// Body parts (merged cells), depth first from the root.
    pub body_parts: Vec<Vec<u16>>,
    /// Joints (merged DoFs); joint n carries body part n + 1.
    pub joints: Vec<JointSection>,
    /// The merged matrix, strictly lower triangular: body parts x joints.
    pub merged: Vec<Vec<bool>>,
    /// Body parts without child joints.
    pub leaves: Vec<usize>,
    /// Chains of joints from the root to each leaf.
    pub limbs: Vec<Vec<usize>>,
    /// The pose of the sensory-motor map's first tile, rad.
    pub smm_pose_rad: Vec<f64>,
    /// Its weights, cells x DoFs, in [-1, 1].
    pub smm_weights: Vec<Vec<f32>>,
    /// What the user should know.
    pub warnings: Vec<String>,
    /// Entries decided on a mounting clearance, not on evidence alone.
    pub assumed: Vec<Assumed>,
    /// Per cell and DoF, the smallest lever the evidence would have
    /// decided as a movement, m (null where the motion saturated).
    pub lever_seen_m: Vec<Vec<f64>>,
    /// Its largest over the entries near an axis, where gravity did not
    /// tell: any lever this large or larger was decided by evidence, m.
    pub smallest_lever_decided_m: Option<f64>,
}

/// The skin calibrated on the robot's description.
#[derive(Clone, Debug, Serialize)]
pub struct CalibrationSection {
    /// Cells with a position along every link axis.
    pub cells_3d: usize,
    /// Cells with part of their position (a lone joint axis hides the rest).
    pub cells_partial: usize,
    /// Cells with no position claimed.
    pub cells_unobservable: usize,
    /// Cells whose accelerometer frame is known.
    pub frames_known: usize,
    /// Robot time spent, s.
    pub robot_time_s: f64,
    /// The skin's delay behind the joint feedback, per excitation, ms.
    pub delays_ms: Vec<f64>,
    /// Cells whose body is in doubt.
    pub warnings: Vec<String>,
    /// Files written beside the report: the skin description and the URDF with skin frames.
    pub files: Vec<String>,
    /// What the three views draw.
    pub picture: Picture,
}

impl CalibrationSection {
    /// The parts of a calibration the report shows.
    pub fn new(c: &Calibration, picture: Picture, files: Vec<String>) -> CalibrationSection {
        let full = c.cells.iter().filter(|p| p.unobservable.is_empty()).count();
        let none = c.cells.iter().filter(|p| p.unobservable.len() == 3).count();
        CalibrationSection {
            cells_3d: full,
            cells_partial: c.cells.len() - full - none,
            cells_unobservable: none,
            frames_known: c.cells.iter().filter(|p| p.orientation_observable).count(),
            robot_time_s: c.robot_time_s,
            delays_ms: c.delays_ms.clone(),
            warnings: c.warnings.clone(),
            files,
            picture,
        }
    }
}

/// One figure of the report.
#[derive(Clone, Debug, Serialize)]
pub struct Figure {
    /// File name in the report folder.
    pub file: String,
    /// Heading.
    pub title: String,
    /// What it shows.
    pub caption: String,
}

/// Everything the report holds; serialized as `report.json`.
#[derive(Clone, Debug, Serialize)]
pub struct Report {
    /// The robot.
    pub robot: RobotSection,
    /// How long each step took.
    pub timing: Timing,
    /// The organized skin.
    pub organization: Organized,
    /// What the interface counted.
    pub interface: InterfaceCounters,
    /// The robot link's trouble.
    pub link: LinkSection,
    /// What the exploration learned.
    pub exploration: ExplorationSection,
    /// Cells whose sensors read what no working one can, found before the
    /// exploration; those with a broken accelerometer were left out of it.
    pub sensor_faults: Vec<crate::health::SensorFault>,
    /// Network latency (simulated skins only).
    #[cfg(feature = "sim")]
    pub latency: Option<LatencySection>,
    /// The skin calibrated on the robot's description (`skin run --urdf`).
    pub calibration: Option<CalibrationSection>,
    /// Teaching and grasps (simulation only).
    #[cfg(feature = "sim")]
    pub grasps: Option<GraspSection>,
    /// Checks against the simulator's truth (simulation only).
    #[cfg(feature = "sim")]
    pub truth: Option<TruthSection>,
    /// The figures, in the order `index.html` shows them.
    pub figures: Vec<Figure>,
}

impl ExplorationSection {
    /// The parts of an exploration the report shows.
    pub fn new(found: &Exploration) -> ExplorationSection {
        let tree = &found.tree;
        let tile = &found.smm.tiles()[0];
        ExplorationSection {
            cells: found.cells.iter().map(|a| a.0).collect(),
            dofs: found.dof_names.clone(),
            activity: found.activity.rows(),
            body_parts: tree.body_parts().iter().map(|p| p.cells.iter().map(|a| a.0).collect()).collect(),
            joints: tree
                .joints()
                .iter()
                .map(|j| JointSection {
                    dofs: j.dofs.iter().map(|&d| found.dof_names[d].clone()).collect(),
                    parent_body_part: j.parent,
                    child_body_part: j.child,
                })
                .collect(),
            merged: tree.lower_triangular(),
            leaves: tree.leaves(),
            limbs: tree.limbs(),
            smm_pose_rad: tile.pose().to_vec(),
            smm_weights: (0..found.cells.len()).map(|u| tile.weights(u).to_vec()).collect(),
            warnings: found.warnings.clone(),
            assumed: found.assumed.clone(),
            lever_seen_m: found.levers.rows(),
            smallest_lever_decided_m: found.levers.smallest_decided_m(),
        }
    }
}
