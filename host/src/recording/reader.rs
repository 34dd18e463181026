//! Reading a recording's raw channels back, in the order they were
//! written; the ROS 2 topics are for other readers and skipped. Every
//! message is checked: a damaged file gives a typed error, never a panic.

use std::net::SocketAddr;
use std::path::{Path, PathBuf};

use skin_protocol::robot_link::{self, FromRobot, ToRobot};

use super::session::ExploreStart;
use super::{RecordError, COMMAND, EXPLORE_START, INTERFACE, STATE};
use crate::ros::cdr::CdrReader;

/// One message of a raw channel.
#[derive(Clone, Debug, PartialEq)]
pub enum Record {
    /// An interface datagram from `from`, taken at `now_us` of the interface's clock.
    Datagram {
        /// Its source.
        from: SocketAddr,
        /// The interface's clock when it was taken, microseconds.
        now_us: u64,
        /// Its bytes.
        bytes: Vec<u8>,
    },
    /// A robot-link command: the velocities.
    Command(Vec<f64>),
    /// A robot-link state.
    State {
        /// The positions.
        positions: Vec<f64>,
        /// The robot's clock, microseconds.
        time_us: u64,
    },
    /// The exploration started.
    ExploreStart(ExploreStart),
}

/// The raw channels of a recording, in order.
#[derive(Debug)]
pub struct Recording {
    /// The file read.
    pub path: PathBuf,
    /// Its records.
    pub records: Vec<Record>,
}

/// A `skin_msgs/Datagram`: stamp in nanoseconds, source, bytes.
fn datagram(cdr: &[u8]) -> Result<(u64, &str, &[u8]), String> {
    let mut r = CdrReader::new(cdr).map_err(|e| e.to_string())?;
    let sec = u64::try_from(r.i32().map_err(|e| e.to_string())?).map_err(|_| "a negative stamp".to_owned())?;
    let nanosec = r.i32().map_err(|e| e.to_string())? as u32;
    let source = r.string().map_err(|e| e.to_string())?;
    let data = r.bytes().map_err(|e| e.to_string())?;
    Ok((sec * 1_000_000_000 + u64::from(nanosec), source, data))
}

fn decode(topic: &str, cdr: &[u8]) -> Result<Option<Record>, String> {
    Ok(Some(match topic {
        INTERFACE => {
            let (stamp_ns, source, bytes) = datagram(cdr)?;
            let from = source.parse().map_err(|_| format!("source {source:?} is not an address"))?;
            Record::Datagram { from, now_us: stamp_ns / 1000, bytes: bytes.to_vec() }
        }
        COMMAND => match robot_link::decode(datagram(cdr)?.2).map_err(|e| e.to_string())? {
            ToRobot::Command { velocities, .. } => Record::Command(velocities.to_vec()),
            other => return Err(format!("{other:?} is not a command")),
        },
        STATE => match robot_link::decode(datagram(cdr)?.2).map_err(|e| e.to_string())? {
            FromRobot::State { positions, time_us, .. } => Record::State { positions: positions.to_vec(), time_us },
            other => return Err(format!("{other:?} is not a state")),
        },
        EXPLORE_START => {
            let mut r = CdrReader::new(cdr).map_err(|e| e.to_string())?;
            let json = r.string().map_err(|e| e.to_string())?;
            Record::ExploreStart(serde_json::from_str(json).map_err(|e| e.to_string())?)
        }
        _ => return Ok(None),
    }))
}

/// The largest recording read: it is held in memory whole.
pub const MAX_FILE_BYTES: usize = 1024 * skin_model::file::MIB;

impl Recording {
    /// Reads the raw channels of the MCAP file at `path`.
    pub fn open(path: &Path) -> Result<Recording, RecordError> {
        let bytes = skin_model::file::read_capped(path, MAX_FILE_BYTES)
            .map_err(|source| RecordError::File { path: path.to_owned(), source })?;
        Recording::parse(path, &bytes)
    }

    /// Reads the raw channels of MCAP `bytes` (named `path` in errors).
    pub fn parse(path: &Path, bytes: &[u8]) -> Result<Recording, RecordError> {
        let mut records = Vec::new();
        let stream = mcap::MessageStream::new(bytes).map_err(|e| RecordError::mcap(path, e))?;
        for message in stream {
            let message = message.map_err(|e| RecordError::mcap(path, e))?;
            let topic = message.channel.topic.as_str();
            match decode(topic, &message.data) {
                Ok(Some(record)) => records.push(record),
                Ok(None) => {}
                Err(why) => {
                    return Err(RecordError::BadMessage {
                        path: path.to_owned(),
                        topic: topic.to_owned(),
                        sequence: message.sequence,
                        why,
                    })
                }
            }
        }
        Ok(Recording { path: path.to_owned(), records })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::recording::McapWriter;
    use crate::ros::msgs::{Datagram, Stamp, StringMsg};

    /// A file with a datagram, the exploration's start, and one `extra`
    /// message on the interface channel.
    fn file(extra: &[u8]) -> Vec<u8> {
        static FILES: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);
        let n = FILES.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        let path = std::env::temp_dir().join(format!("skin-reader-{}-{n}.mcap", std::process::id()));
        let mut w = McapWriter::create(&path).unwrap();
        let datagram = Datagram { stamp: Stamp::from_nanos(5_000), source: "127.0.0.1:9", data: &[1, 2, 3] };
        w.write(INTERFACE, 1, &datagram).unwrap();
        w.write(EXPLORE_START, 2, &StringMsg(serde_json::to_string(&ExploreStart::one_dof()).unwrap())).unwrap();
        w.write("/other", 3, &StringMsg("skipped".into())).unwrap();
        if !extra.is_empty() {
            w.write(INTERFACE, 4, &Raw(extra.to_vec())).unwrap();
        }
        w.finish().unwrap();
        let bytes = std::fs::read(&path).unwrap();
        std::fs::remove_file(&path).unwrap();
        bytes
    }

    /// Bytes written as they are, to damage a channel's messages.
    struct Raw(Vec<u8>);

    impl crate::ros::msgs::Message for Raw {
        const TYPE: &'static crate::ros::schema::MsgType = &crate::ros::schema::DATAGRAM;
        fn write(&self, _: &mut crate::ros::cdr::Cdr) {}
        fn encode_into(&self, out: &mut Vec<u8>) {
            out.clone_from(&self.0);
        }
    }

    #[test]
    fn what_is_written_is_read_back_in_order() {
        let r = Recording::parse(Path::new("t.mcap"), &file(&[])).unwrap();
        assert_eq!(
            r.records,
            vec![
                Record::Datagram { from: "127.0.0.1:9".parse().unwrap(), now_us: 5, bytes: vec![1, 2, 3] },
                Record::ExploreStart(ExploreStart::one_dof())
            ]
        );
    }

    #[test]
    fn a_damaged_message_is_a_typed_error() {
        for bad in [&[0u8, 1, 0, 0, 1][..], &[1, 0, 0, 0, 0, 0, 0, 0]] {
            match Recording::parse(Path::new("t.mcap"), &file(bad)) {
                Err(RecordError::BadMessage { topic, .. }) => assert_eq!(topic, INTERFACE),
                other => panic!("{other:?}"),
            }
        }
    }

    proptest::proptest! {
        #[test]
        fn any_bytes_give_records_or_an_error(bytes in proptest::collection::vec(proptest::prelude::any::<u8>(), 0..200), cut in 0usize..2000) {
            let _ = Recording::parse(Path::new("t.mcap"), &bytes);
            let whole = file(&[]);
            let _ = Recording::parse(Path::new("t.mcap"), &whole[..cut.min(whole.len())]);
        }
    }
}
