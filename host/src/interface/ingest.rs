//! The interface without sockets: datagram bytes and their source go in;
//! events, ID replies and counters come out. Every check of the interface
//! lives here, so tests and simulators can drive it in memory, and any bytes
//! give counted outcomes, never a panic.

use std::net::SocketAddr;

use skin_protocol::frame::FrameError;
use skin_protocol::interface::{Datagram, DatagramError, HEADER_LEN};
use skin_protocol::{Address, Frame, Kind, Message, FRAME_LEN};

use super::counters::{DatagramReject, FrameReject, InterfaceCounters};
use super::event::{Event, EventKind};
use super::ports::Ports;
use super::ratelog::RateLimit;
use crate::config::PortConfig;
use crate::registry::{Registry, Seen};

/// IDs a port may hold that no cell has used yet. A skin organizes from
/// the interface outward, each cell asking only once its master has an ID,
/// so a real tree holds a few at a time; a sender flooding ID requests to
/// take every cell ID stops here, and the other ports' skin is not starved.
pub const MAX_UNHEARD_IDS: usize = 256;

/// Host time after which an ID handed out that no cell has used is taken
/// back, when its port is at [`MAX_UNHEARD_IDS`]: 10 s, over twice the
/// longest a cell that got its ID stays quiet (its 4 s neighbour report).
/// Without it a flood of made-up requests would hold a port's share for
/// good, and the real skin there would get no IDs after a rebind.
pub const RECLAIM_UNHEARD_US: u64 = 10_000_000;

/// The checks, the counters and the registry of the interface.
#[derive(Debug)]
pub struct Ingest {
    ports: Ports,
    registry: Registry,
    counters: InterfaceCounters,
    datagram_log: [RateLimit; DatagramReject::ALL.len()],
    frame_log: [RateLimit; FrameReject::ALL.len()],
    exhausted_log: RateLimit,
    /// IDs handed out down each port (by port index) that no cell has used
    /// yet, with the host time each was last asked for.
    unheard: Vec<Vec<(Address, u64)>>,
    /// ID replies not yet sent: (port index, frame).
    replies: Vec<(usize, Frame)>,
}

/// Where an accepted datagram's frames came from.
#[derive(Clone, Copy)]
struct Origin {
    port: usize,
    interface: u8,
    timestamp_us: u64,
}

impl Ingest {
    /// An interface with the given ports, having heard nothing.
    pub fn new(ports: &[PortConfig]) -> Ingest {
        Ingest {
            ports: Ports::new(ports),
            registry: Registry::new(),
            counters: InterfaceCounters::default(),
            datagram_log: Default::default(),
            frame_log: Default::default(),
            exhausted_log: RateLimit::default(),
            unheard: vec![Vec::new(); ports.len()],
            replies: Vec::new(),
        }
    }

    /// Takes one datagram from `from` received at host time `now_us`,
    /// appending what it carried to `events`; false when it was dropped.
    pub fn datagram(&mut self, from: SocketAddr, bytes: &[u8], now_us: u64, events: &mut Vec<Event>) -> bool {
        self.counters.datagrams.received += 1;
        let datagram = match Datagram::parse(bytes) {
            Ok(d) => d,
            Err(e) => {
                let reason = match e {
                    DatagramError::UnknownVersion(_) => DatagramReject::UnknownVersion,
                    DatagramError::BadMagic => DatagramReject::BadMagic,
                    _ => DatagramReject::BadLength,
                };
                self.reject_datagram(reason, from, &e, now_us);
                return false;
            }
        };
        let header = datagram.header();
        let port = match self.ports.admit(from, header.interface, now_us) {
            Ok(i) => i,
            Err(reason) => {
                self.reject_datagram(reason, from, &format_args!("claims interface port {}", header.interface), now_us);
                return false;
            }
        };
        if !self.ports.get_mut(port).sequence(header.seq, &mut self.counters.datagrams) {
            // Counted by `sequence`; duplicates are normal on a lossy path,
            // so they are not worth a log line.
            return false;
        }
        self.counters.datagrams.accepted += 1;
        let stats = self.ports.get_mut(port).stats_mut();
        stats.datagrams += 1;
        stats.last_rx_us = Some(now_us);
        stats.latest_timestamp_us = stats.latest_timestamp_us.max(Some(header.timestamp_us));

        let origin = Origin { port, interface: header.interface, timestamp_us: header.timestamp_us };
        let (mut accepted, mut corrupt) = (0, 0);
        for (i, frame) in datagram.frames().enumerate() {
            self.counters.frames.received += 1;
            match self.frame(origin, frame, now_us, events) {
                Ok(()) => accepted += 1,
                Err(reason) => {
                    self.counters.frames.reject(reason);
                    if matches!(reason, FrameReject::BadCrc | FrameReject::UnknownKind | FrameReject::BadPayload) {
                        corrupt += 1;
                    }
                    if let Some(suppressed) = self.frame_log[reason as usize].allow(now_us) {
                        let at =
                            bytes.get(HEADER_LEN + i * FRAME_LEN..HEADER_LEN + (i + 1) * FRAME_LEN).unwrap_or_default();
                        tracing::warn!(
                            port = header.interface, %from, frame = i, suppressed,
                            "dropped frame: {} ({at:02x?})", reason.name()
                        );
                    }
                }
            }
        }
        self.counters.frames.accepted += accepted;
        let stats = self.ports.get_mut(port).stats_mut();
        stats.frames += accepted;
        stats.corrupt_frames += corrupt;
        true
    }

    fn reject_datagram(&mut self, reason: DatagramReject, from: SocketAddr, why: &dyn std::fmt::Display, now_us: u64) {
        self.counters.datagrams.reject(reason);
        if let Some(suppressed) = self.datagram_log[reason as usize].allow(now_us) {
            tracing::warn!(%from, suppressed, "dropped datagram: {} ({why})", reason.name());
        }
    }

    /// Checks and dispatches one frame of an accepted datagram.
    fn frame(
        &mut self,
        origin: Origin,
        frame: Result<Frame, FrameError>,
        now_us: u64,
        events: &mut Vec<Event>,
    ) -> Result<(), FrameReject> {
        let frame = frame.map_err(|e| match e {
            FrameError::UnknownKind(_) => FrameReject::UnknownKind,
            FrameError::BadPayload => FrameReject::BadPayload,
            _ => FrameReject::BadCrc,
        })?;
        let (src, kind) = (frame.src(), frame.kind());
        let from_cell = match kind {
            Kind::Sample | Kind::Event | Kind::NeighbourReport | Kind::ConfigAck | Kind::UpdateReport => true,
            Kind::IdRequest => false,
            _ => return Err(FrameReject::UnexpectedKind),
        };
        if frame.dst() != Address::HOST || src.is_cell() != from_cell || (!from_cell && src != Address::UNASSIGNED) {
            self.registry.bad_frame(src);
            return Err(FrameReject::BadAddress);
        }
        let Ok(message) = frame.message() else {
            self.registry.bad_frame(src);
            return Err(FrameReject::BadPayload);
        };
        let event = |cell, kind| Event { interface: origin.interface, timestamp_us: origin.timestamp_us, cell, kind };

        if let Message::IdRequest(request) = message {
            let unheard = &mut self.unheard[origin.port];
            if unheard.len() >= MAX_UNHEARD_IDS {
                let registry = &mut self.registry;
                let before = self.counters.ids_reclaimed;
                let reclaimed = &mut self.counters.ids_reclaimed;
                unheard.retain(|&(id, asked_us)| {
                    if registry.get(id).is_some() {
                        return false;
                    }
                    let expired = now_us.saturating_sub(asked_us) >= RECLAIM_UNHEARD_US;
                    let taken_back = expired && registry.release(id);
                    *reclaimed += u64::from(taken_back);
                    !taken_back
                });
                if self.counters.ids_reclaimed > before {
                    tracing::warn!(
                        port = origin.interface,
                        "took back {} IDs handed out down this port that no cell used within {} s (made-up ID requests?)",
                        self.counters.ids_reclaimed - before,
                        RECLAIM_UNHEARD_US / 1_000_000
                    );
                }
            }
            if unheard.len() >= MAX_UNHEARD_IDS {
                self.counters.ids_flooded += 1;
                if let Some(suppressed) = self.exhausted_log.allow(now_us) {
                    tracing::error!(
                        suppressed, port = origin.interface,
                        "ID request from {} left unanswered: the port holds {MAX_UNHEARD_IDS} IDs no cell has used, a flood of ID requests (someone else sending from the port's address? pin it in the configuration)",
                        request.parent
                    );
                }
                return Ok(());
            }
            match self.registry.assign(request) {
                Some(reply) => {
                    self.counters.id_replies += 1;
                    if let Ok(Message::IdAssign(a)) = reply.message() {
                        // A repeated request (the cell retried) is a sign of life.
                        match unheard.iter_mut().find(|(id, _)| *id == a.id) {
                            Some(entry) => entry.1 = now_us,
                            None => unheard.push((a.id, now_us)),
                        }
                        events.push(event(a.id, EventKind::IdAssigned { parent: request.parent, port: request.port }));
                    }
                    self.replies.push((origin.port, reply));
                }
                None => {
                    self.counters.ids_exhausted += 1;
                    if let Some(suppressed) = self.exhausted_log.allow(now_us) {
                        tracing::error!(
                            suppressed,
                            "ID request from {} left unanswered: every cell ID is taken",
                            request.parent
                        );
                    }
                }
            }
            return Ok(());
        }

        let kind = match message {
            Message::Sample(s) => EventKind::Sample(s),
            Message::Event(e) => EventKind::Tactile(e),
            Message::ConfigAck(a) => EventKind::ConfigAck(a),
            Message::UpdateReport(r) => EventKind::UpdateReport(r),
            Message::NeighbourReport(r) => EventKind::Neighbours(r),
            // Ruled out by the kind check above.
            _ => return Err(FrameReject::UnexpectedKind),
        };
        let (cell, seen) = self.registry.heard(src, origin.interface, now_us);
        match kind {
            EventKind::Sample(s) => Registry::sample(cell, s, now_us),
            EventKind::Tactile(e) => Registry::tactile(cell, &e),
            _ => {}
        }
        match seen {
            Seen::Known => {}
            Seen::New => events.push(event(src, EventKind::Joined)),
            Seen::Moved { from } => events.push(event(src, EventKind::Moved { from })),
        }
        if let EventKind::Neighbours(r) = kind {
            if !self.registry.neighbours(src, r) {
                return Ok(());
            }
        }
        events.push(event(src, kind));
        Ok(())
    }

    /// What was counted.
    pub fn counters(&self) -> &InterfaceCounters {
        &self.counters
    }

    /// The cells heard.
    pub fn registry(&self) -> &Registry {
        &self.registry
    }

    /// The interface ports.
    pub fn ports(&self) -> &Ports {
        &self.ports
    }

    pub(crate) fn ports_and_counters(&mut self) -> (&mut Ports, &mut InterfaceCounters) {
        (&mut self.ports, &mut self.counters)
    }

    /// Takes the ID replies to send: (port index, frame), in arrival order.
    pub fn take_replies(&mut self) -> Vec<(usize, Frame)> {
        std::mem::take(&mut self.replies)
    }
}

#[cfg(test)]
mod tests {
    use skin_protocol::interface::{encode, DatagramHeader, MAX_DATAGRAM};
    use skin_protocol::message::{IdRequest, Port, TactileEvent};
    use skin_protocol::Sample;

    use super::*;

    fn addr(p: u16) -> SocketAddr {
        SocketAddr::from(([127, 0, 0, 1], p))
    }

    fn ingest() -> Ingest {
        Ingest::new(&[PortConfig { number: 0, address: Some(addr(1000)) }, PortConfig { number: 1, address: None }])
    }

    fn datagram(interface: u8, seq: u32, frames: &[Frame]) -> Vec<u8> {
        let mut buf = [0u8; MAX_DATAGRAM];
        let n = encode(DatagramHeader { interface, seq, timestamp_us: 7 }, frames, &mut buf).unwrap();
        buf[..n].to_vec()
    }

    /// An ID request from a new cell on port P0 of `parent`.
    fn id_request(parent: u16) -> Frame {
        let request = IdRequest { parent: Address(parent), port: Port::P0 };
        Frame::new(Address::UNASSIGNED, Address::HOST, &Message::IdRequest(request))
    }

    fn sample(cell: u16, seq: u8) -> Frame {
        let s = Sample::new(100, [1, 2, 3], [0, 0, 256], 900, seq).unwrap();
        Frame::new(Address(cell), Address::HOST, &Message::Sample(s))
    }

    #[test]
    fn every_datagram_rejection_is_counted_for_its_reason() {
        let mut i = ingest();
        let mut ev = Vec::new();
        let good = datagram(0, 0, &[sample(1, 0)]);
        let mut bad_magic = good.clone();
        bad_magic[0] = b'X';
        let mut bad_version = good.clone();
        bad_version[2] = 9;
        assert!(i.datagram(addr(1000), &good, 0, &mut ev));
        assert!(!i.datagram(addr(1000), &good[..30], 0, &mut ev));
        assert!(!i.datagram(addr(1000), &bad_magic, 0, &mut ev));
        assert!(!i.datagram(addr(1000), &bad_version, 0, &mut ev));
        assert!(!i.datagram(addr(1000), &datagram(5, 1, &[sample(1, 1)]), 0, &mut ev));
        assert!(!i.datagram(addr(1001), &datagram(0, 1, &[sample(1, 1)]), 0, &mut ev));
        assert!(!i.datagram(addr(1000), &good, 0, &mut ev));
        let d = &i.counters().datagrams;
        assert_eq!(d.received, 7);
        assert_eq!(d.accepted, 1);
        for (reason, n) in DatagramReject::ALL.into_iter().zip([1, 1, 1, 1, 1, 1, 0]) {
            assert_eq!(d.rejected(reason), n, "{reason:?}");
        }
        assert!(i.counters().balanced());
    }

    #[test]
    fn every_frame_rejection_is_counted_and_the_good_frames_still_pass() {
        let mut i = ingest();
        let mut ev = Vec::new();
        let mut corrupt = sample(1, 0);
        let mut bytes = *corrupt.as_bytes();
        bytes[7] ^= 0x10;
        let probe = Message::Probe(skin_protocol::message::Probe {
            port: Port::P0,
            id: Address(1),
            master: false,
            known: false,
            lost: false,
        });
        let frames = [
            sample(1, 0),
            sample(2, 0),
            Frame::new(Address(1), Address::HOST, &probe),
            Frame::new(Address::UNASSIGNED, Address::HOST, &Message::Sample(Sample::default())),
            Frame::new(Address(3), Address(4), &Message::Sample(Sample::default())),
        ];
        let mut dg = datagram(0, 0, &frames);
        dg.extend_from_slice(&bytes);
        // A frame with a valid CRC over an undefined kind.
        corrupt = sample(1, 1);
        let mut unknown = *corrupt.as_bytes();
        unknown[0] = 0x7F;
        let crc = crc::Crc::<u16>::new(&crc::CRC_16_KERMIT).checksum(&unknown[..18]);
        unknown[18..].copy_from_slice(&crc.to_le_bytes());
        dg.extend_from_slice(&unknown);
        assert!(i.datagram(addr(1000), &dg, 0, &mut ev));
        let f = &i.counters().frames;
        assert_eq!((f.received, f.accepted), (7, 2));
        assert_eq!(f.rejected(FrameReject::BadCrc), 1);
        assert_eq!(f.rejected(FrameReject::UnknownKind), 1);
        assert_eq!(f.rejected(FrameReject::UnexpectedKind), 1);
        assert_eq!(f.rejected(FrameReject::BadAddress), 2);
        assert_eq!(i.ports().get(0).stats().corrupt_frames, 2);
        assert!(i.counters().balanced());
        let kinds: Vec<_> = ev.iter().map(|e| (e.cell.0, matches!(e.kind, EventKind::Joined))).collect();
        assert_eq!(kinds, [(1, true), (1, false), (2, true), (2, false)]);
    }

    #[test]
    fn loss_duplicates_and_reordering_are_counted_and_duplicates_dropped() {
        let mut i = ingest();
        let mut ev = Vec::new();
        for (seq, accepted) in [(0, true), (2, true), (3, true), (2, false), (1, true), (6, true)] {
            let dg = datagram(0, seq, &[sample(1, seq as u8)]);
            assert_eq!(i.datagram(addr(1000), &dg, 0, &mut ev), accepted, "seq {seq}");
        }
        let d = i.counters().datagrams;
        assert_eq!((d.accepted, d.late, d.missing), (5, 1, 2));
        assert_eq!(d.rejected(DatagramReject::Duplicate), 1);
        let cell = i.registry().get(Address(1)).unwrap().health();
        assert_eq!((cell.samples, cell.samples_missing, cell.samples_late), (5, 2, 1));
    }

    #[test]
    fn id_requests_are_answered_down_the_port_they_came_from() {
        let mut i = ingest();
        let mut ev = Vec::new();
        let request = IdRequest { parent: Address(0xFF01), port: Port::P0 };
        let frame = Frame::new(Address::UNASSIGNED, Address::HOST, &Message::IdRequest(request));
        assert!(i.datagram(addr(2000), &datagram(1, 0, &[frame]), 0, &mut ev));
        let replies = i.take_replies();
        assert_eq!(replies.len(), 1);
        assert_eq!(i.ports().get(replies[0].0).number(), 1);
        assert_eq!(replies[0].1.dst(), Address(0xFF01));
        assert!(matches!(ev[..], [Event { cell: Address(1), kind: EventKind::IdAssigned { .. }, .. }]));
        // An ID request from a cell that already has an ID is refused.
        let frame = Frame::new(Address(5), Address::HOST, &Message::IdRequest(request));
        assert!(i.datagram(addr(2000), &datagram(1, 1, &[frame]), 0, &mut ev));
        assert_eq!(i.counters().frames.rejected(FrameReject::BadAddress), 1);
        assert!(i.take_replies().is_empty());
    }

    #[test]
    fn a_restarted_endpoint_is_heard_again_and_its_cells_keep_their_ids() {
        let mut i = ingest();
        let mut ev = Vec::new();
        let frame = id_request(0xFF01);
        assert!(i.datagram(addr(2000), &datagram(1, 40, &[frame]), 0, &mut ev));
        let first = i.take_replies();
        // The endpoint restarts: new source address, sequence from 0.
        let later = super::super::ports::REBIND_QUIET_US + 1;
        assert!(i.datagram(addr(2001), &datagram(1, 0, &[frame]), later, &mut ev));
        let again = i.take_replies();
        assert_eq!(again.len(), 1);
        assert_eq!(again[0].1.as_bytes(), first[0].1.as_bytes(), "the same place gets the same ID");
        assert!(i.datagram(addr(2001), &datagram(1, 1, &[sample(1, 0)]), later, &mut ev));
        assert_eq!(i.counters().datagrams.rejected(DatagramReject::Spoofed), 0);
        assert_eq!(i.ports().get(1).stats().rebinds, 1);
        assert_eq!(i.ports().get(1).stats().restarts, 1, "the new source numbers from 0");
    }

    #[test]
    fn a_flood_of_id_requests_takes_a_bounded_number_of_ids_and_the_skin_still_gets_its_own() {
        let mut i = ingest();
        let mut ev = Vec::new();
        // The flooder claimed port 1 and sends requests from 70,000 made-up places.
        for seq in 0..70_000u32 {
            assert!(i.datagram(addr(2000), &datagram(1, seq, &[id_request(1 + (seq % 60_000) as u16)]), 0, &mut ev));
        }
        assert_eq!(i.counters().id_replies as usize, MAX_UNHEARD_IDS);
        assert_eq!(i.counters().ids_flooded as usize, 70_000 - MAX_UNHEARD_IDS);
        assert_eq!(i.counters().ids_exhausted, 0);
        // The real skin on port 0 still gets an ID.
        assert!(i.datagram(addr(1000), &datagram(0, 0, &[id_request(0xFF00)]), 0, &mut ev));
        assert_eq!(i.take_replies().last().map(|r| r.0), Some(0));
        assert_eq!(i.counters().id_replies as usize, MAX_UNHEARD_IDS + 1);
    }

    #[test]
    fn ids_no_cell_used_are_taken_back_and_the_port_answers_again() {
        let mut i = ingest();
        let mut ev = Vec::new();
        // A sender made up requests until port 1 held its share, then fell silent.
        for seq in 0..MAX_UNHEARD_IDS as u32 + 10 {
            assert!(i.datagram(addr(2000), &datagram(1, seq, &[id_request(1 + seq as u16)]), 0, &mut ev));
        }
        let given = i.take_replies().len();
        assert_eq!((given, i.counters().ids_flooded), (MAX_UNHEARD_IDS, 10));
        // The skin's cell behind the port is answered once they expire, not before.
        let cell = |seq| datagram(1, seq, &[id_request(0xFF01)]);
        assert!(i.datagram(addr(2000), &cell(1000), RECLAIM_UNHEARD_US - 1, &mut ev));
        assert!(i.take_replies().is_empty());
        assert_eq!(i.counters().ids_reclaimed, 0);
        assert!(i.datagram(addr(2000), &cell(1001), RECLAIM_UNHEARD_US, &mut ev));
        let replies = i.take_replies();
        assert_eq!(i.counters().ids_reclaimed as usize, MAX_UNHEARD_IDS);
        // The taken-back IDs come after every fresh one.
        let Ok(Message::IdAssign(a)) = replies[0].1.message() else { panic!("{replies:?}") };
        assert_eq!(a.id, Address(MAX_UNHEARD_IDS as u16 + 1));
        // The made-up place asking again gets a new ID: its old one went back.
        assert!(i.datagram(addr(2000), &datagram(1, 1002, &[id_request(1)]), RECLAIM_UNHEARD_US, &mut ev));
        let replies = i.take_replies();
        let Ok(Message::IdAssign(b)) = replies[0].1.message() else { panic!("{replies:?}") };
        assert_eq!(b.id, Address(MAX_UNHEARD_IDS as u16 + 2));
    }

    #[test]
    fn levels_neighbours_and_moves_reach_the_registry_once() {
        let mut i = ingest();
        let mut ev = Vec::new();
        let touch = TactileEvent { channel: skin_protocol::message::Channel::Force1, level: 3, value: 1500 };
        let report = skin_protocol::message::NeighbourReport::default();
        let frames = [
            Frame::new(Address(9), Address::HOST, &Message::Event(touch)),
            Frame::new(Address(9), Address::HOST, &Message::NeighbourReport(report)),
            Frame::new(Address(9), Address::HOST, &Message::NeighbourReport(report)),
        ];
        i.datagram(addr(1000), &datagram(0, 0, &frames), 0, &mut ev);
        i.datagram(addr(2000), &datagram(1, 0, &[sample(9, 0)]), 0, &mut ev);
        let kinds: Vec<_> = ev.iter().map(|e| std::mem::discriminant(&e.kind)).collect();
        let expected = [
            EventKind::Joined,
            EventKind::Tactile(touch),
            EventKind::Neighbours(report),
            EventKind::Moved { from: 0 },
            EventKind::Sample(Sample::default()),
        ]
        .map(|k| std::mem::discriminant(&k));
        assert_eq!(kinds, expected);
        let cell = i.registry().get(Address(9)).unwrap();
        assert_eq!(cell.level(skin_protocol::message::Channel::Force1), 3);
        assert_eq!(cell.interface(), 1);
    }
}
