//! Any ros2_control robot as the skin's robot: positions from
//! `/joint_states` (joint_state_broadcaster) by joint name, velocities to
//! a forward_command_controller on the velocity interface
//! (`std_msgs/Float64MultiArray` on `/<controller>/commands`, in the order
//! of the controller's `joints` parameter), over DDS.
//!
//! The host drives robots through the robot link, so this is a robot-link
//! server on loopback ([`Ros2Robot`]) that `skin run --robot ros2` connects
//! to like any other robot, running in real time.
//!
//! The robot link announces the period measured from `/joint_states`
//! stamps, and each command is answered with the next `/joint_states`
//! after it, so a tick's positions and the skin's samples of that tick
//! come from the same cycle of the robot while the host keeps up. Joint kinds and
//! limits come from `/robot_description` ([`joints`]); limits clamp every
//! command.
//!
//! Safety, because a forward controller holds its last command forever:
//! the controller's joints are checked against `/joint_states` before
//! anything moves; a command that is not finite or not one per joint is
//! refused and turned into a zero command; and a zero command goes out,
//! acknowledged by the controller or 100 ms passed, on every way out:
//! the host done or failed (the bridge dropped, also while a panic
//! unwinds), SIGINT or SIGTERM, and `/joint_states` silent for
//! [`SILENCE`], after which the process ends naming the silent topic.

mod bridge;
pub mod joints;
pub mod msgs;
mod priority;
mod signals;

use std::time::Duration;

pub use bridge::Ros2Robot;

/// The controller `--robot ros2` drives when none is named (UR's driver
/// ships it; Franka and Kinova set one up the same way).
pub const DEFAULT_CONTROLLER: &str = "forward_velocity_controller";
/// Longest silence of `/joint_states` while the robot is commanded,
/// counted over the time the bridge was running (its own descheduling is
/// no evidence of the robot's silence).
pub const SILENCE: Duration = Duration::from_millis(100);

/// What the bridge needs to know.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ControlConfig {
    /// The controller's name (`forward_velocity_controller`).
    pub controller: String,
    /// The controller's joints in command order, used when its `joints`
    /// parameter cannot be read (its parameter service absent); `None`
    /// refuses to drive a controller whose parameter does not answer.
    pub joints: Option<Vec<String>>,
    /// The robot's description (URDF text), for joint kinds and limits
    /// when the robot does not publish `/robot_description`.
    pub description: Option<String>,
    /// The ROS domain.
    pub domain: u16,
    /// Loopback only (the ROS discovery-range variables).
    pub localhost_only: bool,
    /// Longest wait for the parameter service and the first `/joint_states`.
    pub timeout: Duration,
}

impl ControlConfig {
    /// `spec` is what follows `ros2` in `--robot ros2[:CONTROLLER]`: empty
    /// or `:NAME`.
    pub fn parse(spec: &str, domain: u16) -> Result<ControlConfig, ControlError> {
        let controller = match spec.strip_prefix(':') {
            None if spec.is_empty() => DEFAULT_CONTROLLER.to_owned(),
            Some(name) if valid_name(name) => name.to_owned(),
            _ => return Err(ControlError::Controller(spec.trim_start_matches(':').to_owned())),
        };
        Ok(ControlConfig {
            controller,
            joints: None,
            description: None,
            domain,
            localhost_only: crate::ros::dds::localhost_only_from_env(),
            timeout: Duration::from_secs(10),
        })
    }
}

/// A ROS 2 name token: letters, digits and underscores, not starting with a digit.
fn valid_name(name: &str) -> bool {
    !name.is_empty()
        && !name.starts_with(|c: char| c.is_ascii_digit())
        && name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_')
}

/// Why the robot could not be driven.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ControlError {
    /// A controller name ROS 2 does not allow.
    #[error(
        "--robot ros2:{0}: a controller name is letters, digits and underscores, e.g. ros2:forward_velocity_controller"
    )]
    Controller(String),
    /// DDS did not start or an endpoint could not be created.
    #[error(transparent)]
    Dds(#[from] crate::ros::dds::DdsError),
    /// The controller's parameter service did not answer, and no joints were configured.
    #[error("/{controller} did not tell its joints within {waited:?} (its parameter service /{controller}/get_parameters did not answer), and none were given (--robot-joints): is the controller loaded, and is the ROS domain right?")]
    NoParameters {
        /// The controller.
        controller: String,
        /// How long it was asked.
        waited: Duration,
    },
    /// The `joints` parameter is not a non-empty string array.
    #[error("/{controller}'s `joints` parameter is {got}, not a list of joint names")]
    BadJoints {
        /// The controller.
        controller: String,
        /// What it answered.
        got: String,
    },
    /// The controller's `joints` parameter and the configured joints differ.
    #[error("/{controller}'s `joints` parameter is {parameter:?} but --robot-joints says {configured:?}: refused before any command")]
    JointsDisagree {
        /// The controller.
        controller: String,
        /// Its parameter.
        parameter: Vec<String>,
        /// The configured order.
        configured: Vec<String>,
    },
    /// The robot's description does not give the controller's joints.
    #[error("{0}: refused before any command")]
    Description(#[from] joints::DescriptionError),
    /// No `/joint_states` came.
    #[error("no /joint_states within {0:?}: is joint_state_broadcaster active?")]
    NoJointStates(Duration),
    /// The controller commands a joint `/joint_states` does not report.
    #[error("controller /{controller} commands {joint:?}, which /joint_states does not report (it has {reported:?}): refused before any command")]
    WrongJoints {
        /// The controller.
        controller: String,
        /// The joint missing.
        joint: String,
        /// What `/joint_states` names.
        reported: Vec<String>,
    },
    /// More joints, or a longer name, than the robot link carries.
    #[error("controller /{controller} has {joints} joints or a name over {max_name} bytes: the robot link carries at most {max_joints}")]
    TooMany {
        /// The controller.
        controller: String,
        /// Its joint count.
        joints: usize,
        /// The robot link's limit on joints.
        max_joints: usize,
        /// The robot link's limit on a name.
        max_name: usize,
    },
    /// The loopback socket of the robot link.
    #[error("the robot link to ROS 2 could not open on loopback: {0}")]
    Socket(#[from] std::io::Error),
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_robot_spec_names_the_controller() {
        assert_eq!(ControlConfig::parse("", 0).unwrap().controller, DEFAULT_CONTROLLER);
        assert_eq!(ControlConfig::parse(":joint_group_vel", 3).unwrap().controller, "joint_group_vel");
        for bad in [":", ":a/b", ":9lives", "x", ":a b"] {
            assert!(matches!(ControlConfig::parse(bad, 0), Err(ControlError::Controller(_))), "{bad}");
        }
    }
}
