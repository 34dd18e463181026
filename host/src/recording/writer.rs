//! Writing an MCAP file in rosbag2's `ros2` profile: every channel has
//! its `ros2msg` schema and CDR messages, so `ros2 bag`, Foxglove and
//! rosbags open it as is.

use std::collections::BTreeMap;
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use crate::ros::msgs::Message;
use crate::ros::schema::MsgType;

use super::RecordError;

/// QoS rosbag2 replays a transient-local topic with (`/tf_static`,
/// `/robot_description`): reliable, keep last 1, transient local.
const LATCHED_QOS: &str = "- history: 1\n  depth: 1\n  reliability: 1\n  durability: 1\n  deadline:\n    sec: 9223372036\n    nsec: 854775807\n  lifespan:\n    sec: 9223372036\n    nsec: 854775807\n  liveliness: 1\n  liveliness_lease_duration:\n    sec: 9223372036\n    nsec: 854775807\n  avoid_ros_namespace_conventions: false\n";

/// An MCAP file being written.
pub struct McapWriter {
    writer: mcap::Writer<BufWriter<File>>,
    channels: Vec<(&'static str, u16)>,
    sequence: u32,
    path: PathBuf,
    /// The last message's CDR: its allocation serves the next.
    scratch: Vec<u8>,
}

impl std::fmt::Debug for McapWriter {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("McapWriter").field("path", &self.path).field("messages", &self.sequence).finish()
    }
}

impl McapWriter {
    /// Creates (or truncates) the file.
    pub fn create(path: &Path) -> Result<McapWriter, RecordError> {
        let file = File::create(path).map_err(|source| RecordError::File { path: path.to_owned(), source })?;
        let options = mcap::WriteOptions::new()
            .profile("ros2")
            .library(concat!("skin-host ", env!("CARGO_PKG_VERSION")))
            .compression(Some(mcap::Compression::Lz4));
        let writer = options.create(BufWriter::new(file)).map_err(|e| RecordError::mcap(path, e))?;
        Ok(McapWriter { writer, channels: Vec::new(), sequence: 0, path: path.to_owned(), scratch: Vec::new() })
    }

    /// Writes `message` on `topic` at `time_ns` (nanoseconds since the Unix epoch).
    pub fn write<M: Message>(&mut self, topic: &'static str, time_ns: u64, message: &M) -> Result<(), RecordError> {
        let mut cdr = std::mem::take(&mut self.scratch);
        message.encode_into(&mut cdr);
        let written = self.write_cdr(topic, M::TYPE, time_ns, &cdr);
        self.scratch = cdr;
        written
    }

    /// Writes a message of type `ty` already encoded (`cdr`, header first) on `topic`.
    pub fn write_cdr(
        &mut self,
        topic: &'static str,
        ty: &'static MsgType,
        time_ns: u64,
        cdr: &[u8],
    ) -> Result<(), RecordError> {
        let channel_id = match self.channels.iter().find(|(t, _)| *t == topic) {
            Some(&(_, id)) => id,
            None => {
                let id = self.channel(topic, ty).map_err(|e| RecordError::mcap(&self.path, e))?;
                self.channels.push((topic, id));
                id
            }
        };
        self.sequence = self.sequence.wrapping_add(1);
        let header = mcap::records::MessageHeader {
            channel_id,
            sequence: self.sequence,
            log_time: time_ns,
            publish_time: time_ns,
        };
        self.writer.write_to_known_channel(&header, cdr).map_err(|e| RecordError::mcap(&self.path, e))
    }

    fn channel(&mut self, topic: &'static str, ty: &MsgType) -> Result<u16, mcap::McapError> {
        let schema = self.writer.add_schema(ty.name, "ros2msg", ty.ros2msg().as_bytes())?;
        let mut metadata = BTreeMap::new();
        if crate::ros::skin::keep(topic).latched {
            metadata.insert("offered_qos_profiles".to_owned(), LATCHED_QOS.to_owned());
        }
        self.writer.add_channel(schema, topic, "cdr", &metadata)
    }

    /// Messages written so far.
    pub fn written(&self) -> u32 {
        self.sequence
    }

    /// Writes the summary and closes the file.
    pub fn finish(mut self) -> Result<PathBuf, RecordError> {
        self.writer.finish().map_err(|e| RecordError::mcap(&self.path, e))?;
        let path = self.path;
        self.writer.into_inner().flush().map_err(|source| RecordError::File { path: path.clone(), source })?;
        Ok(path)
    }
}
