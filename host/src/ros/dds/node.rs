//! The node: one DDS participant (a ros2-client context), the ROS 2 node
//! on it, and a writer per topic created when the topic is declared (or
//! on its first message).

use std::net::{IpAddr, Ipv4Addr};

use ros2_client::dds::{Context, Node as RosNode, Publisher};
use ros2_client::qos::{Durability, History, QosProfile, Reliability, WhenFull};
use ros2_client::{MessageTypeName, Name, NodeName, NodeOptions};
use rustdds::DomainParticipantBuilder;

use super::raw::RawCdr;
use super::{DdsConfig, DdsError, MAX_DOMAIN};
use crate::ros::outlet::Outlet;
use crate::ros::schema::MsgType;
use crate::ros::skin;

/// QoS of `topic` as the Zenoh node declares it: reliable, kept as
/// [`skin::keep`] says. A full send window drops the message (counted)
/// rather than stall the host's pipeline.
pub fn qos_of(topic: &str) -> QosProfile {
    let keep = skin::keep(topic);
    let durability = if keep.latched { Durability::TransientLocal } else { Durability::Volatile };
    QosProfile::publisher_default()
        .reliability(Reliability::Reliable { when_full: WhenFull::Fail })
        .durability(durability)
        .history(History::KeepLast { depth: keep.depth as usize })
}

/// `pkg/msg/Type` as ros2-client names it.
pub(crate) fn type_name(ty: &MsgType) -> Result<MessageTypeName, DdsError> {
    match ty.name.split('/').collect::<Vec<_>>()[..] {
        [pkg, "msg", name] => Ok(MessageTypeName::new(pkg, name)),
        _ => Err(DdsError::create(ty.name, "not a pkg/msg/Type name")),
    }
}

/// The participant of a node, on loopback only when asked.
pub(crate) fn context(domain: u16, localhost_only: bool) -> Result<Context, DdsError> {
    if u32::from(domain) > MAX_DOMAIN {
        return Err(DdsError::Domain(domain.into()));
    }
    let mut builder = DomainParticipantBuilder::new(domain);
    if localhost_only {
        builder = builder.with_only_networks([IpAddr::V4(Ipv4Addr::LOCALHOST)]);
    }
    let participant = builder.build().map_err(|e| DdsError::Participant(e.to_string()))?;
    Context::from_domain_participant(participant).map_err(|e| DdsError::Participant(e.to_string()))
}

/// A ROS 2 node named `name` (no namespace) on `context`, without rosout
/// or parameter services.
pub(crate) fn ros_node(context: &Context, name: &str) -> Result<RosNode, DdsError> {
    let node_name =
        NodeName::new("/", name).map_err(|e| DdsError::Name { name: name.to_owned(), reason: format!("{e:?}") })?;
    context
        .new_node(node_name, NodeOptions::new().enable_rosout(false))
        .map_err(|e| DdsError::Name { name: name.to_owned(), reason: format!("{e:?}") })
}

/// One topic's writer.
struct Writer {
    topic: &'static str,
    publisher: Publisher<RawCdr>,
}

/// The skin's ROS 2 node on DDS.
pub struct Node {
    node: RosNode,
    _context: Context,
    writers: Vec<Writer>,
    /// Messages not sent (a writer that could not be created, a full send
    /// window, a message not in little-endian CDR).
    dropped: u64,
}

impl std::fmt::Debug for Node {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Node").field("name", &self.node.fully_qualified_name()).field("dropped", &self.dropped).finish()
    }
}

impl Node {
    /// Starts the participant and announces the node.
    pub fn open(config: &DdsConfig) -> Result<Node, DdsError> {
        let context = context(config.domain, config.localhost_only)?;
        let node = ros_node(&context, &config.node)?;
        Ok(Node { node, _context: context, writers: Vec::new(), dropped: 0 })
    }

    /// The node's fully qualified name (`/skin`).
    pub fn name(&self) -> String {
        self.node.fully_qualified_name()
    }

    /// The DDS domain.
    pub fn domain(&self) -> u16 {
        self.node.domain_id()
    }

    /// Messages not sent so far.
    pub fn dropped(&self) -> u64 {
        self.dropped
    }

    /// The writer of `topic`, created if it is new; `None` (counted as a
    /// drop) if it cannot be.
    fn writer(&mut self, topic: &'static str, ty: &'static MsgType) -> Option<usize> {
        if let Some(i) = self.writers.iter().position(|w| w.topic == topic) {
            return Some(i);
        }
        self.create(topic, ty).map_err(|e| self.drop_one(format_args!("{e}"))).ok()
    }

    fn create(&mut self, topic: &'static str, ty: &'static MsgType) -> Result<usize, DdsError> {
        let qos = qos_of(topic);
        let name = Name::parse(topic).map_err(|e| DdsError::create(topic, format!("{e:?}")))?;
        let dds_topic = self.node.create_topic(&name, type_name(ty)?, &qos).map_err(|e| DdsError::create(topic, e))?;
        let publisher = self.node.create_publisher(&dds_topic, Some(qos)).map_err(|e| DdsError::create(topic, e))?;
        self.writers.push(Writer { topic, publisher });
        Ok(self.writers.len() - 1)
    }

    fn drop_one(&mut self, why: std::fmt::Arguments<'_>) {
        if self.dropped == 0 {
            tracing::warn!("ROS 2 over DDS: {why}");
        }
        self.dropped += 1;
    }
}

impl Outlet for Node {
    fn declare(&mut self, topic: &'static str, ty: &'static MsgType) {
        self.writer(topic, ty);
    }

    fn publish(&mut self, topic: &'static str, ty: &'static MsgType, _time_ns: u64, cdr: &[u8]) {
        let Some(i) = self.writer(topic, ty) else { return };
        let Some(raw) = RawCdr::from_message(cdr) else {
            return self.drop_one(format_args!("a message on {topic} is not little-endian CDR"));
        };
        if let Err(e) = self.writers[i].publisher.publish(raw) {
            self.drop_one(format_args!("a message on {topic} was not sent: {e:?}"));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_latched_topics_are_transient_local_keep_last_one() {
        for topic in [skin::TF_STATIC, skin::ROBOT_DESCRIPTION] {
            let q = qos_of(topic);
            assert_eq!((q.durability, q.history), (Durability::TransientLocal, History::KeepLast { depth: 1 }));
        }
        let q = qos_of(skin::CELLS);
        assert_eq!((q.durability, q.history), (Durability::Volatile, History::KeepLast { depth: 10 }));
        assert!(matches!(q.reliability, Reliability::Reliable { .. }));
    }

    #[test]
    fn type_names_split_into_package_and_type() {
        let t = type_name(&crate::ros::schema::POINT_CLOUD2).unwrap();
        assert_eq!(t.dds_msg_type(), "sensor_msgs::msg::dds_::PointCloud2_");
    }

    #[test]
    fn a_domain_beyond_the_port_mapping_is_refused() {
        assert!(matches!(context(233, true), Err(DdsError::Domain(233))));
    }
}
