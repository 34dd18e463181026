//! Counters that account for every datagram and every frame the interface
//! received: each one is accepted or rejected for exactly one reason.

use serde::ser::SerializeMap;
use serde::{Serialize, Serializer};

/// Why a datagram was dropped whole.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum DatagramReject {
    /// Not a header plus a whole number of 1..=72 frames.
    BadLength,
    /// Does not start with the skin magic.
    BadMagic,
    /// A protocol version this build does not speak.
    UnknownVersion,
    /// Claims an interface port that is not configured.
    UnknownPort,
    /// Claims a configured port that is bound to another source address.
    Spoofed,
    /// Its sequence number was seen before.
    Duplicate,
    /// Its sequence number is too old to tell from a duplicate.
    Stale,
}

impl DatagramReject {
    /// Every reason, in report order.
    pub const ALL: [DatagramReject; 7] = [
        DatagramReject::BadLength,
        DatagramReject::BadMagic,
        DatagramReject::UnknownVersion,
        DatagramReject::UnknownPort,
        DatagramReject::Spoofed,
        DatagramReject::Duplicate,
        DatagramReject::Stale,
    ];

    /// A short name for logs and tables.
    pub fn name(self) -> &'static str {
        match self {
            DatagramReject::BadLength => "bad length",
            DatagramReject::BadMagic => "bad magic",
            DatagramReject::UnknownVersion => "unknown version",
            DatagramReject::UnknownPort => "unknown port",
            DatagramReject::Spoofed => "spoofed port",
            DatagramReject::Duplicate => "duplicate",
            DatagramReject::Stale => "stale",
        }
    }
}

/// Why one frame of an accepted datagram was dropped.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum FrameReject {
    /// The CRC does not match: corrupted on the way.
    BadCrc,
    /// Byte 0 names no message kind.
    UnknownKind,
    /// The payload does not decode as its kind.
    BadPayload,
    /// A kind the skin never sends to the host (link-local traffic,
    /// ID assignments, configuration writes).
    UnexpectedKind,
    /// Source or destination is not what the kind requires (data from a
    /// cell without an ID, an ID request from a cell that has one, a frame
    /// not addressed to the host).
    BadAddress,
}

impl FrameReject {
    /// Every reason, in report order.
    pub const ALL: [FrameReject; 5] = [
        FrameReject::BadCrc,
        FrameReject::UnknownKind,
        FrameReject::BadPayload,
        FrameReject::UnexpectedKind,
        FrameReject::BadAddress,
    ];

    /// A short name for logs and tables.
    pub fn name(self) -> &'static str {
        match self {
            FrameReject::BadCrc => "bad CRC",
            FrameReject::UnknownKind => "unknown kind",
            FrameReject::BadPayload => "bad payload",
            FrameReject::UnexpectedKind => "unexpected kind",
            FrameReject::BadAddress => "bad address",
        }
    }
}

/// Datagram counts since the interface started.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct DatagramCounters {
    /// Every datagram received.
    pub received: u64,
    /// Taken in: their frames were looked at one by one.
    pub accepted: u64,
    /// Dropped, by reason, in [`DatagramReject::ALL`] order.
    #[serde(serialize_with = "datagram_reasons")]
    pub rejected: [u64; 7],
    /// Accepted ones that arrived after a later one (they filled a gap).
    pub late: u64,
    /// Sequence numbers skipped and not (yet) filled: datagrams lost.
    pub missing: u64,
    /// Times a port's sender started its sequence over.
    pub restarts: u64,
}

/// Frame counts since the interface started.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct FrameCounters {
    /// Every frame in an accepted datagram.
    pub received: u64,
    /// Decoded and dispatched.
    pub accepted: u64,
    /// Dropped, by reason, in [`FrameReject::ALL`] order.
    #[serde(serialize_with = "frame_reasons")]
    pub rejected: [u64; 5],
}

/// Everything the interface counted.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct InterfaceCounters {
    /// Datagrams from the skin.
    pub datagrams: DatagramCounters,
    /// Frames in accepted datagrams.
    pub frames: FrameCounters,
    /// ID requests answered.
    pub id_replies: u64,
    /// ID requests left unanswered: every cell ID is taken.
    pub ids_exhausted: u64,
    /// ID requests left unanswered because their port already holds
    /// [`MAX_UNHEARD_IDS`](super::ingest::MAX_UNHEARD_IDS) IDs no cell has
    /// used: a flood of requests, not a skin organizing.
    pub ids_flooded: u64,
    /// IDs handed out that no cell used within
    /// [`RECLAIM_UNHEARD_US`](super::ingest::RECLAIM_UNHEARD_US), taken
    /// back so their port can answer requests again.
    pub ids_reclaimed: u64,
    /// Datagrams sent down to the skin.
    pub sent_datagrams: u64,
    /// Frames sent down to the skin.
    pub sent_frames: u64,
    /// Frames that could not be sent (socket error, or no address known
    /// for the port yet).
    pub send_failures: u64,
}

impl DatagramCounters {
    /// Datagrams dropped for `reason`.
    pub fn rejected(&self, reason: DatagramReject) -> u64 {
        self.rejected[reason as usize]
    }

    /// Datagrams dropped for any reason.
    pub fn rejected_total(&self) -> u64 {
        self.rejected.iter().sum()
    }

    pub(crate) fn reject(&mut self, reason: DatagramReject) {
        self.rejected[reason as usize] += 1;
    }
}

impl FrameCounters {
    /// Frames dropped for `reason`.
    pub fn rejected(&self, reason: FrameReject) -> u64 {
        self.rejected[reason as usize]
    }

    /// Frames dropped for any reason.
    pub fn rejected_total(&self) -> u64 {
        self.rejected.iter().sum()
    }

    pub(crate) fn reject(&mut self, reason: FrameReject) {
        self.rejected[reason as usize] += 1;
    }
}

impl InterfaceCounters {
    /// True when every datagram and every frame received is accepted or
    /// rejected for one reason: nothing vanished uncounted.
    pub fn balanced(&self) -> bool {
        let d = &self.datagrams;
        let f = &self.frames;
        d.received == d.accepted + d.rejected_total() && f.received == f.accepted + f.rejected_total()
    }
}

/// Counts by reason as a JSON object keyed by the reason's name.
fn by_name<S: Serializer>(names: impl Iterator<Item = &'static str>, counts: &[u64], s: S) -> Result<S::Ok, S::Error> {
    let mut map = s.serialize_map(Some(counts.len()))?;
    for (name, count) in names.zip(counts) {
        map.serialize_entry(&name.replace(' ', "_").to_lowercase(), count)?;
    }
    map.end()
}

fn datagram_reasons<S: Serializer>(counts: &[u64; 7], s: S) -> Result<S::Ok, S::Error> {
    by_name(DatagramReject::ALL.iter().map(|r| r.name()), counts, s)
}

fn frame_reasons<S: Serializer>(counts: &[u64; 5], s: S) -> Result<S::Ok, S::Error> {
    by_name(FrameReject::ALL.iter().map(|r| r.name()), counts, s)
}
