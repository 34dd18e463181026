//! What the bridge knows of each commanded joint: its kind (turning or
//! sliding, told to the host on the robot link) and its limits (which
//! clamp every command), read from a URDF (`/robot_description`, or the
//! run's `--urdf`) through skin_model's reader. Without a description the
//! joints are revolute and unlimited, as the paper's robots, and the
//! bridge says so.

use skin_model::robot::Robot;
use skin_protocol::robot_link::DofKind;

/// Where the joints' kinds and limits came from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Source {
    /// The robot's `/robot_description` topic.
    Topic,
    /// The description the run was given (`--urdf`).
    Configuration,
    /// No description: revolute joints without limits.
    Assumed,
}

impl std::fmt::Display for Source {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Source::Topic => "from /robot_description",
            Source::Configuration => "from --urdf (/robot_description was not published)",
            Source::Assumed => "assumed revolute and unlimited (no /robot_description, no --urdf)",
        })
    }
}

/// One commanded joint.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Joint {
    /// Turning (rad) or sliding (m).
    pub kind: DofKind,
    /// Lowest position (`-inf` when unlimited or continuous).
    pub lower: f64,
    /// Highest position (`+inf` when unlimited or continuous).
    pub upper: f64,
    /// Largest speed (`inf` when not given).
    pub max_velocity: f64,
}

impl Joint {
    /// A revolute joint without limits.
    pub const UNLIMITED: Joint =
        Joint { kind: DofKind::Revolute, lower: f64::NEG_INFINITY, upper: f64::INFINITY, max_velocity: f64::INFINITY };

    /// `velocity` within the speed limit, and no faster toward a position
    /// limit than reaches it from `position` in `period_s`; a joint past a
    /// limit may only move back. Both inputs finite.
    pub fn clamp(&self, position: f64, velocity: f64, period_s: f64) -> f64 {
        let toward_upper = ((self.upper - position) / period_s).max(0.0);
        let toward_lower = ((self.lower - position) / period_s).min(0.0);
        velocity.clamp(-self.max_velocity, self.max_velocity).clamp(toward_lower, toward_upper)
    }
}

/// Why a description could not give the joints.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum DescriptionError {
    /// The URDF did not read.
    #[error("the robot's description ({source_name}) is not a usable URDF: {reason}")]
    Unreadable {
        /// `/robot_description` or `--urdf`.
        source_name: &'static str,
        /// What the reader said.
        reason: String,
    },
    /// The controller commands a joint the description does not move.
    #[error("the robot's description ({source_name}) has no movable joint {joint:?}, which the controller commands")]
    Missing {
        /// `/robot_description` or `--urdf`.
        source_name: &'static str,
        /// The joint.
        joint: String,
    },
}

/// The kinds and limits of `joints` (in that order) from the URDF `text`.
pub fn from_urdf(text: &str, joints: &[String], source: Source) -> Result<Vec<Joint>, DescriptionError> {
    let source_name = match source {
        Source::Topic => "/robot_description",
        Source::Configuration | Source::Assumed => "--urdf",
    };
    let robot =
        Robot::from_urdf_str(text).map_err(|e| DescriptionError::Unreadable { source_name, reason: e.to_string() })?;
    joints
        .iter()
        .map(|name| {
            robot
                .dofs()
                .iter()
                .find(|d| d.name == *name)
                .map(|d| Joint { kind: d.kind, lower: d.lower, upper: d.upper, max_velocity: d.max_velocity })
                .ok_or_else(|| DescriptionError::Missing { source_name, joint: name.clone() })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    const URDF: &str = r#"<robot name="r">
      <link name="base"/><link name="a"/><link name="b"/><link name="c"/>
      <joint name="turn" type="revolute"><parent link="base"/><child link="a"/><axis xyz="0 0 1"/>
        <limit lower="-1" upper="1" velocity="2" effort="1"/></joint>
      <joint name="slide" type="prismatic"><parent link="a"/><child link="b"/><axis xyz="1 0 0"/>
        <limit lower="0" upper="0.5" velocity="0.1" effort="1"/></joint>
      <joint name="spin" type="continuous"><parent link="b"/><child link="c"/><axis xyz="0 1 0"/></joint>
    </robot>"#;

    fn names(n: &[&str]) -> Vec<String> {
        n.iter().map(|s| s.to_string()).collect()
    }

    #[test]
    fn kinds_and_limits_come_in_the_controllers_order() {
        let j = from_urdf(URDF, &names(&["spin", "slide", "turn"]), Source::Topic).unwrap();
        assert_eq!(j[0].kind, DofKind::Revolute);
        assert_eq!((j[0].lower, j[0].upper), (f64::NEG_INFINITY, f64::INFINITY), "continuous: no range");
        assert_eq!((j[1].kind, j[1].lower, j[1].upper, j[1].max_velocity), (DofKind::Prismatic, 0.0, 0.5, 0.1));
        assert_eq!((j[2].kind, j[2].lower, j[2].upper, j[2].max_velocity), (DofKind::Revolute, -1.0, 1.0, 2.0));
    }

    #[test]
    fn a_joint_the_description_lacks_or_a_broken_description_is_an_error() {
        let e = from_urdf(URDF, &names(&["turn", "elbow"]), Source::Topic).unwrap_err();
        assert!(e.to_string().contains("no movable joint \"elbow\""), "{e}");
        let e = from_urdf("<robot", &names(&["turn"]), Source::Configuration).unwrap_err();
        assert!(matches!(e, DescriptionError::Unreadable { source_name: "--urdf", .. }), "{e}");
    }

    #[test]
    fn commands_are_clamped_to_the_speed_and_the_range() {
        let j = Joint { kind: DofKind::Revolute, lower: -1.0, upper: 1.0, max_velocity: 2.0 };
        assert_eq!(j.clamp(0.0, 5.0, 0.01), 2.0, "speed limit");
        assert_eq!(j.clamp(0.0, -5.0, 0.01), -2.0);
        assert!((j.clamp(0.99, 2.0, 0.01) - 1.0).abs() < 1e-9, "no further than the upper limit in one period");
        assert_eq!(j.clamp(1.2, 1.0, 0.01), 0.0, "past the limit: no further out");
        assert_eq!(j.clamp(1.2, -1.0, 0.01), -1.0, "but back in");
        assert_eq!(Joint::UNLIMITED.clamp(100.0, 1e3, 0.002), 1e3);
    }
}
