//! The simulated world behind the [`Robot`] and [`SampleSource`] traits.

use skin_protocol::{Address, Sample};
use skin_sim::world::{World, WorldError};

use super::{DofKind, Robot, RobotError, SampleSource};

impl From<WorldError> for RobotError {
    fn from(e: WorldError) -> Self {
        match e {
            WorldError::WrongLength { expected, got } => RobotError::WrongLength { expected, got },
            WorldError::NotFinite(d) => RobotError::NotFinite(d),
            other => RobotError::Disconnected(other.to_string()),
        }
    }
}

/// The simulated world as a robot and a skin.
pub struct SimRobot {
    world: World,
}

impl SimRobot {
    /// Wraps a world.
    pub fn new(world: World) -> SimRobot {
        SimRobot { world }
    }

    /// The world, for ground truth when checking results.
    pub fn world(&self) -> &World {
        &self.world
    }
}

impl Robot for SimRobot {
    fn dof_names(&self) -> Vec<String> {
        self.world.robot().dofs().iter().map(|d| d.name.clone()).collect()
    }

    fn dof_kinds(&self) -> Vec<DofKind> {
        self.world.robot().dofs().iter().map(|d| d.kind).collect()
    }

    /// The description's limits, which the world clips commands to.
    fn velocity_limits(&self) -> Vec<Option<f64>> {
        self.world
            .robot()
            .dofs()
            .iter()
            .map(|d| (d.max_velocity.is_finite() && d.max_velocity > 0.0).then_some(d.max_velocity))
            .collect()
    }

    fn command_velocities(&mut self, omega_rad_s: &[f64]) -> Result<(), RobotError> {
        Ok(self.world.command(omega_rad_s)?)
    }

    fn positions(&self) -> Vec<f64> {
        self.world.positions().to_vec()
    }
}

impl SampleSource for SimRobot {
    fn tick_s(&self) -> f64 {
        self.world.config().tick_s
    }

    fn next_tick(&mut self, out: &mut Vec<(Address, Sample)>) -> Result<(), RobotError> {
        self.world.step(out);
        Ok(())
    }
}
