//! Where the grasping experiment runs: the built-in scene, or MuJoCo
//! (`--mujoco [MODEL]`, a build with the `mujoco` feature), where objects
//! slide, tip and fall, contacts are soft and frictional and the arms'
//! servos saturate.

use std::path::PathBuf;

use skin_sim::endpoint::{Endpoint, EndpointConfig};
use skin_sim::network::NetworkError;

/// The experiment's world.
#[derive(clap::Args)]
pub struct LabArgs {
    /// Run the experiment in MuJoCo: the built-in HRP-2-like upper body as a MuJoCo model
    /// (the same links, DoFs and limits, HRP-2-class torque limits), or MODEL, an MJCF of it
    /// (as `skin model` writes; a build with the `mujoco` feature).
    #[arg(long, value_name = "MODEL", num_args = 0..=1)]
    #[allow(clippy::option_option)]
    mujoco: Option<Option<PathBuf>>,
}

impl LabArgs {
    /// Refuses `--mujoco` in a build without MuJoCo, before anything starts.
    pub fn check(&self) -> Result<(), super::world::Error> {
        #[cfg(not(feature = "mujoco"))]
        if self.mujoco.is_some() {
            return Err(super::world::Error::NoMujoco);
        }
        Ok(())
    }

    /// What the world is, for the report.
    pub fn describe(&self) -> String {
        match &self.mujoco {
            None => "the built-in world".into(),
            Some(None) => "MuJoCo 3.17 (the built-in robot written as a MuJoCo model)".into(),
            Some(Some(path)) => format!("MuJoCo 3.17 ({})", path.display()),
        }
    }

    /// A recipe for the endpoint, to build on its serving thread.
    pub fn recipe(&self) -> Recipe {
        Recipe(self.mujoco.clone())
    }
}

/// How to build the experiment's endpoint (it is `Send`; the world it builds is not).
pub struct Recipe(Option<Option<PathBuf>>);

impl Recipe {
    /// The endpoint of the experiment, seeded.
    pub fn build(self, seed: u64, config: EndpointConfig) -> Result<Endpoint, NetworkError> {
        match self.0 {
            None => Endpoint::experiment(seed, config),
            #[cfg(feature = "mujoco")]
            Some(model) => Endpoint::experiment_mujoco(model.as_deref(), seed, config),
            #[cfg(not(feature = "mujoco"))]
            Some(_) => Err(NetworkError::Flag(super::world::Error::NoMujoco.to_string())),
        }
    }
}
