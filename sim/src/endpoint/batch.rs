//! The interface ports' batching: the frames the skin network hands a port
//! go to the host in as few datagrams as a real interface port would send,
//! not one datagram per frame. Kernel work per datagram, not per byte, is
//! what a loopback UDP send costs, so this is most of the endpoint's time.
//!
//! A sensor frame waits at most [`Batching::max_wait_ns`] of virtual time (wall
//! time is virtual time in real-time pacing) or until its port holds
//! [`Batching::max_frames`]. The endpoint sends only at the end of a
//! control period, so a port's frames are sent at the end of the period
//! they arrived in unless holding them to the next one keeps them within
//! the bound; other frames go at once (see [`SENSOR`]). With the default
//! 1 ms and the 4 ms period, every frame goes to the host in the same
//! period as unbatched. Each frame's latency is
//! measured by the network when it reaches the port, so batching changes
//! no latency figure; a datagram's header carries the interface clock of
//! its first frame, as the format says.

use skin_protocol::frame::{Kind, FRAME_LEN};
use skin_protocol::interface::{Datagram, DatagramHeader, HEADER_LEN, MAX_FRAMES};

use crate::network::NetworkError;

/// How an interface port gathers frames into datagrams.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Batching {
    /// Most frames in one datagram, 1..=72.
    pub max_frames: usize,
    /// Longest a frame waits for others, ns of virtual time.
    pub max_wait_ns: u64,
}

impl Default for Batching {
    /// Full datagrams, 1 ms at most.
    fn default() -> Batching {
        Batching { max_frames: MAX_FRAMES, max_wait_ns: 1_000_000 }
    }
}

impl Batching {
    /// No batching: every frame in a datagram of its own.
    pub const NONE: Batching = Batching { max_frames: 1, max_wait_ns: 0 };

    /// Checks the frame count is one a datagram can carry.
    pub fn checked(self) -> Result<Batching, String> {
        if (1..=MAX_FRAMES).contains(&self.max_frames) {
            Ok(self)
        } else {
            Err(format!("{} frames per datagram: use 1..={MAX_FRAMES}", self.max_frames))
        }
    }
}

/// The kinds of sensor frames (samples and tactile events), which wait
/// for others; every other frame (ID requests, neighbour reports,
/// acknowledgements) goes at once, after everything held before it, so
/// the host hears the skin organize in the order it did.
const SENSOR: [u8; 2] = [Kind::Sample as u8, Kind::Event as u8];

/// The frames one port holds for the host.
#[derive(Debug, Default)]
struct Held {
    /// A datagram being filled: header, then the frames.
    bytes: Vec<u8>,
    /// Virtual time the first frame arrived, ns.
    first_ns: u64,
    /// The port's next datagram sequence number.
    seq: u32,
}

impl Held {
    fn frames(&self) -> usize {
        self.bytes.len().saturating_sub(HEADER_LEN) / FRAME_LEN
    }
}

/// Every interface port's held frames.
#[derive(Debug)]
pub(super) struct Batcher {
    batching: Batching,
    ports: Vec<Held>,
}

impl Batcher {
    /// `ports` interface ports batching as `batching` says.
    pub(super) fn new(ports: usize, batching: Batching) -> Batcher {
        Batcher { batching, ports: (0..ports).map(|_| Held::default()).collect() }
    }

    /// Takes a datagram the network delivered at virtual time `at_ns`;
    /// full datagrams go to `out`, with their port number.
    pub(super) fn take(
        &mut self,
        at_ns: u64,
        bytes: &[u8],
        out: &mut Vec<(usize, Vec<u8>)>,
    ) -> Result<(), NetworkError> {
        let d = Datagram::parse(bytes).map_err(NetworkError::Datagram)?;
        let port = usize::from(d.header().interface);
        if port >= self.ports.len() {
            return Err(NetworkError::NoSuchInterface(d.header().interface));
        }
        let frames = &bytes[HEADER_LEN..];
        let urgent = frames.chunks_exact(FRAME_LEN).any(|f| !SENSOR.contains(&f[0]));
        if urgent {
            self.send_where(out, |_| true);
        }
        let held = &mut self.ports[port];
        for frame in frames.chunks_exact(FRAME_LEN) {
            if held.bytes.is_empty() {
                held.first_ns = at_ns;
                let header = DatagramHeader { seq: held.seq, ..d.header() };
                held.bytes.extend_from_slice(&header.to_bytes());
            }
            held.bytes.extend_from_slice(frame);
            if held.frames() == self.batching.max_frames {
                send(port, held, out);
            }
        }
        if urgent && !held.bytes.is_empty() {
            send(port, held, out);
        }
        Ok(())
    }

    /// Sends what cannot wait for the next chance to send, at virtual time
    /// `next_ns`, without breaking the bound.
    pub(super) fn due(&mut self, next_ns: u64, out: &mut Vec<(usize, Vec<u8>)>) {
        let wait = self.batching.max_wait_ns;
        self.send_where(out, |first_ns| first_ns.saturating_add(wait) < next_ns);
    }

    /// Sends every port's held frames whose first arrival `must_go` picks.
    fn send_where(&mut self, out: &mut Vec<(usize, Vec<u8>)>, must_go: impl Fn(u64) -> bool) {
        for (port, held) in self.ports.iter_mut().enumerate() {
            if !held.bytes.is_empty() && must_go(held.first_ns) {
                send(port, held, out);
            }
        }
    }
}

fn send(port: usize, held: &mut Held, out: &mut Vec<(usize, Vec<u8>)>) {
    out.push((port, std::mem::take(&mut held.bytes)));
    held.seq = held.seq.wrapping_add(1);
}

#[cfg(test)]
mod tests {
    use super::*;
    use skin_protocol::interface::encode;
    use skin_protocol::{Address, Frame, Message, Sample};

    /// A datagram of port `port` holding one sample frame from each of `srcs`.
    fn datagram(port: u8, seq: u32, timestamp_us: u64, srcs: std::ops::Range<u16>) -> Vec<u8> {
        let sample = Message::Sample(Sample::default());
        let frames: Vec<Frame> = srcs.map(|src| Frame::new(Address(src), Address::HOST, &sample)).collect();
        let mut buf = [0u8; skin_protocol::interface::MAX_DATAGRAM];
        let n = encode(DatagramHeader { interface: port, seq, timestamp_us }, &frames, &mut buf).unwrap();
        buf[..n].to_vec()
    }

    #[test]
    fn frames_wait_within_the_bound_and_keep_their_order() {
        let mut b = Batcher::new(2, Batching::default());
        let mut out = Vec::new();
        // Port 1 gets 100 frames in 1-frame datagrams, 10 us apart.
        for i in 0..100u16 {
            let at_us = u64::from(i) * 10;
            b.take(at_us * 1000, &datagram(1, u32::from(i), at_us, i + 1..i + 2), &mut out).unwrap();
        }
        assert_eq!(out.len(), 1, "72 frames fill a datagram at once");
        // The next chance to send is 4 ms on: within 1 ms of the 73rd
        // frame it waits, past that it goes.
        b.due(720_000 + 1_000_000, &mut out);
        assert_eq!(out.len(), 1);
        b.due(720_000 + 1_000_001, &mut out);
        assert_eq!(out.len(), 2);
        b.due(u64::MAX, &mut out);
        assert_eq!(out.len(), 2, "nothing is held");
        let sent: Vec<Datagram> = out.iter().map(|(_, bytes)| Datagram::parse(bytes).unwrap()).collect();
        assert_eq!(sent.iter().map(Datagram::len).collect::<Vec<_>>(), [72, 28]);
        let headers: Vec<(u8, u32, u64)> =
            sent.iter().map(|d| (d.header().interface, d.header().seq, d.header().timestamp_us)).collect();
        assert_eq!(headers, [(1, 0, 0), (1, 1, 720)], "the first frame's clock, the port's own sequence");
        let srcs: Vec<u16> = sent.iter().flat_map(|d| d.frames()).map(|f| f.unwrap().src().0).collect();
        assert_eq!(srcs, (1..101).collect::<Vec<_>>());
        assert!(out.iter().all(|(port, _)| *port == 1));
    }

    #[test]
    fn other_frames_go_at_once_after_everything_held() {
        // However long sensor frames may wait.
        let mut b = Batcher::new(3, Batching { max_wait_ns: u64::MAX, ..Batching::default() });
        let mut out = Vec::new();
        b.take(0, &datagram(2, 0, 0, 1..3), &mut out).unwrap();
        b.take(1, &datagram(0, 0, 0, 3..4), &mut out).unwrap();
        assert!(out.is_empty());
        let request = Message::IdRequest(skin_protocol::message::IdRequest {
            parent: Address(3),
            port: skin_protocol::message::Port::P1,
        });
        let frame = Frame::new(Address::UNASSIGNED, Address::HOST, &request);
        let mut buf = [0u8; skin_protocol::interface::MAX_DATAGRAM];
        let n = encode(DatagramHeader { interface: 1, seq: 0, timestamp_us: 0 }, &[frame], &mut buf).unwrap();
        b.take(2, &buf[..n], &mut out).unwrap();
        let ports: Vec<usize> = out.iter().map(|(port, _)| *port).collect();
        assert_eq!(ports, [0, 2, 1], "the held sensor frames first, then the request, alone");
        assert_eq!(Datagram::parse(&out[2].1).unwrap().frames().next(), Some(Ok(frame)));
    }

    #[test]
    fn unbatched_sends_every_frame_alone_and_bad_input_is_an_error() {
        let mut b = Batcher::new(1, Batching::NONE);
        let mut out = Vec::new();
        b.take(0, &datagram(0, 9, 3, 1..4), &mut out).unwrap();
        assert_eq!(out.len(), 3);
        assert!(b.take(0, &datagram(1, 0, 0, 1..2), &mut out).is_err(), "no port 1");
        assert!(b.take(0, b"SK", &mut out).is_err());
        assert_eq!(out.len(), 3);
        assert!(Batching { max_frames: 73, ..Batching::default() }.checked().is_err());
        assert!(Batching { max_frames: 0, ..Batching::default() }.checked().is_err());
    }
}
