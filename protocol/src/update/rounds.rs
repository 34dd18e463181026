//! The host's pace for image chunks: rounds of at most [`ROUND_FRAMES`],
//! each sent only once every cell still receiving has answered the one
//! before (or [`ROUND_TIMEOUT_US`] passed).
//!
//! Nothing tells the host how fast a skin takes chunks: a tree of real
//! cells at 4 Mbit/s takes thousands a second, QEMU cells sharing two
//! cores a few dozen, and a chunk sent faster than the slowest cell of a
//! tree takes it is dropped on the way and asked for again. A cell answers
//! [`super::QUIET_US`] after the last chunk it heard, so a round whose
//! answers are all in has left the network: the rounds go as fast as the
//! slowest tree, whatever it is, with at most one round in flight.

use std::collections::BTreeSet;

use crate::address::Address;

/// Chunk frames in one round: below the 64 frames an interface port
/// queues for its cell ([`crate::organize::Sink`]), so a round waits there
/// whole while the cell is slow to take it.
pub const ROUND_FRAMES: usize = 48;
/// How long a round waits for answers: a cell that does not answer by then
/// (off, or its answer lost) is not waited for again until it answers.
pub const ROUND_TIMEOUT_US: u64 = 1_000_000;

/// Which interface ports a frame of the update goes down.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Via {
    /// Every interface port: offers, commands and the first pass of chunks.
    Every,
    /// Only this interface port: a chunk some cell of its tree asked for.
    Port(u8),
}

impl Via {
    /// True when the frame goes down interface port `port`.
    pub fn includes(self, port: u8) -> bool {
        self == Via::Every || self == Via::Port(port)
    }
}

/// Where the chunk frames are in their rounds.
#[derive(Clone, Debug, Default)]
pub struct Rounds {
    /// Chunks sent in this round, still on their way, and down which ports.
    in_flight: BTreeSet<(u16, Via)>,
    /// Chunk frames sent in this round.
    sent: usize,
    /// When the last of them was sent.
    last_us: u64,
    /// Cells heard since then.
    heard: BTreeSet<Address>,
    /// Cells that did not answer a round, not waited for until they answer.
    silent: BTreeSet<Address>,
}

impl Rounds {
    /// A cell answered.
    pub fn heard(&mut self, cell: Address) {
        self.heard.insert(cell);
        self.silent.remove(&cell);
    }

    /// True when another chunk frame may go at `now_us`, with `receiving`
    /// the cells still receiving the image. A round ends when all of them
    /// that are not silent answered after its last frame (and at least one
    /// cell did), or at its timeout, which makes the unanswering silent.
    pub fn open(&mut self, now_us: u64, receiving: impl Iterator<Item = Address>) -> bool {
        if self.sent == 0 {
            return true;
        }
        let waiting: Vec<Address> = receiving.filter(|c| !self.silent.contains(c) && !self.heard.contains(c)).collect();
        let answered = waiting.is_empty() && !self.heard.is_empty();
        let late = now_us.saturating_sub(self.last_us) >= ROUND_TIMEOUT_US;
        if late {
            self.silent.extend(waiting);
        }
        if answered || late {
            self.sent = 0;
            self.in_flight.clear();
            return true;
        }
        self.sent < ROUND_FRAMES
    }

    /// True while chunk `index` was sent in this round: a cell that asks for
    /// it may have answered before it arrived (it heard no chunk for a
    /// while: a slow link, or a host slow to send the round), and asks
    /// again after the round if it still misses it.
    /// `port` is the interface port the asking cell's tree hangs on.
    pub fn in_flight(&self, index: u16, port: u8) -> bool {
        self.in_flight.contains(&(index, Via::Every)) || self.in_flight.contains(&(index, Via::Port(port)))
    }

    /// Chunk `index` went down `via` at `now_us`.
    pub fn sent(&mut self, index: u16, via: Via, now_us: u64) {
        self.in_flight.insert((index, via));
        self.sent += 1;
        self.last_us = now_us;
        self.heard.clear();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cells(ids: &[u16]) -> impl Iterator<Item = Address> + '_ {
        ids.iter().map(|i| Address(*i))
    }

    #[test]
    fn a_round_waits_for_every_receiving_cell_or_its_timeout() {
        let mut r = Rounds::default();
        for t in 0..ROUND_FRAMES as u64 {
            assert!(r.open(t, cells(&[1, 2])));
            r.sent(t as u16, Via::Every, t);
        }
        r.sent(60, Via::Port(2), 60);
        assert!(r.in_flight(60, 2) && !r.in_flight(60, 1), "a resend is on its way down its port alone");
        assert!(!r.open(100, cells(&[1, 2])), "a full round waits");
        r.heard(Address(1));
        assert!(!r.open(200, cells(&[1, 2])), "cell 2 has not answered");
        r.heard(Address(2));
        assert!(r.in_flight(3, 0) && r.in_flight(3, 4), "a broadcast is on its way down every port");
        assert!(r.open(300, cells(&[1, 2])), "both answered");
        assert!(!r.in_flight(3, 0), "a new round: what is missing now was lost");
        for t in 0..ROUND_FRAMES as u64 {
            r.sent(t as u16, Via::Every, 1_000 + t);
        }
        r.heard(Address(1));
        assert!(!r.open(1_000 + ROUND_TIMEOUT_US - 1, cells(&[1, 2])));
        assert!(r.open(1_100 + ROUND_TIMEOUT_US, cells(&[1, 2])), "cell 2 timed out");
        for t in 0..ROUND_FRAMES as u64 {
            r.sent(t as u16, Via::Every, 3_000_000 + t);
        }
        r.heard(Address(1));
        assert!(r.open(3_000_100, cells(&[1, 2])), "silent cell 2 is not waited for");
        r.heard(Address(2));
        for t in 0..ROUND_FRAMES as u64 {
            r.sent(t as u16, Via::Every, 4_000_000 + t);
        }
        r.heard(Address(1));
        assert!(!r.open(4_000_100, cells(&[1, 2])), "cell 2 answered again: it is waited for");
    }
}
