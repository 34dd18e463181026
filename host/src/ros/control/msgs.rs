//! The messages of a ros2_control robot, as serde types RustDDS encodes
//! in CDR: `sensor_msgs/JointState` from joint_state_broadcaster,
//! `std_msgs/Float64MultiArray` to forward_command_controller, and
//! `std_msgs/String` of robot_state_publisher's `/robot_description`.

use serde::{Deserialize, Serialize};

/// `builtin_interfaces/Time`.
#[derive(Clone, Debug, Default, Serialize, Deserialize, PartialEq)]
pub struct Time {
    /// Seconds.
    pub sec: i32,
    /// Nanoseconds.
    pub nanosec: u32,
}

/// `std_msgs/Header`.
#[derive(Clone, Debug, Default, Serialize, Deserialize, PartialEq)]
pub struct Header {
    /// When.
    pub stamp: Time,
    /// Frame.
    pub frame_id: String,
}

impl Header {
    /// The stamp in seconds.
    pub fn stamp_s(&self) -> f64 {
        f64::from(self.stamp.sec) + f64::from(self.stamp.nanosec) * 1e-9
    }
}

/// `sensor_msgs/JointState`: positions (and more) by joint name.
#[derive(Clone, Debug, Default, Serialize, Deserialize, PartialEq)]
pub struct JointState {
    /// Header.
    pub header: Header,
    /// Joint names.
    pub name: Vec<String>,
    /// Positions, rad or m, one per name.
    pub position: Vec<f64>,
    /// Velocities (may be empty).
    pub velocity: Vec<f64>,
    /// Efforts (may be empty).
    pub effort: Vec<f64>,
}

/// `std_msgs/String`: the URDF on `/robot_description`.
#[derive(Clone, Debug, Default, Serialize, Deserialize, PartialEq)]
pub struct Text {
    /// The text.
    pub data: String,
}

/// `std_msgs/MultiArrayDimension`.
#[derive(Clone, Debug, Default, Serialize, Deserialize, PartialEq)]
pub struct MultiArrayDimension {
    /// Label.
    pub label: String,
    /// Size.
    pub size: u32,
    /// Stride.
    pub stride: u32,
}

/// `std_msgs/MultiArrayLayout`.
#[derive(Clone, Debug, Default, Serialize, Deserialize, PartialEq)]
pub struct MultiArrayLayout {
    /// Dimensions (forward_command_controller ignores them).
    pub dim: Vec<MultiArrayDimension>,
    /// Offset of the first element.
    pub data_offset: u32,
}

/// `std_msgs/Float64MultiArray`: one velocity per controller joint, in
/// the order of its `joints` parameter.
#[derive(Clone, Debug, Default, Serialize, Deserialize, PartialEq)]
pub struct Float64MultiArray {
    /// Layout (empty: a flat array).
    pub layout: MultiArrayLayout,
    /// The values.
    pub data: Vec<f64>,
}

impl Float64MultiArray {
    /// A flat array of `data`.
    pub fn flat(data: Vec<f64>) -> Float64MultiArray {
        Float64MultiArray { layout: MultiArrayLayout::default(), data }
    }
}

impl JointState {
    /// The position of every joint of `joints` (by name), or the first
    /// one it lacks or whose position is missing or not finite.
    pub fn positions_of<'a>(&self, joints: &'a [String]) -> Result<Vec<f64>, &'a str> {
        joints
            .iter()
            .map(|j| {
                self.name
                    .iter()
                    .position(|n| n == j)
                    .and_then(|i| self.position.get(i).copied())
                    .filter(|q| q.is_finite())
                    .ok_or(j.as_str())
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cdr<T: Serialize>(value: &T) -> Vec<u8> {
        let mut out = Vec::new();
        rustdds::serialization::to_writer_with_rep_id(&mut out, value, rustdds::RepresentationIdentifier::CDR_LE)
            .unwrap();
        out
    }

    #[test]
    fn a_joint_state_is_the_cdr_our_encoder_writes() {
        use crate::ros::msgs::{JointState as Ours, Message, Stamp};
        let ours = crate::ros::skin::joint_state(
            Stamp { sec: 3, nanosec: 4 },
            &["a".to_owned(), "b".to_owned()],
            &[0.5, -1.0],
        );
        let mut ours_cdr = crate::ros::cdr::Cdr::new();
        Ours::write(&ours, &mut ours_cdr);
        let theirs = JointState {
            header: Header { stamp: Time { sec: 3, nanosec: 4 }, frame_id: String::new() },
            name: vec!["a".to_owned(), "b".to_owned()],
            position: vec![0.5, -1.0],
            ..JointState::default()
        };
        assert_eq!(cdr(&theirs), ours_cdr.into_bytes()[4..]);
    }

    #[test]
    fn positions_are_taken_by_name_and_refused_when_missing_or_not_finite() {
        let state = JointState {
            name: vec!["b".into(), "a".into(), "c".into()],
            position: vec![2.0, 1.0, f64::NAN],
            ..JointState::default()
        };
        let joints = |names: &[&str]| names.iter().map(|s| s.to_string()).collect::<Vec<_>>();
        assert_eq!(state.positions_of(&joints(&["a", "b"])), Ok(vec![1.0, 2.0]));
        assert_eq!(state.positions_of(&joints(&["a", "z"])), Err("z"));
        assert_eq!(state.positions_of(&joints(&["c"])), Err("c"));
    }
}
