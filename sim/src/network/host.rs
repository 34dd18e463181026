//! A minimal host, for runs without the real one: it hands out IDs with
//! the protocol's [`Allocator`] and keeps the neighbour table the cells
//! report, so a run can check self-organization against the wiring.

use std::collections::BTreeMap;

use skin_protocol::address::Address;
use skin_protocol::frame::{self, Frame, Kind, FRAME_LEN};
use skin_protocol::interface::{self, Datagram, DatagramHeader, HEADER_LEN, MAX_DATAGRAM, MAX_FRAMES};
use skin_protocol::message::{Message, Neighbour};
use skin_protocol::organize::Allocator;

/// The host side of phase 3 and 4.
#[derive(Debug)]
pub struct Host {
    allocator: Allocator,
    tables: BTreeMap<Address, [Option<Neighbour>; 4]>,
    seq: BTreeMap<u8, u32>,
    /// One bit per address the allocator has observed (observing one
    /// again changes nothing, and most frames come from known cells).
    observed: Vec<u64>,
    /// Datagrams or frames from the skin that did not parse (of a known
    /// cell's frames, only those of the kinds the host acts on are checked
    /// and decoded).
    pub rejected: u64,
}

impl Default for Host {
    fn default() -> Self {
        Host::new()
    }
}

impl Host {
    /// A host that knows no cell yet.
    pub fn new() -> Host {
        Host {
            allocator: Allocator::new(),
            tables: BTreeMap::new(),
            seq: BTreeMap::new(),
            observed: vec![0; (1 << 16) / 64],
            rejected: 0,
        }
    }

    /// Takes a datagram from the skin; returns the datagrams to send back
    /// (ID assignments, to the interface port the requests came from).
    pub fn receive(&mut self, bytes: &[u8]) -> Vec<Vec<u8>> {
        let Ok(d) = Datagram::parse(bytes) else {
            self.rejected += 1;
            return Vec::new();
        };
        let mut replies: Vec<Frame> = Vec::new();
        // Checked by `Datagram::parse`: whole frames after the header.
        for raw in bytes[HEADER_LEN..].chunks_exact(FRAME_LEN) {
            // A known cell's sample or event (nearly all of the traffic)
            // tells the host nothing: known by its kind and source, it is
            // neither checked nor decoded.
            let (kind, src) = frame::peek(raw.try_into().expect("chunks of a frame's length"));
            let word = self.observed.get_mut(usize::from(src.0) / 64).expect("the bitmap covers every address");
            let bit = 1 << (src.0 % 64);
            let acted_on = [Kind::IdRequest as u8, Kind::NeighbourReport as u8].contains(&kind);
            if *word & bit != 0 && !acted_on {
                continue;
            }
            let Ok(message) = Frame::parse(raw).and_then(|f| f.message()) else {
                self.rejected += 1;
                continue;
            };
            if *word & bit == 0 {
                *word |= bit;
                self.allocator.observe(src);
            }
            match message {
                Message::IdRequest(r) => replies.extend(self.allocator.request(r)),
                Message::NeighbourReport(r) => {
                    self.tables.insert(src, r.neighbours);
                }
                _ => {}
            }
        }
        let k = d.header().interface;
        replies
            .chunks(MAX_FRAMES)
            .map(|frames| {
                let seq = self.seq.entry(k).or_default();
                let header = DatagramHeader { interface: k, seq: *seq, timestamp_us: d.header().timestamp_us };
                *seq = seq.wrapping_add(1);
                let mut buf = [0u8; MAX_DATAGRAM];
                let len = interface::encode(header, frames, &mut buf).expect("1..=72 frames fit");
                buf[..len].to_vec()
            })
            .collect()
    }

    /// The latest neighbour table cell `id` reported.
    pub fn table(&self, id: Address) -> Option<&[Option<Neighbour>; 4]> {
        self.tables.get(&id)
    }
}
