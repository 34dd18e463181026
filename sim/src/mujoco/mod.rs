//! The skin's world in MuJoCo: a physics engine and robot models nobody on
//! this project wrote, behind the same seam as the built-in world.
//!
//! [`Model::load`] reads an MJCF or URDF file with MuJoCo and the robot from
//! MuJoCo's compiled model (mjModel); the skin is laid on it as on a URDF
//! robot. [`Model::world`] then adds, through mjSpec, a site per cell with
//! MuJoCo's `accelerometer`, a `rangefinder` along its normal and three
//! `touch` zones, a position servo to every DoF that has none and a weld to
//! every floating base, compiles, and returns a [`World`] that MuJoCo moves
//! ([`Engine`]): the network simulator, the endpoint, the robot link and the
//! host run on it unchanged, and its readings go through the same sensor
//! models (BMA250, VCNL4010, force cells) as the built-in world's.

mod cells;
mod engine;
mod load;
mod rangefinder;
mod stage;
mod tree;
mod with_skin;

use std::path::Path;

use skin_model::robot::{Robot, UrdfError};
use skin_model::skin::Skin;

pub use engine::Engine;
pub use stage::{experiment_world, SharedStage};
pub use with_skin::{model_with_skin, CellSite, ModelWithSkin};

use crate::world::{World, WorldConfig};

/// Why a MuJoCo world cannot be built.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum MujocoError {
    /// MuJoCo cannot read or compile the model file.
    #[error("MuJoCo cannot load {path}: {message}")]
    Load {
        /// The model file.
        path: String,
        /// MuJoCo's message.
        message: String,
    },
    /// The model has something the skin's world cannot drive.
    #[error("the model cannot be driven as a robot: {0}")]
    Unsupported(String),
    /// The robot read from the model is refused (no DoF, too many).
    #[error(transparent)]
    Robot(#[from] UrdfError),
    /// A cell names a link that is no body of the model.
    #[error("the skin puts a cell on \"{0}\", which is not a body of the model")]
    UnknownBody(String),
    /// MuJoCo refuses the model with the skin's sites, sensors, servos and welds.
    #[error("MuJoCo cannot compile the model with the skin: {0}")]
    Compile(String),
}

/// A robot model loaded by MuJoCo, ready to carry a skin.
pub struct Model {
    spec: mujoco_rs::prelude::MjSpec,
    /// The model as loaded, before the skin: its actuators and inertias.
    compiled: mujoco_rs::prelude::MjModel,
    tree: tree::Tree,
    notes: Vec<String>,
    /// The start keyframe's controls, one per actuator of the model (none
    /// without a keyframe): what holds the joints the world does not drive.
    start_ctrl: Vec<f64>,
}

impl Model {
    /// Loads an MJCF or URDF file (a URDF's links joined by fixed joints
    /// stay links); meshes MuJoCo cannot find are left out, and said so.
    pub fn load(path: &Path) -> Result<Model, MujocoError> {
        load::load(path)
    }

    /// The built-in HRP-2-like upper body in MuJoCo: `model` (an MJCF of
    /// it) or, with none, the built-in robot written as one; checked to
    /// have the built-in robot's DoFs, and starting where the built-in
    /// robot stands (MuJoCo's would start at the model's zero pose).
    pub fn built_in(model: Option<&Path>, seed: u64) -> Result<Model, MujocoError> {
        let built_in = skin_model::robot::hrp2::robot();
        let mut loaded = match model {
            Some(path) => Model::load(path)?,
            None => {
                // MuJoCo reads a model from a file: the built-in robot's,
                // written where no other run writes (nor another call of
                // this process: two worlds of one seed may be built at once).
                static CALLS: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
                let call = CALLS.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                let path = std::env::temp_dir().join(format!("skin-hrp2-{}-{seed}-{call}.xml", std::process::id()));
                let failed =
                    |e: std::io::Error| MujocoError::Load { path: path.display().to_string(), message: e.to_string() };
                std::fs::write(&path, skin_model::robot::mjcf::write(&built_in)).map_err(failed)?;
                let loaded = Model::load(&path);
                let _ = std::fs::remove_file(&path);
                loaded?
            }
        };
        let names = |r: &Robot| r.dofs().iter().map(|d| d.name.clone()).collect::<Vec<_>>();
        if names(loaded.robot()) != names(&built_in) {
            return Err(MujocoError::Unsupported(format!(
                "the built-in robot's DoFs {:?} are needed; the model has {:?}",
                names(&built_in),
                names(loaded.robot())
            )));
        }
        loaded.set_home(built_in.home())?;
        Ok(loaded)
    }

    /// The robot as MuJoCo compiled it: bodies, DoFs named as the model's
    /// joints, links named as its bodies.
    pub fn robot(&self) -> &Robot {
        &self.tree.robot
    }

    /// Makes `pose` (DoF order) the pose the world starts in and its
    /// servos hold, as a robot's home.
    pub fn set_home(&mut self, pose: &[f64]) -> Result<(), MujocoError> {
        Ok(self.tree.robot.set_home(pose)?)
    }

    /// What was assumed of the model so far, one sentence each.
    pub fn notes(&self) -> &[String] {
        &self.notes
    }

    /// The world: the model with `skin`'s cells as sites with sensors, its
    /// DoFs under position servos, floating bases welded, on `cfg`'s clock
    /// and sensor models; the base's tilt turns gravity (MuJoCo's base does
    /// not sway or rock: it stands as the model holds it).
    pub fn world(self, skin: Skin, cfg: WorldConfig) -> Result<World, MujocoError> {
        let robot = self.tree.robot.clone();
        let engine = Engine::new(self, &skin, &cfg, None)?;
        Ok(World::mujoco(robot, skin, cfg, engine))
    }

    /// The world as [`Model::world`], in the grasping experiment's lab:
    /// a floor, the person's hands and the tray they put objects on, as
    /// MuJoCo bodies the person moves through `lab`.
    pub fn world_on_stage(self, skin: Skin, cfg: WorldConfig, lab: SharedStage) -> Result<World, MujocoError> {
        let robot = self.tree.robot.clone();
        let engine = Engine::new(self, &skin, &cfg, Some(lab))?;
        Ok(World::mujoco(robot, skin, cfg, engine))
    }
}
