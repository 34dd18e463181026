//! rmw_zenoh's names: the key expression a topic's data travels on, the
//! QoS text and the liveliness tokens that announce a node and its
//! publishers to the ROS 2 graph, and the GID derived from a token
//! (rmw_zenoh's `liveliness_utils.cpp`, `qos.cpp`).

use crate::ros::schema::MsgType;

/// The prefix of every liveliness token of the ROS 2 graph.
pub const ADMIN_SPACE: &str = "@ros2_lv";

/// Which type hashes go into key expressions and tokens.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum TypeHashes {
    /// RIHS01 hashes of REP 2011 (Jazzy and later).
    #[default]
    Rihs01,
    /// `TypeHashNotSupported`, as Humble's rmw_zenoh sends.
    NotSupported,
}

impl TypeHashes {
    /// The hash text of `ty`.
    pub fn of(self, ty: &MsgType) -> String {
        match self {
            TypeHashes::Rihs01 => ty.rihs01(),
            TypeHashes::NotSupported => "TypeHashNotSupported".to_owned(),
        }
    }
}

/// `pkg/msg/Type` as rmw_zenoh names it: `pkg::msg::dds_::Type_`.
pub fn dds_type_name(ty: &MsgType) -> String {
    dds_type_name_of(ty.name)
}

/// [`dds_type_name`] of a type's full name.
pub fn dds_type_name_of(name: &str) -> String {
    let mut parts = name.split('/');
    match (parts.next(), parts.next(), parts.next()) {
        (Some(pkg), Some(kind), Some(name)) => format!("{pkg}::{kind}::dds_::{name}_"),
        _ => name.replace('/', "::"),
    }
}

/// The key expression `topic`'s data travels on:
/// `<domain>/<topic without its outer slashes>/<dds type>/<hash>`.
pub fn topic_key(domain: u32, topic: &str, ty: &MsgType, hashes: TypeHashes) -> String {
    format!("{domain}/{}/{}/{}", topic.trim_matches('/'), dds_type_name(ty), hashes.of(ty))
}

/// A publisher's QoS, as far as the skin sets it: reliable, keep last
/// `depth`, volatile or transient local; the rest at rmw_zenoh's defaults.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Qos {
    /// Keep-last depth.
    pub depth: u32,
    /// Late subscribers get the last `depth` messages (`/tf_static`, `/robot_description`).
    pub transient_local: bool,
}

/// rmw_zenoh's default depth (`qos.cpp`): left out of the QoS text.
const DEFAULT_DEPTH: u32 = 42;
/// `RMW_QOS_POLICY_DURABILITY_TRANSIENT_LOCAL`.
const TRANSIENT_LOCAL: u8 = 1;

impl Qos {
    /// rmw_zenoh's QoS text: `reliability:durability:history,depth:deadline:lifespan:liveliness`,
    /// each field empty where it is rmw_zenoh's default (reliable,
    /// volatile, keep last 42, infinite durations, automatic liveliness).
    pub fn key(&self) -> String {
        let durability = if self.transient_local { TRANSIENT_LOCAL.to_string() } else { String::new() };
        let depth = if self.depth == DEFAULT_DEPTH { String::new() } else { self.depth.to_string() };
        format!(":{durability}:,{depth}:,:,:,,")
    }
}

/// `/` in a name becomes `%` inside a token (an empty namespace `/` is `%`).
fn mangle(name: &str) -> String {
    name.replace('/', "%")
}

/// Who announces: the node's domain, Zenoh session ID and name (in the
/// root namespace and the default enclave).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct NodeName {
    /// The ROS domain ID.
    pub domain: u32,
    /// The Zenoh session's ID, as Zenoh prints it.
    pub zid: String,
    /// The node's name.
    pub name: String,
}

impl NodeName {
    fn prefix(&self, entity_id: u32, kind: &str) -> String {
        format!("{ADMIN_SPACE}/{}/{}/0/{entity_id}/{kind}/%/%/{}", self.domain, self.zid, mangle(&self.name))
    }

    /// The node's token: `@ros2_lv/<domain>/<zid>/0/0/NN/%/%/<name>`.
    pub fn node_token(&self) -> String {
        self.prefix(0, "NN")
    }

    /// Publisher `entity_id`'s token on `topic`:
    /// `…/<entity_id>/MP/%/%/<name>/<topic>/<dds type>/<hash>/<qos>`.
    pub fn publisher_token(&self, entity_id: u32, topic: &str, ty: &MsgType, hashes: TypeHashes, qos: Qos) -> String {
        format!(
            "{}/{}/{}/{}/{}",
            self.prefix(entity_id, "MP"),
            mangle(topic),
            dds_type_name(ty),
            hashes.of(ty),
            qos.key()
        )
    }
}

/// An entity's GID: the XXH3 128-bit hash of its token, low half first,
/// as rmw_zenoh derives it.
pub fn gid(token: &str) -> [u8; 16] {
    let h = xxhash_rust::xxh3::xxh3_128(token.as_bytes());
    let mut gid = [0; 16];
    gid[..8].copy_from_slice(&(h as u64).to_le_bytes());
    gid[8..].copy_from_slice(&((h >> 64) as u64).to_le_bytes());
    gid
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ros::schema::{POINT_CLOUD2, TF_MESSAGE};

    fn node() -> NodeName {
        NodeName { domain: 0, zid: "1a2b".into(), name: "skin".into() }
    }

    #[test]
    fn topic_keys_follow_rmw_zenoh() {
        let key = topic_key(0, "/skin/cells", &POINT_CLOUD2, TypeHashes::NotSupported);
        assert_eq!(key, "0/skin/cells/sensor_msgs::msg::dds_::PointCloud2_/TypeHashNotSupported");
        let key = topic_key(7, "/tf_static", &TF_MESSAGE, TypeHashes::Rihs01);
        assert_eq!(key, format!("7/tf_static/tf2_msgs::msg::dds_::TFMessage_/{}", TF_MESSAGE.rihs01()));
    }

    #[test]
    fn qos_text_leaves_defaults_empty() {
        assert_eq!(Qos { depth: 42, transient_local: false }.key(), "::,:,:,:,,");
        assert_eq!(Qos { depth: 10, transient_local: false }.key(), "::,10:,:,:,,");
        assert_eq!(Qos { depth: 1, transient_local: true }.key(), ":1:,1:,:,:,,");
    }

    #[test]
    fn tokens_name_the_node_and_its_publishers() {
        assert_eq!(node().node_token(), "@ros2_lv/0/1a2b/0/0/NN/%/%/skin");
        let qos = Qos { depth: 1, transient_local: true };
        assert_eq!(
            node().publisher_token(3, "/tf_static", &TF_MESSAGE, TypeHashes::NotSupported, qos),
            "@ros2_lv/0/1a2b/0/3/MP/%/%/skin/%tf_static/tf2_msgs::msg::dds_::TFMessage_/TypeHashNotSupported/:1:,1:,:,:,,"
        );
    }

    #[test]
    fn gids_are_xxh3_128_of_the_token() {
        // XXH3-128 as Python's `xxhash` (the xxHash C library) computes it, low half first.
        let bytes = |h: u128| {
            let mut want = [0u8; 16];
            want[..8].copy_from_slice(&(h as u64).to_le_bytes());
            want[8..].copy_from_slice(&((h >> 64) as u64).to_le_bytes());
            want
        };
        assert_eq!(gid(""), bytes(0x99aa06d3014798d86001c324468d497f));
        let qos = Qos { depth: 1, transient_local: true };
        let token = node().publisher_token(3, "/tf_static", &TF_MESSAGE, TypeHashes::NotSupported, qos);
        assert_eq!(gid(&token), bytes(0xcaceb4bbdb165fd588d1baded12b8637));
    }
}
