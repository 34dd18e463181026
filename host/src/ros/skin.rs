//! The skin as ROS 2 topics: what the host knows (the latest sample of
//! every cell, tactile events, the robot's positions, the learned tree)
//! turned into core messages every ROS 2 installation has, so RViz,
//! Foxglove and `ros2 bag` need no plugin and no custom package.
//!
//! Cells sit at their [`CellPose`]. Until the pose calibration fills the
//! poses in, a cell is at the origin of the body part it was learned on
//! (`skin_part_K`; `skin_part_0` is the root, also before the exploration).

use std::collections::BTreeMap;
use std::fmt::Write;

use skin_protocol::message::{AccelRange, Channel, G0};
use skin_protocol::{Address, Sample};

use super::msgs::{
    Header, Imu, JointState, Marker, MarkerArray, PointCloud2, PointField, Stamp, StringMsg, TfMessage,
    TransformStamped, ADD, DELETE, FLOAT32, SPHERE, UINT16,
};
use crate::explore::Exploration;
use crate::interface::{Event, EventKind};

/// `/skin/cells`: one point per cell.
pub const CELLS: &str = "/skin/cells";
/// `/skin/imu`: one message per cell, its frame in the header.
pub const IMU: &str = "/skin/imu";
/// `/skin/events`: tactile levels as markers.
pub const EVENTS: &str = "/skin/events";
/// `/joint_states`.
pub const JOINT_STATES: &str = "/joint_states";
/// `/tf_static`: a frame per cell (transient local).
pub const TF_STATIC: &str = "/tf_static";
/// `/robot_description`: the learned tree with the skin's frames, as URDF (transient local).
pub const ROBOT_DESCRIPTION: &str = "/robot_description";

/// How a topic's publishers keep history.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Keep {
    /// Keep-last depth.
    pub depth: u32,
    /// Late subscribers get the last `depth` messages (transient local).
    pub latched: bool,
}

/// How `topic` is kept: the description and the cells' frames latched,
/// the last one; the rest rclcpp's usual 10.
pub fn keep(topic: &str) -> Keep {
    match topic {
        TF_STATIC | ROBOT_DESCRIPTION => Keep { depth: 1, latched: true },
        _ => Keep { depth: 10, latched: false },
    }
}

/// Full scale of one force cell, N (Table 1: 0-10 N).
const FORCE_FULL_SCALE_N: f32 = 10.0;

/// Where a cell is: in which frame, at which position and orientation.
#[derive(Clone, Debug, PartialEq)]
pub struct CellPose {
    /// The cell's ID.
    pub id: u16,
    /// The frame it is attached to (a body part's or a URDF link's).
    pub frame: String,
    /// Position in that frame, m.
    pub xyz: [f64; 3],
    /// Orientation in that frame: roll, pitch, yaw, rad.
    pub rpy: [f64; 3],
}

/// The frame of learned body part `k`.
pub fn part_frame(k: usize) -> String {
    format!("skin_part_{k}")
}

/// The frame of cell `id`.
pub fn cell_frame(id: u16) -> String {
    format!("skin_cell_{id}")
}

/// Every explored cell at the origin of the body part it was learned on.
pub fn poses_on_parts(exploration: &Exploration) -> Vec<CellPose> {
    let mut poses: Vec<CellPose> = exploration
        .tree
        .body_parts()
        .iter()
        .enumerate()
        .flat_map(|(k, part)| {
            part.cells.iter().map(move |c| CellPose { id: c.0, frame: part_frame(k), xyz: [0.0; 3], rpy: [0.0; 3] })
        })
        .collect();
    poses.sort_by_key(|p| p.id);
    poses
}

/// The quaternion (x, y, z, w) of roll, pitch, yaw.
fn quaternion([roll, pitch, yaw]: [f64; 3]) -> [f64; 4] {
    let (sr, cr) = (roll / 2.0).sin_cos();
    let (sp, cp) = (pitch / 2.0).sin_cos();
    let (sy, cy) = (yaw / 2.0).sin_cos();
    [sr * cp * cy - cr * sp * sy, cr * sp * cy + sr * cp * sy, cr * cp * sy - sr * sp * cy, cr * cp * cy + sr * sp * sy]
}

/// The point layout of `/skin/cells`: position, then the cell's ID and
/// sensors in SI units (proximity normalized to 0-1 as in Table 3).
const POINT_FIELDS: [(&str, u32, u8); 9] = [
    ("x", 0, FLOAT32),
    ("y", 4, FLOAT32),
    ("z", 8, FLOAT32),
    ("proximity", 12, FLOAT32),
    ("force", 16, FLOAT32),
    ("temperature", 20, FLOAT32),
    ("ax", 24, FLOAT32),
    ("ay", 28, FLOAT32),
    ("az", 32, FLOAT32),
];
/// The ID after the floats: `uint16` at byte 36, two bytes of padding.
const ID_OFFSET: u32 = 36;
const POINT_STEP: u32 = 40;

/// What the topics are made from, updated by the interface's events.
#[derive(Debug)]
pub struct SkinTopics {
    range: AccelRange,
    latest: BTreeMap<u16, Sample>,
    poses: BTreeMap<u16, CellPose>,
    contacts: Vec<Marker>,
}

impl SkinTopics {
    /// Nothing heard yet; accelerations are read in `range`.
    pub fn new(range: AccelRange) -> SkinTopics {
        SkinTopics { range, latest: BTreeMap::new(), poses: BTreeMap::new(), contacts: Vec::new() }
    }

    /// Sets the cells' poses (the exploration's or a calibration's).
    pub fn set_poses(&mut self, poses: Vec<CellPose>) {
        self.poses = poses.into_iter().map(|p| (p.id, p)).collect();
    }

    /// Takes what the skin said: samples become the cells' latest, and
    /// tactile level changes become contact markers.
    pub fn take(&mut self, events: &[Event], stamp: Stamp) {
        for e in events {
            match e.kind {
                EventKind::Sample(s) => {
                    self.latest.insert(e.cell.0, s);
                }
                EventKind::Tactile(t) => self.contacts.push(self.contact(e.cell, t.channel, t.level, stamp)),
                _ => {}
            }
        }
    }

    fn frame_of(&self, id: u16) -> String {
        self.poses.get(&id).map_or_else(|| part_frame(0), |p| p.frame.clone())
    }

    /// A tactile level as a sphere at the cell, one marker per cell and
    /// sensor (`ns` names the sensor, `id` is the cell), removed at level 0.
    fn contact(&self, cell: Address, channel: Channel, level: u8, stamp: Stamp) -> Marker {
        let position = self.poses.get(&cell.0).map_or([0.0; 3], |p| p.xyz);
        let (ns, rgb) = match channel {
            Channel::Proximity => ("skin/proximity", [0.2, 0.5, 1.0]),
            _ => ("skin/force", [1.0, 0.3, 0.1]),
        };
        let size = 0.01 + 0.01 * f64::from(level);
        Marker {
            header: Header { stamp, frame_id: self.frame_of(cell.0) },
            ns: format!("{ns}/{channel:?}"),
            id: i32::from(cell.0),
            kind: SPHERE,
            action: if level == 0 { DELETE } else { ADD },
            position,
            scale: [size; 3],
            color: [rgb[0], rgb[1], rgb[2], 0.25 + 0.1875 * f32::from(level.min(4))],
            lifetime: Stamp::default(),
            text: format!("cell {} {channel:?} level {level}", cell.0),
        }
    }

    /// The contact markers since the last call, if any.
    pub fn take_contacts(&mut self) -> Option<MarkerArray> {
        (!self.contacts.is_empty()).then(|| MarkerArray(std::mem::take(&mut self.contacts)))
    }

    fn accel_m_s2(&self, s: &Sample) -> [f64; 3] {
        s.accel().map(|a| f64::from(a) / self.range.counts_per_g() * G0)
    }

    /// `/skin/cells`: every cell heard, at its pose, with its latest sample.
    pub fn cloud(&self, stamp: Stamp) -> PointCloud2 {
        let mut fields: Vec<PointField> = POINT_FIELDS
            .iter()
            .map(|&(name, offset, datatype)| PointField { name, offset, datatype, count: 1 })
            .collect();
        fields.push(PointField { name: "id", offset: ID_OFFSET, datatype: UINT16, count: 1 });
        let mut data = Vec::with_capacity(self.latest.len() * POINT_STEP as usize);
        for (&id, s) in &self.latest {
            let xyz = self.poses.get(&id).map_or([0.0; 3], |p| p.xyz);
            let a = self.accel_m_s2(s);
            let force_n: f32 = s.force_norm().iter().map(|f| f * FORCE_FULL_SCALE_N).sum();
            let values = [xyz[0], xyz[1], xyz[2]].map(|v| v as f32).into_iter().chain([
                s.proximity_norm(),
                force_n,
                s.temperature_c(),
            ]);
            for v in values.chain(a.map(|v| v as f32)) {
                data.extend_from_slice(&v.to_le_bytes());
            }
            data.extend_from_slice(&id.to_le_bytes());
            data.extend_from_slice(&[0, 0]);
        }
        PointCloud2 { header: Header { stamp, frame_id: part_frame(0) }, fields, point_step: POINT_STEP, data }
    }

    /// `/skin/imu`: one message per cell heard, in the cell's frame.
    pub fn imus(&self, stamp: Stamp) -> Vec<Imu> {
        self.latest
            .iter()
            .map(|(&id, s)| Imu {
                header: Header { stamp, frame_id: cell_frame(id) },
                linear_acceleration: self.accel_m_s2(s),
            })
            .collect()
    }

    /// `/tf_static`: every cell's frame on its pose's frame.
    pub fn tf_static(&self, stamp: Stamp) -> TfMessage {
        TfMessage(
            self.poses
                .values()
                .map(|p| TransformStamped {
                    header: Header { stamp, frame_id: p.frame.clone() },
                    child_frame_id: cell_frame(p.id),
                    translation: p.xyz,
                    rotation: quaternion(p.rpy),
                })
                .collect(),
        )
    }
}

/// `/joint_states`: the robot's DoFs by name.
pub fn joint_state(stamp: Stamp, names: &[String], positions: &[f64]) -> JointState {
    JointState { header: Header { stamp, frame_id: String::new() }, name: names.to_vec(), position: positions.to_vec() }
}

/// `/robot_description`: the learned kinematic tree as URDF. A body part
/// is a link `skin_part_K`; a joint of several DoFs is a chain of one
/// URDF joint per DoF (named after the DoF, so `/joint_states` drives
/// it) through links `skin_part_K_dofN`; every cell is a link on a fixed
/// joint at its pose. The skin does not tell axes or offsets: every
/// joint turns about z at the parent's origin until a calibration says
/// otherwise.
pub fn robot_description(exploration: &Exploration, poses: &[CellPose]) -> StringMsg {
    let tree = &exploration.tree;
    let mut urdf = String::from("<?xml version=\"1.0\"?>\n<robot name=\"skin\">\n");
    for k in 0..tree.body_parts().len() {
        let _ = writeln!(urdf, "  <link name=\"{}\"/>", part_frame(k));
    }
    for joint in tree.joints() {
        let mut parent = part_frame(joint.parent);
        for (i, &dof) in joint.dofs.iter().enumerate() {
            let child = if i + 1 == joint.dofs.len() {
                part_frame(joint.child)
            } else {
                let link = format!("{}_dof{dof}", part_frame(joint.child));
                let _ = writeln!(urdf, "  <link name=\"{link}\"/>");
                link
            };
            let (kind, limits) = match exploration.dof_kinds.get(dof) {
                Some(skin_protocol::robot_link::DofKind::Prismatic) => ("prismatic", "-1 1"),
                _ => ("continuous", ""),
            };
            let _ = write!(
                urdf,
                "  <joint name=\"{}\" type=\"{kind}\"><parent link=\"{parent}\"/><child link=\"{child}\"/><axis xyz=\"0 0 1\"/>",
                xml_escape(&exploration.dof_names[dof])
            );
            if let Some((lower, upper)) = limits.split_once(' ') {
                let _ = write!(urdf, "<limit lower=\"{lower}\" upper=\"{upper}\" effort=\"0\" velocity=\"0\"/>");
            }
            urdf += "</joint>\n";
            parent = child;
        }
    }
    for p in poses {
        let _ = writeln!(
            urdf,
            "  <link name=\"{cell}\"/>\n  <joint name=\"{cell}_mount\" type=\"fixed\"><parent link=\"{}\"/><child link=\"{cell}\"/><origin xyz=\"{} {} {}\" rpy=\"{} {} {}\"/></joint>",
            xml_escape(&p.frame),
            p.xyz[0],
            p.xyz[1],
            p.xyz[2],
            p.rpy[0],
            p.rpy[1],
            p.rpy[2],
            cell = cell_frame(p.id),
        );
    }
    urdf += "</robot>\n";
    StringMsg(urdf)
}

/// `s` safe inside an XML attribute.
fn xml_escape(s: &str) -> String {
    s.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;").replace('"', "&quot;").replace('\'', "&apos;")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quaternions_of_quarter_turns() {
        let close = |a: [f64; 4], b: [f64; 4]| a.iter().zip(b).all(|(x, y)| (x - y).abs() < 1e-12);
        let h = std::f64::consts::FRAC_1_SQRT_2;
        assert!(close(quaternion([0.0; 3]), [0.0, 0.0, 0.0, 1.0]));
        assert!(close(quaternion([std::f64::consts::FRAC_PI_2, 0.0, 0.0]), [h, 0.0, 0.0, h]));
        assert!(close(quaternion([0.0, 0.0, std::f64::consts::FRAC_PI_2]), [0.0, 0.0, h, h]));
    }

    #[test]
    fn the_cloud_has_one_point_per_cell_in_si_units() {
        let mut topics = SkinTopics::new(AccelRange::G2);
        let sample = Sample::new(0, [4095, 0, 0], [256, 0, -256], 800, 0).unwrap();
        let event = Event { interface: 0, timestamp_us: 0, cell: Address(7), kind: EventKind::Sample(sample) };
        topics.take(&[event, Event { cell: Address(9), ..event }], Stamp::default());
        let cloud = topics.cloud(Stamp::default());
        assert_eq!(cloud.data.len(), 2 * POINT_STEP as usize);
        let f = |i: usize| f32::from_le_bytes(cloud.data[i..i + 4].try_into().unwrap());
        assert_eq!(f(16), 10.0, "one force cell at full scale is 10 N");
        assert_eq!(f(20), 25.0, "800 counts of 1/32 degree");
        assert!((f64::from(f(24)) - G0 * 256.0 / AccelRange::G2.counts_per_g()).abs() < 1e-4);
        assert_eq!(u16::from_le_bytes([cloud.data[36], cloud.data[37]]), 7);
        assert_eq!(u16::from_le_bytes([cloud.data[76], cloud.data[77]]), 9);
    }
}
