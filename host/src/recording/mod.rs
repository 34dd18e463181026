//! Recording a run into an MCAP file and reading it back.
//!
//! A [`Session`] rides in the [`Remote`](crate::remote::Remote) and writes,
//! as the run goes: every interface datagram as it came off the socket
//! (`/skin/interface`), every robot-link command and state as sent and
//! received (`/skin/robot_link/command`, `/skin/robot_link/state`), what
//! the exploration needs to be run again (`/skin/explore_start`), and the
//! ROS 2 topics of [`crate::ros::skin`]. The raw channels are
//! `skin_msgs/Datagram`, whose definition travels in the file; the rest are
//! core ROS 2 types. [`Recording`] reads the raw channels back for
//! `skin replay`.

mod reader;
mod session;
mod writer;

use std::path::{Path, PathBuf};

pub use reader::{Record, Recording};
pub use session::{ExploreStart, Session};
pub use writer::McapWriter;

/// `/skin/interface`: the skin's interface datagrams.
pub const INTERFACE: &str = "/skin/interface";
/// `/skin/robot_link/command`: robot-link commands, as sent.
pub const COMMAND: &str = "/skin/robot_link/command";
/// `/skin/robot_link/state`: robot-link states, as received.
pub const STATE: &str = "/skin/robot_link/state";
/// `/skin/explore_start`: the robot and settings the exploration started with (JSON).
pub const EXPLORE_START: &str = "/skin/explore_start";

/// Why a recording could not be written or read.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum RecordError {
    /// The file could not be created, written or read.
    #[error("{}: {source} (check the path and the free space)", path.display())]
    File {
        /// The file.
        path: PathBuf,
        /// What the OS said.
        #[source]
        source: std::io::Error,
    },
    /// The MCAP writer or reader failed.
    #[error("{}: not a readable MCAP recording: {source}", path.display())]
    Mcap {
        /// The file.
        path: PathBuf,
        /// What the MCAP library said.
        #[source]
        source: mcap::McapError,
    },
    /// A message of a channel `skin replay` reads is not what it should be.
    #[error("{}: message {sequence} on {topic}: {why}", path.display())]
    BadMessage {
        /// The file.
        path: PathBuf,
        /// The channel.
        topic: String,
        /// The message's sequence number.
        sequence: u32,
        /// What is wrong with it.
        why: String,
    },
    /// The recording has no exploration to replay.
    #[error("{}: no exploration was recorded (the run stopped before it started, or was not recorded by `skin run --record` / `skin demo`)", path.display())]
    NoExploration {
        /// The file.
        path: PathBuf,
    },
}

impl RecordError {
    fn mcap(path: &Path, source: mcap::McapError) -> RecordError {
        RecordError::Mcap { path: path.to_owned(), source }
    }
}
