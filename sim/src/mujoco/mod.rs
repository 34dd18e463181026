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
}

impl Model {
    /// Loads an MJCF or URDF file (a URDF's links joined by fixed joints
    /// stay links); meshes MuJoCo cannot find are left out, and said so.
    pub fn load(path: &Path) -> Result<Model, MujocoError> {
        load::load(path)
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
