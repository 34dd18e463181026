//! The skin's ROS 2 topics live over DDS/RTPS, the middleware ROS 2 uses
//! by default (Fast DDS in Humble, Jazzy and Kilted), so a stock ROS 2
//! installation sees them with `ros2 topic list/echo`, RViz and
//! robot_state_publisher with no change to its nodes.
//!
//! Built on `ros2-client` (RustDDS, pure Rust): it speaks RTPS as Fast DDS
//! and Cyclone DDS do, names topics and types as the ROS 2 RMWs do
//! (`rt/skin/cells`, `sensor_msgs::msg::dds_::PointCloud2_`), and
//! announces the node and its endpoints on `ros_discovery_info`, which is
//! how `ros2 node list` and rclpy's graph learn which node owns which
//! publisher. Messages are encoded once by [`crate::ros::cdr`] and handed
//! to RustDDS as they are ([`raw`]).

pub(crate) mod node;
pub mod raw;

pub use node::Node;

/// How the node joins the ROS 2 graph.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct DdsConfig {
    /// The ROS domain ID (0-232 as ROS 2 allows: the RTPS ports are derived from it).
    pub domain: u16,
    /// The node's name.
    pub node: String,
    /// Discover and talk over loopback only (what `ROS_LOCALHOST_ONLY=1`
    /// or `ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST` ask of an RMW).
    pub localhost_only: bool,
}

impl DdsConfig {
    /// Domain `domain`, node `/skin`, the discovery range from the ROS
    /// environment variables ([`localhost_only_from_env`]).
    pub fn new(domain: u16) -> DdsConfig {
        DdsConfig { domain, node: "skin".to_owned(), localhost_only: localhost_only_from_env() }
    }
}

/// The largest domain ID ROS 2 accepts with the default RTPS port mapping.
pub const MAX_DOMAIN: u32 = 232;

/// Whether the environment restricts ROS 2 discovery to this host, as the
/// RMWs read it: `ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST` (Jazzy and
/// later) or, when that is unset, `ROS_LOCALHOST_ONLY=1` (Humble).
pub fn localhost_only_from_env() -> bool {
    localhost_only(
        std::env::var("ROS_AUTOMATIC_DISCOVERY_RANGE").ok().as_deref(),
        std::env::var("ROS_LOCALHOST_ONLY").ok().as_deref(),
    )
}

fn localhost_only(range: Option<&str>, localhost: Option<&str>) -> bool {
    match range.map(str::trim).filter(|r| !r.is_empty()) {
        Some(r) => r.eq_ignore_ascii_case("LOCALHOST"),
        None => localhost.is_some_and(|v| v.trim() == "1"),
    }
}

/// Why the node could not join.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum DdsError {
    /// A domain ID beyond [`MAX_DOMAIN`].
    #[error("ROS domain {0} is out of range: ROS 2 over DDS takes 0 to {MAX_DOMAIN}")]
    Domain(u32),
    /// The DDS participant did not start (its UDP ports taken, no interface).
    #[error("the DDS participant did not start: {0}")]
    Participant(String),
    /// A node name ROS 2 refuses.
    #[error("ROS 2 node name {name:?}: {reason}")]
    Name {
        /// The name given.
        name: String,
        /// What ros2-client said.
        reason: String,
    },
    /// A topic, publisher, subscription or service endpoint could not be created.
    #[error("DDS could not create {what}: {reason}")]
    Create {
        /// The topic or endpoint.
        what: String,
        /// What ros2-client said.
        reason: String,
    },
}

impl DdsError {
    pub(crate) fn create(what: impl Into<String>, reason: impl std::fmt::Display) -> DdsError {
        DdsError::Create { what: what.into(), reason: reason.to_string() }
    }
}

#[cfg(test)]
mod tests {
    use super::localhost_only;

    #[test]
    fn the_discovery_range_is_read_as_the_rmws_read_it() {
        assert!(!localhost_only(None, None));
        assert!(localhost_only(None, Some("1")));
        assert!(!localhost_only(None, Some("0")));
        assert!(localhost_only(Some("LOCALHOST"), None));
        assert!(localhost_only(Some("localhost"), Some("0")));
        assert!(!localhost_only(Some("SUBNET"), Some("1")), "the range wins over the older variable");
        assert!(localhost_only(Some(""), Some("1")), "an empty range is unset");
    }
}
