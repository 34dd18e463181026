//! The node: one Zenoh session, its liveliness token, and a publisher per
//! topic, declared before its first message or on it.

use std::time::Duration;

use zenoh::qos::{CongestionControl, Reliability};
use zenoh::{Session, Wait};
use zenoh_ext::{AdvancedPublisher, AdvancedPublisherBuilderExt, CacheConfig, MissDetectionConfig};

use super::keys::{self, NodeName, Qos};
use super::{attachment, ZenohConfig, ZenohError};
use crate::ros::outlet::Outlet;
use crate::ros::schema::MsgType;
use crate::ros::skin;

/// How often a transient-local publisher tells subscribers its last
/// sequence number when it changed, so a missed message is fetched from
/// its cache (rmw_zenoh's sporadic heartbeat).
const HEARTBEAT: Duration = Duration::from_millis(500);

/// One topic's publisher.
struct Publisher {
    topic: &'static str,
    publisher: AdvancedPublisher<'static>,
    _token: zenoh::liveliness::LivelinessToken,
    gid: [u8; 16],
    sequence: i64,
}

/// The skin's ROS 2 node on a Zenoh session.
pub struct Node {
    session: Session,
    name: NodeName,
    config: ZenohConfig,
    _token: zenoh::liveliness::LivelinessToken,
    publishers: Vec<Publisher>,
    /// Messages not sent (a publisher that could not be declared, a put that failed).
    dropped: u64,
}

impl std::fmt::Debug for Node {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Node").field("name", &self.name).field("dropped", &self.dropped).finish()
    }
}

fn insert(config: &mut zenoh::Config, key: &'static str, value: String) -> Result<(), ZenohError> {
    config.insert_json5(key, &value).map_err(|source| ZenohError::Config { key, value, source })
}

/// `items` as a JSON5 list of strings.
fn list(items: &[String]) -> String {
    serde_json::to_string(items).unwrap_or_else(|_| "[]".to_owned())
}

/// QoS of `topic`: kept as [`skin::keep`] says.
fn qos_of(topic: &str) -> Qos {
    let keep = skin::keep(topic);
    Qos { depth: keep.depth, transient_local: keep.latched }
}

impl Node {
    /// Opens the session and announces the node.
    pub fn open(config: ZenohConfig) -> Result<Node, ZenohError> {
        let mut z = zenoh::Config::default();
        insert(&mut z, "mode", "\"peer\"".to_owned())?;
        insert(&mut z, "scouting/multicast/enabled", "false".to_owned())?;
        let listen = if config.listen.is_empty() { vec!["tcp/127.0.0.1:0".to_owned()] } else { config.listen.clone() };
        insert(&mut z, "listen/endpoints", list(&listen))?;
        insert(&mut z, "connect/endpoints", list(&config.connect))?;
        // Timestamps on every sample, as rmw_zenoh's session config asks:
        // the advanced publisher's cache orders by them.
        insert(&mut z, "timestamping/enabled", "true".to_owned())?;
        let session = zenoh::open(z).wait().map_err(ZenohError::Open)?;
        let name = NodeName { domain: config.domain, zid: session.zid().to_string(), name: config.node.clone() };
        let token = declare_token(&session, name.node_token())?;
        Ok(Node { session, name, config, _token: token, publishers: Vec::new(), dropped: 0 })
    }

    /// The Zenoh session's ID, as in the tokens.
    pub fn zid(&self) -> &str {
        &self.name.zid
    }

    /// Where other peers reach this one (`tcp/127.0.0.1:PORT`).
    pub fn locators(&self) -> Vec<String> {
        self.session.info().locators().wait().iter().map(ToString::to_string).collect()
    }

    /// Messages not sent so far.
    pub fn dropped(&self) -> u64 {
        self.dropped
    }

    /// The publisher of `topic`, declared if it is new; `None` (counted as
    /// a drop) if it cannot be.
    fn publisher(&mut self, topic: &'static str, ty: &'static MsgType) -> Option<usize> {
        if let Some(i) = self.publishers.iter().position(|p| p.topic == topic) {
            return Some(i);
        }
        self.create(topic, ty).map_err(|e| self.drop_one(format_args!("{e}"))).ok()
    }

    /// Counts a message not sent, logging the first.
    fn drop_one(&mut self, why: std::fmt::Arguments<'_>) {
        if self.dropped == 0 {
            tracing::warn!("ROS 2 over Zenoh: {why}");
        }
        self.dropped += 1;
    }

    fn create(&mut self, topic: &'static str, ty: &'static MsgType) -> Result<usize, ZenohError> {
        let qos = qos_of(topic);
        let entity_id = self.publishers.len() as u32 + 1;
        let token_key = self.name.publisher_token(entity_id, topic, ty, self.config.hashes, qos);
        let key = keys::topic_key(self.config.domain, topic, ty, self.config.hashes);
        let builder = self
            .session
            .declare_publisher(key.clone())
            .reliability(Reliability::Reliable)
            .congestion_control(CongestionControl::Drop);
        let publisher = if qos.transient_local {
            builder
                .cache(CacheConfig::default().max_samples(qos.depth as usize))
                .publisher_detection()
                .sample_miss_detection(MissDetectionConfig::default().sporadic_heartbeat(HEARTBEAT))
                .wait()
        } else {
            builder.advanced().wait()
        }
        .map_err(|source| ZenohError::Declare { what: key, source })?;
        let token = declare_token(&self.session, token_key.clone())?;
        self.publishers.push(Publisher { topic, publisher, _token: token, gid: keys::gid(&token_key), sequence: 0 });
        Ok(self.publishers.len() - 1)
    }
}

fn declare_token(session: &Session, key: String) -> Result<zenoh::liveliness::LivelinessToken, ZenohError> {
    session.liveliness().declare_token(key.clone()).wait().map_err(|source| ZenohError::Declare { what: key, source })
}

impl Outlet for Node {
    fn declare(&mut self, topic: &'static str, ty: &'static MsgType) {
        self.publisher(topic, ty);
    }

    fn publish(&mut self, topic: &'static str, ty: &'static MsgType, time_ns: u64, cdr: &[u8]) {
        let Some(i) = self.publisher(topic, ty) else { return };
        let p = &mut self.publishers[i];
        p.sequence += 1;
        let attachment = attachment::encode(p.sequence, time_ns.min(i64::MAX as u64) as i64, p.gid);
        if let Err(e) = p.publisher.put(cdr.to_vec()).attachment(attachment.to_vec()).wait() {
            self.drop_one(format_args!("a message on {topic} was not sent: {e}"));
        }
    }
}
