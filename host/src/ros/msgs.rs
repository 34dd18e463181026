//! The ROS 2 messages the skin publishes, as values with their CDR
//! encoding; each writes the fields its [`MsgType`] lists, in that order.

use super::cdr::Cdr;
use super::schema::{self, MsgType};

/// A message that can be written as CDR.
pub trait Message {
    /// Its type.
    const TYPE: &'static MsgType;
    /// Writes its fields.
    fn write(&self, c: &mut Cdr);
    /// The whole message: encapsulation header and fields, into `out`
    /// (cleared first; its allocation is reused).
    fn encode_into(&self, out: &mut Vec<u8>) {
        let mut c = Cdr::reusing(std::mem::take(out));
        self.write(&mut c);
        *out = c.into_bytes();
    }
    /// The whole message in a new buffer.
    fn to_cdr(&self) -> Vec<u8> {
        let mut out = Vec::new();
        self.encode_into(&mut out);
        out
    }
}

/// `builtin_interfaces/Time` (and `Duration`): whole seconds and nanoseconds.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Stamp {
    /// Seconds.
    pub sec: i32,
    /// Nanoseconds, below 1e9.
    pub nanosec: u32,
}

impl Stamp {
    /// The stamp of `ns` nanoseconds (saturating past 2038).
    pub fn from_nanos(ns: u64) -> Stamp {
        Stamp { sec: i32::try_from(ns / 1_000_000_000).unwrap_or(i32::MAX), nanosec: (ns % 1_000_000_000) as u32 }
    }

    fn write(&self, c: &mut Cdr) {
        c.i32(self.sec);
        c.u32(self.nanosec);
    }
}

/// `std_msgs/Header`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Header {
    /// When.
    pub stamp: Stamp,
    /// In which frame.
    pub frame_id: String,
}

impl Header {
    fn write(&self, c: &mut Cdr) {
        self.stamp.write(c);
        c.string(&self.frame_id);
    }
}

fn xyz(c: &mut Cdr, v: [f64; 3]) {
    v.iter().for_each(|x| c.f64(*x));
}

fn xyzw(c: &mut Cdr, q: [f64; 4]) {
    q.iter().for_each(|x| c.f64(*x));
}

/// `std_msgs/String`.
#[derive(Clone, Debug, PartialEq)]
pub struct StringMsg(pub String);

impl Message for StringMsg {
    const TYPE: &'static MsgType = &schema::STRING;
    fn write(&self, c: &mut Cdr) {
        c.string(&self.0);
    }
}

/// `sensor_msgs/PointField` datatype `FLOAT32`.
pub const FLOAT32: u8 = 7;
/// `sensor_msgs/PointField` datatype `UINT16`.
pub const UINT16: u8 = 4;

/// `sensor_msgs/PointField`.
#[derive(Clone, Debug, PartialEq)]
pub struct PointField {
    /// Field name.
    pub name: &'static str,
    /// Byte offset within a point.
    pub offset: u32,
    /// One of the datatype constants ([`FLOAT32`], [`UINT16`]).
    pub datatype: u8,
    /// Elements.
    pub count: u32,
}

/// `sensor_msgs/PointCloud2`, one row of points.
#[derive(Clone, Debug, PartialEq)]
pub struct PointCloud2 {
    /// Stamp and frame.
    pub header: Header,
    /// The layout of a point.
    pub fields: Vec<PointField>,
    /// Bytes per point.
    pub point_step: u32,
    /// The points, little endian, `point_step` bytes each.
    pub data: Vec<u8>,
}

impl Message for PointCloud2 {
    const TYPE: &'static MsgType = &schema::POINT_CLOUD2;
    fn write(&self, c: &mut Cdr) {
        self.header.write(c);
        let width = (self.data.len() / self.point_step.max(1) as usize) as u32;
        c.u32(1);
        c.u32(width);
        c.len(self.fields.len());
        for f in &self.fields {
            c.string(f.name);
            c.u32(f.offset);
            c.u8(f.datatype);
            c.u32(f.count);
        }
        c.bool(false);
        c.u32(self.point_step);
        c.u32(self.data.len() as u32);
        c.bytes(&self.data);
        c.bool(true);
    }
}

/// `sensor_msgs/Imu` of an accelerometer alone: orientation and angular
/// velocity unknown (covariance element 0 set to -1, as the message says).
#[derive(Clone, Debug, PartialEq)]
pub struct Imu {
    /// Stamp and the cell's frame.
    pub header: Header,
    /// Linear acceleration, m/s^2.
    pub linear_acceleration: [f64; 3],
}

impl Message for Imu {
    const TYPE: &'static MsgType = &schema::IMU;
    fn write(&self, c: &mut Cdr) {
        let mut unknown = [0.0; 9];
        unknown[0] = -1.0;
        self.header.write(c);
        xyzw(c, [0.0, 0.0, 0.0, 1.0]);
        unknown.iter().for_each(|x| c.f64(*x));
        xyz(c, [0.0; 3]);
        unknown.iter().for_each(|x| c.f64(*x));
        xyz(c, self.linear_acceleration);
        [0.0; 9].iter().for_each(|x| c.f64(*x));
    }
}

/// `sensor_msgs/JointState`: positions only.
#[derive(Clone, Debug, PartialEq)]
pub struct JointState {
    /// Stamp.
    pub header: Header,
    /// Joint names.
    pub name: Vec<String>,
    /// Positions, rad or m.
    pub position: Vec<f64>,
}

impl Message for JointState {
    const TYPE: &'static MsgType = &schema::JOINT_STATE;
    fn write(&self, c: &mut Cdr) {
        self.header.write(c);
        c.strings(&self.name);
        c.f64s(&self.position);
        c.f64s(&[]);
        c.f64s(&[]);
    }
}

/// `geometry_msgs/TransformStamped`.
#[derive(Clone, Debug, PartialEq)]
pub struct TransformStamped {
    /// Stamp and parent frame.
    pub header: Header,
    /// The child frame.
    pub child_frame_id: String,
    /// Translation, m.
    pub translation: [f64; 3],
    /// Rotation as a quaternion x, y, z, w.
    pub rotation: [f64; 4],
}

/// `tf2_msgs/TFMessage`.
#[derive(Clone, Debug, PartialEq)]
pub struct TfMessage(pub Vec<TransformStamped>);

impl Message for TfMessage {
    const TYPE: &'static MsgType = &schema::TF_MESSAGE;
    fn write(&self, c: &mut Cdr) {
        c.len(self.0.len());
        for t in &self.0 {
            t.header.write(c);
            c.string(&t.child_frame_id);
            xyz(c, t.translation);
            xyzw(c, t.rotation);
        }
    }
}

/// `visualization_msgs/Marker` type `SPHERE`.
pub const SPHERE: i32 = 2;
/// `visualization_msgs/Marker` action `ADD` (add or modify).
pub const ADD: i32 = 0;
/// `visualization_msgs/Marker` action `DELETE`.
pub const DELETE: i32 = 2;

/// `visualization_msgs/Marker`: a shape at a pose; no points, texture or mesh.
#[derive(Clone, Debug, PartialEq)]
pub struct Marker {
    /// Stamp and frame.
    pub header: Header,
    /// Namespace: with `id`, what identifies the marker.
    pub ns: String,
    /// ID within the namespace.
    pub id: i32,
    /// Shape ([`SPHERE`]).
    pub kind: i32,
    /// [`ADD`] or [`DELETE`].
    pub action: i32,
    /// Position in the frame, m.
    pub position: [f64; 3],
    /// Size, m.
    pub scale: [f64; 3],
    /// Colour r, g, b, a in 0..=1.
    pub color: [f32; 4],
    /// How long it stays without being renewed (zero: forever).
    pub lifetime: Stamp,
    /// A label.
    pub text: String,
}

/// `visualization_msgs/MarkerArray`.
#[derive(Clone, Debug, PartialEq)]
pub struct MarkerArray(pub Vec<Marker>);

impl Message for MarkerArray {
    const TYPE: &'static MsgType = &schema::MARKER_ARRAY;
    fn write(&self, c: &mut Cdr) {
        c.len(self.0.len());
        for m in &self.0 {
            m.header.write(c);
            c.string(&m.ns);
            c.i32(m.id);
            c.i32(m.kind);
            c.i32(m.action);
            xyz(c, m.position);
            xyzw(c, [0.0, 0.0, 0.0, 1.0]);
            xyz(c, m.scale);
            m.color.iter().for_each(|x| c.f32(*x));
            m.lifetime.write(c);
            c.bool(false);
            c.len(0); // points
            c.len(0); // colors
            c.string(""); // texture_resource
            Header::default().write(c); // texture: header, format, data
            c.string("");
            c.bytes(&[]);
            c.len(0); // uv_coordinates
            c.string(&m.text);
            c.string(""); // mesh_resource
            c.string(""); // mesh_file: filename, data
            c.bytes(&[]);
            c.bool(false);
        }
    }
}

/// `skin_msgs/Datagram`: the bytes of one datagram as they crossed the wire.
#[derive(Clone, Debug, PartialEq)]
pub struct Datagram<'a> {
    /// When the host took it (or sent it).
    pub stamp: Stamp,
    /// The peer's address.
    pub source: &'a str,
    /// The bytes.
    pub data: &'a [u8],
}

impl Message for Datagram<'_> {
    const TYPE: &'static MsgType = &schema::DATAGRAM;
    fn write(&self, c: &mut Cdr) {
        self.stamp.write(c);
        c.string(self.source);
        c.bytes(self.data);
    }
}
