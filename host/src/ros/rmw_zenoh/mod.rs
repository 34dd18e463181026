//! The skin's ROS 2 topics live over Zenoh, in rmw_zenoh's format, so a
//! ROS 2 machine running `rmw_zenoh_cpp` sees them with `ros2 topic
//! list/echo`, RViz and robot_state_publisher, with no bridge.
//!
//! As rmw_zenoh does ([`keys`], [`attachment`]): a topic's CDR messages
//! travel on `<domain>/<topic>/<pkg>::msg::dds_::<Type>_/<type hash>`,
//! each with an attachment (sequence number, source timestamp, GID); a
//! liveliness token announces the node and each publisher; transient-local
//! topics (`/tf_static`, `/robot_description`) are published through
//! zenoh-ext's advanced publisher with a cache of the last message, which
//! late-joining rmw_zenoh subscribers query. The session is a peer with
//! multicast scouting off, listening on `tcp/127.0.0.1:0` unless told, and
//! connecting to the routers or peers it is given.

pub mod attachment;
pub mod keys;
mod node;

pub use keys::TypeHashes;
pub use node::Node;

/// How the node joins the ROS 2 graph.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ZenohConfig {
    /// Zenoh endpoints to connect to (`tcp/HOST:PORT`: an `rmw_zenohd` router or peers).
    pub connect: Vec<String>,
    /// Zenoh endpoints to listen on; empty is `tcp/127.0.0.1:0`.
    pub listen: Vec<String>,
    /// The ROS domain ID.
    pub domain: u32,
    /// The node's name.
    pub node: String,
    /// RIHS01 hashes (Jazzy and later) or none (Humble).
    pub hashes: TypeHashes,
}

impl Default for ZenohConfig {
    fn default() -> ZenohConfig {
        ZenohConfig {
            connect: Vec::new(),
            listen: Vec::new(),
            domain: 0,
            node: "skin".to_owned(),
            hashes: TypeHashes::Rihs01,
        }
    }
}

/// Why the node could not join.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ZenohError {
    /// An endpoint or setting Zenoh does not accept.
    #[error("zenoh configuration {key} = {value}: {source} (endpoints look like tcp/192.168.1.10:7447)")]
    Config {
        /// The setting.
        key: &'static str,
        /// The value given.
        value: String,
        /// What Zenoh said.
        #[source]
        source: zenoh::Error,
    },
    /// The session did not open (a listen endpoint taken, a connect endpoint unreachable).
    #[error("zenoh session did not open: {0} (check --zenoh-listen and --zenoh-connect)")]
    Open(#[source] zenoh::Error),
    /// A liveliness token or publisher could not be declared.
    #[error("zenoh could not declare {what}: {source}")]
    Declare {
        /// The key expression.
        what: String,
        /// What Zenoh said.
        #[source]
        source: zenoh::Error,
    },
}
