//! The payload of every message kind.
//!
//! Payloads are postcard-encoded into the 13 payload bytes of a frame,
//! after the message's [`Kind`]; `frame` proves at compile time that each
//! one fits. Enums on the wire (ports, channels, settings) make
//! out-of-range values undecodable instead of checks scattered over the
//! receivers.

use postcard::experimental::max_size::MaxSize;
use serde::{Deserialize, Serialize};

mod update;

pub use update::{ImageChunk, Refusal, UpdateAction, UpdateCommand, UpdateOffer, UpdateReport, UpdateState, CHUNK_LEN};

use crate::address::Address;
use crate::sample::Sample;

/// One of the four cell-2-cell ports of a hexagonal cell (Figure 6).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize, MaxSize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Port {
    /// Port 0.
    P0,
    /// Port 1.
    P1,
    /// Port 2.
    P2,
    /// Port 3.
    P3,
}

impl Port {
    /// All ports, in order.
    pub const ALL: [Port; 4] = [Port::P0, Port::P1, Port::P2, Port::P3];

    /// The port's number, 0..4.
    pub fn index(self) -> usize {
        self as usize
    }

    /// The port numbered `i`, if `i < 4`.
    pub fn from_index(i: usize) -> Option<Port> {
        Port::ALL.get(i).copied()
    }
}

/// Phase 1 and 4: "I am here, on this port, with this ID".
///
/// Sent as [`Message::Probe`] on every port that has sent nothing else for a
/// keep-alive period, and at once when the sender's place in the tree
/// changes; answered at once with [`Message::ProbeAck`] when the sender does
/// not know the receiver yet, so both sides learn the link is up and who is
/// on the other end.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, MaxSize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Probe {
    /// The sender's port this frame left on.
    pub port: Port,
    /// The sender's address ([`Address::UNASSIGNED`] before phase 3).
    pub id: Address,
    /// True when this port is the sender's master port: the receiver is its
    /// parent in the tree and must deliver downstream traffic to it.
    pub master: bool,
    /// True when the sender already knows who is on this port, so a probe
    /// needs no answer: on a settled link the periodic probes of both sides
    /// carry everything, and only a new or rebooted neighbour is answered.
    pub known: bool,
    /// True when the sender has no route to an interface port, or its
    /// route missed its last waves: it gets every beacon wave, a settled
    /// neighbour only one per keep-alive period (see [`crate::organize`]).
    pub lost: bool,
}

/// Phase 2: one wave of a tree beacon, started by an interface port every
/// beacon period and relayed by each cell away from its master port.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, MaxSize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Beacon {
    /// The interface port that is the sink of this tree.
    pub interface: u8,
    /// Wave number, wrapping; newer waves replace stale routes.
    pub seq: u16,
    /// Hops from the interface port to the sender of this frame.
    pub hops: u16,
}

/// Phase 3: a cell without an ID asks the host for one. The cell is named
/// by its parent and the parent's port toward it, the only name it has.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize, MaxSize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct IdRequest {
    /// The parent's address (a cell or an interface port).
    pub parent: Address,
    /// The parent's port toward the asking cell.
    pub port: Port,
}

/// Phase 3: the host's answer to an [`IdRequest`], sent down to the parent,
/// which hands it on through `port` to the child.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, MaxSize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct IdAssign {
    /// The parent's port toward the new cell.
    pub port: Port,
    /// The new, unique cell ID.
    pub id: Address,
}

/// The far end of a link: which cell, on which of its ports.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize, MaxSize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Neighbour {
    /// The neighbour's address (a cell ID or an interface port).
    pub id: Address,
    /// The neighbour's port on this link.
    pub port: Port,
}

/// Phase 4: the sender's whole neighbour table (the sender is the frame's
/// source), indexed by the sender's own port; `None` where a port is free or
/// its link is down; and the sender's master port, so the host sees the
/// trees too. Sent upstream on every change and as a heartbeat; each report
/// is complete, so the latest one received is the truth.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[serde(into = "PackedReport", try_from = "PackedReport")]
pub struct NeighbourReport {
    /// Who is on each of the sender's ports.
    pub neighbours: [Option<Neighbour>; 4],
    /// The sender's port toward its interface port, if it has one.
    pub master: Option<Port>,
}

/// Wire form of a [`NeighbourReport`]: four little-endian IDs, the four
/// neighbour ports in 2 bits each, a presence bit per row (low nibble) and
/// the master port as one bit of the high nibble.
#[derive(Clone, Copy, Serialize, Deserialize, MaxSize)]
struct PackedReport {
    ids: [u8; 8],
    ports: u8,
    present: u8,
}

impl From<NeighbourReport> for PackedReport {
    fn from(r: NeighbourReport) -> PackedReport {
        let mut p = PackedReport { ids: [0; 8], ports: 0, present: 0 };
        for (i, n) in r.neighbours.iter().enumerate() {
            if let Some(n) = n {
                p.ids[2 * i..2 * i + 2].copy_from_slice(&n.id.0.to_le_bytes());
                p.ports |= (n.port as u8) << (2 * i);
                p.present |= 1 << i;
            }
        }
        if let Some(m) = r.master {
            p.present |= 0x10 << m.index();
        }
        p
    }
}

/// A packed report with bits set outside its rows, a present row without an
/// ID, or two master ports, has no meaning.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct NotCanonical;

impl core::fmt::Display for NotCanonical {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str("neighbour report is not in canonical form")
    }
}

impl TryFrom<PackedReport> for NeighbourReport {
    type Error = NotCanonical;
    fn try_from(p: PackedReport) -> Result<NeighbourReport, NotCanonical> {
        let master = p.present >> 4;
        if master.count_ones() > 1 {
            return Err(NotCanonical);
        }
        let mut r = NeighbourReport::default();
        if master != 0 {
            r.master = Port::from_index(master.trailing_zeros() as usize);
        }
        for i in 0..4 {
            let id = Address(u16::from_le_bytes([p.ids[2 * i], p.ids[2 * i + 1]]));
            let port = (p.ports >> (2 * i)) & 3;
            if p.present & (1 << i) != 0 {
                if id == Address::UNASSIGNED {
                    return Err(NotCanonical);
                }
                r.neighbours[i] = Some(Neighbour { id, port: Port::ALL[usize::from(port)] });
            } else if id != Address::UNASSIGNED || port != 0 {
                return Err(NotCanonical);
            }
        }
        Ok(r)
    }
}

impl MaxSize for NeighbourReport {
    const POSTCARD_MAX_SIZE: usize = PackedReport::POSTCARD_MAX_SIZE;
}

/// A tactile channel that events are quantized on.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize, MaxSize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Channel {
    /// The proximity (pre-touch) sensor.
    Proximity,
    /// Normal-force cell 0.
    Force0,
    /// Normal-force cell 1.
    Force1,
    /// Normal-force cell 2.
    Force2,
}

/// A change of tactile level (Table 3) on one channel of the sender.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, MaxSize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct TactileEvent {
    /// Which sensor changed level.
    pub channel: Channel,
    /// The new level, 0 (nothing) to 4 (pain force / close contact).
    pub level: u8,
    /// The filtered raw value that caused the change.
    pub value: u16,
}

/// How a cell sends its samples.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, MaxSize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum TrafficMode {
    /// Every sample at the sampling rate.
    Clock,
    /// Only samples that moved by more than the send-on-delta thresholds,
    /// plus tactile level events.
    Event,
}

/// Standard gravity, m/s^2: the "g" of the accelerometer ranges.
pub const G0: f64 = 9.806_65;

/// BMA250 measurement range.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, MaxSize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum AccelRange {
    /// +-2 g.
    G2,
    /// +-8 g.
    G8,
    /// +-16 g.
    G16,
}

impl AccelRange {
    /// Full scale in g.
    pub fn full_scale_g(self) -> f32 {
        match self {
            AccelRange::G2 => 2.0,
            AccelRange::G8 => 8.0,
            AccelRange::G16 => 16.0,
        }
    }

    /// Counts per g of a 10-bit reading at this range (256 at +-2 g): what
    /// the host needs to turn counts into accelerations (with [`G0`]).
    pub fn counts_per_g(self) -> f64 {
        f64::from(crate::sample::ACCEL_MAX - crate::sample::ACCEL_MIN + 1) / (2.0 * f64::from(self.full_scale_g()))
    }
}

/// One setting of a cell, written by the host.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, MaxSize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Setting {
    /// Sensor sampling rate in Hz.
    SampleRateHz(f32),
    /// Clock-driven or event-driven sending.
    Traffic(TrafficMode),
    /// Cut-off of the local low-pass filter in Hz.
    FilterCutoffHz(f32),
    /// Lower bound of force level `level` (1..=4), normalized to `[0, 1]`.
    ForceLevel {
        /// The level whose threshold is set.
        level: u8,
        /// Normalized threshold.
        value: f32,
    },
    /// Lower bound of proximity level `level` (1..=4), normalized.
    ProximityLevel {
        /// The level whose threshold is set.
        level: u8,
        /// Normalized threshold.
        value: f32,
    },
    /// Hysteresis of the level quantizers, normalized.
    Hysteresis(f32),
    /// Send-on-delta threshold of sample channel `channel` (0..8, the order
    /// of [`Sample::channels`]) in raw counts.
    Delta {
        /// Sample channel.
        channel: u8,
        /// Threshold in counts.
        counts: u16,
    },
    /// Calibration gain of force cell `cell` (0..3).
    ForceGain {
        /// Force cell.
        cell: u8,
        /// Gain, positive.
        gain: f32,
    },
    /// Accelerometer range.
    AccelRange(AccelRange),
    /// Re-measure the offsets of proximity and forces now, with nothing
    /// touching the skin.
    Calibrate,
}

impl Setting {
    /// True when the value is one a cell can apply: finite, positive rates,
    /// thresholds in `[0, 1]`, indices in range.
    pub fn is_valid(&self) -> bool {
        let unit = |v: f32| (0.0..=1.0).contains(&v);
        match *self {
            Setting::SampleRateHz(hz) => hz.is_finite() && hz > 0.0 && hz <= 10_000.0,
            Setting::FilterCutoffHz(hz) => hz.is_finite() && hz > 0.0,
            Setting::ForceLevel { level, value } | Setting::ProximityLevel { level, value } => {
                (1..=4).contains(&level) && unit(value)
            }
            Setting::Hysteresis(h) => unit(h),
            Setting::Delta { channel, .. } => channel < 8,
            Setting::ForceGain { cell, gain } => cell < 3 && gain.is_finite() && gain > 0.0,
            Setting::Traffic(_) | Setting::AccelRange(_) | Setting::Calibrate => true,
        }
    }

    /// Where a cell keeps this setting among [`SETTING_SLOTS`]: a later
    /// write of the same kind (and level, channel or cell) replaces it.
    /// `None` for a command (calibrate), which is not state to restore.
    pub fn slot(&self) -> Option<usize> {
        Some(match *self {
            Setting::SampleRateHz(_) => 0,
            Setting::Traffic(_) => 1,
            Setting::FilterCutoffHz(_) => 2,
            Setting::ForceLevel { level, .. } => 2 + usize::from(level.clamp(1, 4)),
            Setting::ProximityLevel { level, .. } => 6 + usize::from(level.clamp(1, 4)),
            Setting::Hysteresis(_) => 11,
            Setting::Delta { channel, .. } => 12 + usize::from(channel.min(7)),
            Setting::ForceGain { cell, .. } => 20 + usize::from(cell.min(2)),
            Setting::AccelRange(_) => 23,
            Setting::Calibrate => return None,
        })
    }
}

/// Slots of the settings a cell keeps: one per kind of [`Setting`] (and per
/// level, channel or cell).
pub const SETTING_SLOTS: usize = 24;

/// A configuration write, addressed to one cell or broadcast.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, MaxSize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ConfigWrite {
    /// Chosen by the host; echoed in the acknowledgement.
    pub tag: u8,
    /// What to set.
    pub setting: Setting,
}

/// A cell's answer to a [`ConfigWrite`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, MaxSize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ConfigAck {
    /// The tag of the write.
    pub tag: u8,
    /// False when the setting was invalid and ignored.
    pub accepted: bool,
}

/// The kind of a message: byte 0 of the frame that carries it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[repr(u8)]
pub enum Kind {
    /// Link probe / keep-alive.
    Probe = 0x01,
    /// Answer to a probe.
    ProbeAck = 0x02,
    /// Tree beacon.
    Beacon = 0x03,
    /// ID request.
    IdRequest = 0x04,
    /// ID assignment.
    IdAssign = 0x05,
    /// Neighbour report.
    NeighbourReport = 0x06,
    /// Sensor sample.
    Sample = 0x10,
    /// Tactile level event.
    Event = 0x11,
    /// Configuration write.
    ConfigWrite = 0x20,
    /// Configuration acknowledgement.
    ConfigAck = 0x21,
    /// Firmware update offer (down).
    UpdateOffer = 0x30,
    /// Firmware image chunk (down, broadcast or to the cell that missed it).
    ImageChunk = 0x31,
    /// A cell's firmware update report (up).
    UpdateReport = 0x32,
    /// Firmware update command (down).
    UpdateCommand = 0x33,
}

impl Kind {
    /// Every kind, in wire order.
    pub const ALL: [Kind; 14] = [
        Kind::Probe,
        Kind::ProbeAck,
        Kind::Beacon,
        Kind::IdRequest,
        Kind::IdAssign,
        Kind::NeighbourReport,
        Kind::Sample,
        Kind::Event,
        Kind::ConfigWrite,
        Kind::ConfigAck,
        Kind::UpdateOffer,
        Kind::ImageChunk,
        Kind::UpdateReport,
        Kind::UpdateCommand,
    ];

    /// Kinds that only ever cross one link and are never forwarded.
    pub fn is_link_local(self) -> bool {
        matches!(self, Kind::Probe | Kind::ProbeAck | Kind::Beacon)
    }
}

/// Every message of the skin network; the variant is the frame's [`Kind`].
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Message {
    /// Link probe / keep-alive (phase 1).
    Probe(Probe),
    /// Answer to a probe (phase 1).
    ProbeAck(Probe),
    /// Tree beacon (phase 2).
    Beacon(Beacon),
    /// ID request (phase 3).
    IdRequest(IdRequest),
    /// ID assignment (phase 3).
    IdAssign(IdAssign),
    /// Neighbour report (phase 4).
    NeighbourReport(NeighbourReport),
    /// Sensor sample.
    Sample(Sample),
    /// Tactile level event.
    Event(TactileEvent),
    /// Configuration write.
    ConfigWrite(ConfigWrite),
    /// Configuration acknowledgement.
    ConfigAck(ConfigAck),
    /// Firmware update offer.
    UpdateOffer(UpdateOffer),
    /// Firmware image chunk.
    ImageChunk(ImageChunk),
    /// A cell's firmware update report.
    UpdateReport(UpdateReport),
    /// Firmware update command.
    UpdateCommand(UpdateCommand),
}

impl Message {
    /// The frame kind this message travels as.
    pub fn kind(&self) -> Kind {
        match self {
            Message::Probe(_) => Kind::Probe,
            Message::ProbeAck(_) => Kind::ProbeAck,
            Message::Beacon(_) => Kind::Beacon,
            Message::IdRequest(_) => Kind::IdRequest,
            Message::IdAssign(_) => Kind::IdAssign,
            Message::NeighbourReport(_) => Kind::NeighbourReport,
            Message::Sample(_) => Kind::Sample,
            Message::Event(_) => Kind::Event,
            Message::ConfigWrite(_) => Kind::ConfigWrite,
            Message::ConfigAck(_) => Kind::ConfigAck,
            Message::UpdateOffer(_) => Kind::UpdateOffer,
            Message::ImageChunk(_) => Kind::ImageChunk,
            Message::UpdateReport(_) => Kind::UpdateReport,
            Message::UpdateCommand(_) => Kind::UpdateCommand,
        }
    }

    /// Postcard-encodes the payload into `buf`, returning the bytes used.
    pub(crate) fn encode_payload(&self, buf: &mut [u8]) -> postcard::Result<usize> {
        let used = match self {
            Message::Probe(m) | Message::ProbeAck(m) => postcard::to_slice(m, buf)?,
            Message::Beacon(m) => postcard::to_slice(m, buf)?,
            Message::IdRequest(m) => postcard::to_slice(m, buf)?,
            Message::IdAssign(m) => postcard::to_slice(m, buf)?,
            Message::NeighbourReport(m) => postcard::to_slice(m, buf)?,
            Message::Sample(m) => postcard::to_slice(m, buf)?,
            Message::Event(m) => postcard::to_slice(m, buf)?,
            Message::ConfigWrite(m) => postcard::to_slice(m, buf)?,
            Message::ConfigAck(m) => postcard::to_slice(m, buf)?,
            Message::UpdateOffer(m) => postcard::to_slice(m, buf)?,
            Message::ImageChunk(m) => postcard::to_slice(m, buf)?,
            Message::UpdateReport(m) => postcard::to_slice(m, buf)?,
            Message::UpdateCommand(m) => postcard::to_slice(m, buf)?,
        };
        Ok(used.len())
    }

    /// Decodes a payload of the given kind, if it is the very bytes its
    /// message encodes to: postcard also reads over-long varints (0 as
    /// `80 80 00`) and ignores trailing bytes, which would give one message
    /// many frames.
    pub(crate) fn decode_payload(kind: Kind, bytes: &[u8]) -> Option<Message> {
        fn take<'a, T: Deserialize<'a>>(bytes: &'a [u8]) -> Option<T> {
            postcard::from_bytes(bytes).ok()
        }
        let message = match kind {
            Kind::Probe => Message::Probe(take(bytes)?),
            Kind::ProbeAck => Message::ProbeAck(take(bytes)?),
            Kind::Beacon => Message::Beacon(take(bytes)?),
            Kind::IdRequest => Message::IdRequest(take(bytes)?),
            Kind::IdAssign => Message::IdAssign(take(bytes)?),
            Kind::NeighbourReport => Message::NeighbourReport(take(bytes)?),
            Kind::Sample => Message::Sample(take(bytes)?),
            Kind::Event => Message::Event(take(bytes)?),
            Kind::ConfigWrite => Message::ConfigWrite(take(bytes)?),
            Kind::ConfigAck => Message::ConfigAck(take(bytes)?),
            Kind::UpdateOffer => Message::UpdateOffer(take(bytes)?),
            Kind::ImageChunk => Message::ImageChunk(take(bytes)?),
            Kind::UpdateReport => Message::UpdateReport(take(bytes)?),
            Kind::UpdateCommand => Message::UpdateCommand(take(bytes)?),
        };
        let mut buf = [0; crate::frame::PAYLOAD_LEN];
        let canonical = buf.get_mut(..bytes.len())?;
        message.encode_payload(canonical).ok()?;
        (*canonical == *bytes).then_some(message)
    }
}

/// The largest encoded payload of any kind; `frame` checks it at compile time.
pub(crate) const MAX_PAYLOAD: usize = {
    let sizes = [
        Probe::POSTCARD_MAX_SIZE,
        Beacon::POSTCARD_MAX_SIZE,
        IdRequest::POSTCARD_MAX_SIZE,
        IdAssign::POSTCARD_MAX_SIZE,
        NeighbourReport::POSTCARD_MAX_SIZE,
        Sample::POSTCARD_MAX_SIZE,
        TactileEvent::POSTCARD_MAX_SIZE,
        ConfigWrite::POSTCARD_MAX_SIZE,
        ConfigAck::POSTCARD_MAX_SIZE,
        UpdateOffer::POSTCARD_MAX_SIZE,
        ImageChunk::POSTCARD_MAX_SIZE,
        UpdateReport::POSTCARD_MAX_SIZE,
        UpdateCommand::POSTCARD_MAX_SIZE,
    ];
    let mut max = 0;
    let mut i = 0;
    while i < sizes.len() {
        if sizes[i] > max {
            max = sizes[i];
        }
        i += 1;
    }
    max
};
