//! How large and how extreme a URDF may be.
//!
//! A description is data from anywhere: the reader bounds the work and
//! memory it spends (bytes, XML nodes, nesting, links, joints, DoFs) and
//! refuses numbers no robot has, so everything downstream (kinematics,
//! skin placement, sampling) only ever sees finite, physically sane values.
//! The bounds are far beyond any real robot and far below where `f64`
//! arithmetic on them overflows.

use super::UrdfError;

/// Largest document, bytes (the biggest public descriptions are a few MB).
pub const MAX_BYTES: usize = 32 << 20;
/// Largest number of XML nodes (elements, text, comments) in a document.
pub const MAX_NODES: u32 = 2_000_000;
/// Deepest element nesting (a URDF needs 5: robot, link, visual, geometry, box).
pub const MAX_DEPTH: usize = 64;
/// Most links, and most joints, in a robot.
pub const MAX_LINKS: usize = 10_000;
/// Most DoFs: what the robot link between host and robot carries.
pub const MAX_DOFS: usize = skin_protocol::robot_link::MAX_DOFS;
/// Largest coordinate or size, m: 1 km.
pub const MAX_LENGTH_M: f64 = 1e3;
/// Largest link mass, kg.
pub const MAX_MASS_KG: f64 = 1e6;
/// Largest effort limit, N m or N.
pub const MAX_EFFORT: f64 = 1e6;
/// Largest angle (origin rpy, revolute limit), rad.
pub const MAX_ANGLE_RAD: f64 = 1e3;
/// Largest mimic multiplier or offset (rad or m per unit of the master).
pub const MAX_MIMIC: f64 = 1e3;

/// What a number read from the description stands for, and so its range.
#[derive(Clone, Copy, Debug)]
pub(super) enum Quantity {
    /// A coordinate or prismatic position, m: |v| <= 1 km.
    Position,
    /// A box edge, radius or length, m: 0 <= v <= 1 km.
    Size,
    /// An angle, rad: |v| <= 1000.
    Angle,
    /// A link mass, kg: 0 <= v <= 1e6.
    Mass,
    /// A velocity limit, rad/s or m/s: v >= 0 (0 means none).
    Speed,
    /// An effort limit, N m or N: 0 <= v <= 1e6 (0 means none).
    Effort,
    /// A mimic multiplier or offset: |v| <= 1000.
    Mimic,
    /// An axis component: any finite number (the axis is normalized).
    Direction,
}

impl Quantity {
    /// `value` if it is finite and in range; `element` names it in the error.
    pub(super) fn check(self, value: f64, element: impl FnOnce() -> String) -> Result<f64, UrdfError> {
        if !value.is_finite() {
            return Err(UrdfError::NotFinite { element: element() });
        }
        let (ok, range) = match self {
            Quantity::Position => (value.abs() <= MAX_LENGTH_M, "from -1000 to 1000 m"),
            Quantity::Size => ((0.0..=MAX_LENGTH_M).contains(&value), "from 0 to 1000 m"),
            Quantity::Angle => (value.abs() <= MAX_ANGLE_RAD, "from -1000 to 1000 rad"),
            Quantity::Mass => ((0.0..=MAX_MASS_KG).contains(&value), "from 0 to 1e6 kg"),
            Quantity::Speed => (value >= 0.0, "0 (no limit) or more"),
            Quantity::Effort => ((0.0..=MAX_EFFORT).contains(&value), "0 (no limit) to 1e6 N m or N"),
            Quantity::Mimic => (value.abs() <= MAX_MIMIC, "from -1000 to 1000"),
            Quantity::Direction => (true, ""),
        };
        if ok {
            Ok(value)
        } else {
            Err(UrdfError::OutOfRange { element: element(), value, range })
        }
    }
}
