//! ROS 2 message types described once, as data: each [`MsgType`] gives
//! its `ros2msg` definition text (what MCAP files carry as the schema) and
//! its RIHS01 type hash (what rmw_zenoh puts in key expressions and
//! rosbag2 in its metadata), both derived from the same field list, so
//! the two cannot drift apart. The encoders in [`super::msgs`] write the
//! fields in the order listed here.

use std::fmt::Write;

use sha2::{Digest, Sha256};

/// The element type of a field.
#[derive(Clone, Copy, Debug)]
pub enum Base {
    /// `bool`.
    Bool,
    /// `uint8`.
    U8,
    /// `int32`.
    I32,
    /// `uint32`.
    U32,
    /// `float32`.
    F32,
    /// `float64`.
    F64,
    /// `string` (unbounded).
    Str,
    /// Another message.
    Msg(&'static MsgType),
}

/// How many elements a field holds.
#[derive(Clone, Copy, Debug)]
pub enum Shape {
    /// One.
    One,
    /// A fixed-size array of that many.
    Array(u32),
    /// An unbounded sequence.
    Seq,
}

/// One field of a message.
#[derive(Debug)]
pub struct Field {
    /// Its name.
    pub name: &'static str,
    /// Its element type.
    pub base: Base,
    /// Its count.
    pub shape: Shape,
}

/// A message type: its full name (`pkg/msg/Type`) and fields in wire order.
#[derive(Debug)]
pub struct MsgType {
    /// `pkg/msg/Type`.
    pub name: &'static str,
    /// The fields, in wire order.
    pub fields: &'static [Field],
}

const fn f(name: &'static str, base: Base) -> Field {
    Field { name, base, shape: Shape::One }
}

const fn seq(name: &'static str, base: Base) -> Field {
    Field { name, base, shape: Shape::Seq }
}

const fn array(name: &'static str, base: Base, n: u32) -> Field {
    Field { name, base, shape: Shape::Array(n) }
}

/// `builtin_interfaces/msg/Time`.
pub static TIME: MsgType =
    MsgType { name: "builtin_interfaces/msg/Time", fields: &[f("sec", Base::I32), f("nanosec", Base::U32)] };
/// `builtin_interfaces/msg/Duration`.
pub static DURATION: MsgType =
    MsgType { name: "builtin_interfaces/msg/Duration", fields: &[f("sec", Base::I32), f("nanosec", Base::U32)] };
/// `std_msgs/msg/Header`.
pub static HEADER: MsgType =
    MsgType { name: "std_msgs/msg/Header", fields: &[f("stamp", Base::Msg(&TIME)), f("frame_id", Base::Str)] };
/// `std_msgs/msg/String`.
pub static STRING: MsgType = MsgType { name: "std_msgs/msg/String", fields: &[f("data", Base::Str)] };
/// `std_msgs/msg/ColorRGBA`.
pub static COLOR_RGBA: MsgType = MsgType {
    name: "std_msgs/msg/ColorRGBA",
    fields: &[f("r", Base::F32), f("g", Base::F32), f("b", Base::F32), f("a", Base::F32)],
};
/// `geometry_msgs/msg/Vector3`.
pub static VECTOR3: MsgType =
    MsgType { name: "geometry_msgs/msg/Vector3", fields: &[f("x", Base::F64), f("y", Base::F64), f("z", Base::F64)] };
/// `geometry_msgs/msg/Point`.
pub static POINT: MsgType =
    MsgType { name: "geometry_msgs/msg/Point", fields: &[f("x", Base::F64), f("y", Base::F64), f("z", Base::F64)] };
/// `geometry_msgs/msg/Quaternion`.
pub static QUATERNION: MsgType = MsgType {
    name: "geometry_msgs/msg/Quaternion",
    fields: &[f("x", Base::F64), f("y", Base::F64), f("z", Base::F64), f("w", Base::F64)],
};
/// `geometry_msgs/msg/Pose`.
pub static POSE: MsgType = MsgType {
    name: "geometry_msgs/msg/Pose",
    fields: &[f("position", Base::Msg(&POINT)), f("orientation", Base::Msg(&QUATERNION))],
};
/// `geometry_msgs/msg/Transform`.
pub static TRANSFORM: MsgType = MsgType {
    name: "geometry_msgs/msg/Transform",
    fields: &[f("translation", Base::Msg(&VECTOR3)), f("rotation", Base::Msg(&QUATERNION))],
};
/// `geometry_msgs/msg/TransformStamped`.
pub static TRANSFORM_STAMPED: MsgType = MsgType {
    name: "geometry_msgs/msg/TransformStamped",
    fields: &[f("header", Base::Msg(&HEADER)), f("child_frame_id", Base::Str), f("transform", Base::Msg(&TRANSFORM))],
};
/// `tf2_msgs/msg/TFMessage`.
pub static TF_MESSAGE: MsgType =
    MsgType { name: "tf2_msgs/msg/TFMessage", fields: &[seq("transforms", Base::Msg(&TRANSFORM_STAMPED))] };
/// `sensor_msgs/msg/PointField`.
pub static POINT_FIELD: MsgType = MsgType {
    name: "sensor_msgs/msg/PointField",
    fields: &[f("name", Base::Str), f("offset", Base::U32), f("datatype", Base::U8), f("count", Base::U32)],
};
/// `sensor_msgs/msg/PointCloud2`.
pub static POINT_CLOUD2: MsgType = MsgType {
    name: "sensor_msgs/msg/PointCloud2",
    fields: &[
        f("header", Base::Msg(&HEADER)),
        f("height", Base::U32),
        f("width", Base::U32),
        seq("fields", Base::Msg(&POINT_FIELD)),
        f("is_bigendian", Base::Bool),
        f("point_step", Base::U32),
        f("row_step", Base::U32),
        seq("data", Base::U8),
        f("is_dense", Base::Bool),
    ],
};
/// `sensor_msgs/msg/Imu`.
pub static IMU: MsgType = MsgType {
    name: "sensor_msgs/msg/Imu",
    fields: &[
        f("header", Base::Msg(&HEADER)),
        f("orientation", Base::Msg(&QUATERNION)),
        array("orientation_covariance", Base::F64, 9),
        f("angular_velocity", Base::Msg(&VECTOR3)),
        array("angular_velocity_covariance", Base::F64, 9),
        f("linear_acceleration", Base::Msg(&VECTOR3)),
        array("linear_acceleration_covariance", Base::F64, 9),
    ],
};
/// `sensor_msgs/msg/JointState`.
pub static JOINT_STATE: MsgType = MsgType {
    name: "sensor_msgs/msg/JointState",
    fields: &[
        f("header", Base::Msg(&HEADER)),
        seq("name", Base::Str),
        seq("position", Base::F64),
        seq("velocity", Base::F64),
        seq("effort", Base::F64),
    ],
};
/// `sensor_msgs/msg/CompressedImage` (a part of every `Marker`).
pub static COMPRESSED_IMAGE: MsgType = MsgType {
    name: "sensor_msgs/msg/CompressedImage",
    fields: &[f("header", Base::Msg(&HEADER)), f("format", Base::Str), seq("data", Base::U8)],
};
/// `visualization_msgs/msg/UVCoordinate`.
pub static UV_COORDINATE: MsgType =
    MsgType { name: "visualization_msgs/msg/UVCoordinate", fields: &[f("u", Base::F32), f("v", Base::F32)] };
/// `visualization_msgs/msg/MeshFile`.
pub static MESH_FILE: MsgType =
    MsgType { name: "visualization_msgs/msg/MeshFile", fields: &[f("filename", Base::Str), seq("data", Base::U8)] };
/// `visualization_msgs/msg/Marker`.
pub static MARKER: MsgType = MsgType {
    name: "visualization_msgs/msg/Marker",
    fields: &[
        f("header", Base::Msg(&HEADER)),
        f("ns", Base::Str),
        f("id", Base::I32),
        f("type", Base::I32),
        f("action", Base::I32),
        f("pose", Base::Msg(&POSE)),
        f("scale", Base::Msg(&VECTOR3)),
        f("color", Base::Msg(&COLOR_RGBA)),
        f("lifetime", Base::Msg(&DURATION)),
        f("frame_locked", Base::Bool),
        seq("points", Base::Msg(&POINT)),
        seq("colors", Base::Msg(&COLOR_RGBA)),
        f("texture_resource", Base::Str),
        f("texture", Base::Msg(&COMPRESSED_IMAGE)),
        seq("uv_coordinates", Base::Msg(&UV_COORDINATE)),
        f("text", Base::Str),
        f("mesh_resource", Base::Str),
        f("mesh_file", Base::Msg(&MESH_FILE)),
        f("mesh_use_embedded_materials", Base::Bool),
    ],
};
/// `visualization_msgs/msg/MarkerArray`.
pub static MARKER_ARRAY: MsgType =
    MsgType { name: "visualization_msgs/msg/MarkerArray", fields: &[seq("markers", Base::Msg(&MARKER))] };
/// `skin_msgs/msg/Datagram`: one datagram of the skin's interface or the
/// robot link as it crossed the wire, with when the host took it and from
/// whom. Not a ROS package: its definition travels in every file.
pub static DATAGRAM: MsgType = MsgType {
    name: "skin_msgs/msg/Datagram",
    fields: &[f("stamp", Base::Msg(&TIME)), f("source", Base::Str), seq("data", Base::U8)],
};

/// Every type this crate writes, for tests and for listing.
pub static ALL: [&MsgType; 21] = [
    &TIME,
    &DURATION,
    &HEADER,
    &STRING,
    &COLOR_RGBA,
    &VECTOR3,
    &POINT,
    &QUATERNION,
    &POSE,
    &TRANSFORM,
    &TRANSFORM_STAMPED,
    &TF_MESSAGE,
    &POINT_FIELD,
    &POINT_CLOUD2,
    &IMU,
    &JOINT_STATE,
    &COMPRESSED_IMAGE,
    &UV_COORDINATE,
    &MESH_FILE,
    &MARKER,
    &MARKER_ARRAY,
];

impl MsgType {
    /// The name as `.msg` files write it: `pkg/Type`.
    pub fn short_name(&self) -> String {
        self.name.replacen("/msg/", "/", 1)
    }

    /// Every message type this one uses, directly or not, each once, in
    /// the order first met depth first.
    pub fn dependencies(&self) -> Vec<&'static MsgType> {
        fn walk(t: &MsgType, out: &mut Vec<&'static MsgType>) {
            for field in t.fields {
                if let Base::Msg(m) = field.base {
                    if !out.iter().any(|o| o.name == m.name) {
                        out.push(m);
                        walk(m, out);
                    }
                }
            }
        }
        let mut out = Vec::new();
        walk(self, &mut out);
        out
    }

    /// The `ros2msg` schema MCAP carries: this type's definition, then
    /// each dependency's after a line of 80 `=` and `MSG: pkg/Type`.
    pub fn ros2msg(&self) -> String {
        let mut text = self.definition();
        for dep in self.dependencies() {
            let _ = write!(text, "{}\nMSG: {}\n{}", "=".repeat(80), dep.short_name(), dep.definition());
        }
        text
    }

    /// The `.msg` text of this type alone.
    fn definition(&self) -> String {
        let mut text = String::new();
        for field in self.fields {
            let base = match field.base {
                Base::Msg(m) => m.short_name(),
                other => primitive(other).0.to_owned(),
            };
            let shape = match field.shape {
                Shape::One => String::new(),
                Shape::Array(n) => format!("[{n}]"),
                Shape::Seq => "[]".to_owned(),
            };
            let _ = writeln!(text, "{base}{shape} {}", field.name);
        }
        text
    }

    /// The RIHS01 hash of REP 2011: SHA-256 of the type description and
    /// every referenced one (sorted by name, default values left out) as
    /// Python's `json.dumps` writes them.
    pub fn rihs01(&self) -> String {
        let mut refs = self.dependencies();
        refs.sort_by_key(|t| t.name);
        let referenced: Vec<String> = refs.iter().map(|t| t.description_json()).collect();
        let json = format!(
            "{{\"type_description\": {}, \"referenced_type_descriptions\": [{}]}}",
            self.description_json(),
            referenced.join(", ")
        );
        let digest = Sha256::digest(json.as_bytes());
        let mut out = String::from("RIHS01_");
        for byte in digest {
            let _ = write!(out, "{byte:02x}");
        }
        out
    }

    fn description_json(&self) -> String {
        let fields: Vec<String> = self
            .fields
            .iter()
            .map(|field| {
                let (base_id, nested) = match field.base {
                    Base::Msg(m) => (1, m.name),
                    other => (primitive(other).1, ""),
                };
                let (offset, capacity) = match field.shape {
                    Shape::One => (0, 0),
                    Shape::Array(n) => (48, n),
                    Shape::Seq => (144, 0),
                };
                format!(
                    "{{\"name\": \"{}\", \"type\": {{\"type_id\": {}, \"capacity\": {capacity}, \"string_capacity\": 0, \"nested_type_name\": \"{nested}\"}}}}",
                    field.name,
                    base_id + offset
                )
            })
            .collect();
        format!("{{\"type_name\": \"{}\", \"fields\": [{}]}}", self.name, fields.join(", "))
    }
}

/// A primitive's `.msg` name and its `type_description_interfaces/FieldType` ID.
fn primitive(base: Base) -> (&'static str, u32) {
    match base {
        Base::Bool => ("bool", 15),
        Base::U8 => ("uint8", 3),
        Base::I32 => ("int32", 6),
        Base::U32 => ("uint32", 7),
        Base::F32 => ("float32", 10),
        Base::F64 => ("float64", 11),
        Base::Str => ("string", 17),
        Base::Msg(_) => ("", 1),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_schema_lists_each_dependency_once_after_the_type() {
        let text = TF_MESSAGE.ros2msg();
        assert!(text.starts_with("geometry_msgs/TransformStamped[] transforms\n"), "{text}");
        for dep in ["std_msgs/Header", "builtin_interfaces/Time", "geometry_msgs/Quaternion"] {
            assert_eq!(text.matches(&format!("MSG: {dep}\n")).count(), 1, "{dep} in {text}");
        }
    }

    #[test]
    fn hashes_are_distinct_and_well_formed() {
        let hashes: std::collections::HashSet<String> = ALL.iter().map(|t| t.rihs01()).collect();
        assert_eq!(hashes.len(), ALL.len());
        assert!(hashes.iter().all(|h| h.len() == 7 + 64 && h.starts_with("RIHS01_")));
    }
}
