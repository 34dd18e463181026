//! The interface port's side of a link: the sink of one tree.

use super::Config;
use crate::address::Address;
use crate::frame::Frame;
use crate::message::{Beacon, Message, Port, Probe};

/// The interface port's side of a link: the sink of one tree.
///
/// It answers probes, starts a beacon wave every period, hands frames from
/// the cell to the host and frames from the host to the cell; an
/// [`IdAssign`](crate::message::IdAssign) for a child of the interface is readdressed for that child.
#[derive(Clone, Debug)]
pub struct Sink {
    config: Config,
    address: Address,
    seq: u16,
    next_beacon_us: u64,
    last_rx_us: Option<u64>,
    link: heapless::Deque<Frame, 4>,
    down: heapless::Deque<Frame, 64>,
    /// Link-local frames dropped on a full queue.
    dropped: u32,
}

/// What a [`Sink`] makes of the bytes its cell sent.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FromCell {
    /// Link traffic, handled here.
    Link,
    /// A frame for the host.
    Host(Frame),
}

impl Sink {
    /// Interface port `number` (below [`Address::MAX_INTERFACES`]), starting at `now_us`.
    pub fn new(number: u8, config: Config, now_us: u64) -> Option<Sink> {
        Some(Sink {
            config,
            address: Address::interface(number)?,
            seq: 0,
            next_beacon_us: now_us,
            last_rx_us: None,
            link: heapless::Deque::new(),
            down: heapless::Deque::new(),
            dropped: 0,
        })
    }

    /// This interface port's address.
    pub fn address(&self) -> Address {
        self.address
    }

    /// True while the cell on the other end is talking.
    pub fn is_active(&self, now_us: u64) -> bool {
        self.last_rx_us.is_some_and(|t| now_us <= t + self.config.keepalive_timeout_us)
    }

    /// Takes the bytes the cell sent.
    pub fn receive(&mut self, bytes: &[u8], now_us: u64) -> Result<FromCell, crate::frame::FrameError> {
        self.receive_frame(Frame::parse(bytes)?, now_us)
    }

    /// [`Sink::receive`] for a frame the caller has already checked.
    pub fn receive_frame(&mut self, frame: Frame, now_us: u64) -> Result<FromCell, crate::frame::FrameError> {
        self.last_rx_us = Some(now_us);
        if !frame.kind().is_link_local() {
            return Ok(FromCell::Host(frame));
        }
        if let Message::Probe(Probe { known: false, .. }) = frame.message()? {
            let ack = Probe { port: Port::P0, id: self.address, master: false, known: true, lost: false };
            self.link_frame(Frame::new(self.address, Address::BROADCAST, &Message::ProbeAck(ack)));
        }
        Ok(FromCell::Link)
    }

    /// Queues a frame from the host for the cell; `Err` gives it back when
    /// the queue is full.
    pub fn send(&mut self, frame: Frame) -> Result<(), Frame> {
        let frame = match frame.message() {
            Ok(Message::IdAssign(_)) if frame.dst() == self.address => frame.readdressed(Address::UNASSIGNED),
            _ => frame,
        };
        self.down.push_back(frame)
    }

    /// Starts the beacon wave when it is due.
    pub fn poll(&mut self, now_us: u64) {
        if now_us >= self.next_beacon_us {
            self.next_beacon_us = now_us + self.config.beacon_period_us;
            self.seq = self.seq.wrapping_add(1);
            let beacon = Beacon { interface: self.address.interface_number().unwrap_or(0), seq: self.seq, hops: 0 };
            self.link_frame(Frame::new(self.address, Address::BROADCAST, &Message::Beacon(beacon)));
        }
    }

    /// The next time [`Sink::poll`] has work to do.
    pub fn poll_at(&self) -> u64 {
        self.next_beacon_us
    }

    /// The next frame for the cell, when the link is free.
    pub fn transmit(&mut self) -> Option<Frame> {
        self.link.pop_front().or_else(|| self.down.pop_front())
    }

    /// Frames waiting for the cell.
    pub fn queued(&self) -> usize {
        self.link.len() + self.down.len()
    }

    /// Link-local frames (beacons, probe answers) dropped on a full queue;
    /// frames from the host that did not fit were handed back by [`Sink::send`].
    pub fn dropped(&self) -> u32 {
        self.dropped
    }

    /// Queues a link-local frame, or counts it dropped.
    fn link_frame(&mut self, frame: Frame) {
        if self.link.push_back(frame).is_err() {
            self.dropped += 1;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn beacons_the_link_has_no_room_for_are_counted() {
        let config = Config::default();
        let mut sink = Sink::new(0, config, 0).unwrap();
        for k in 0..6 {
            sink.poll(k * config.beacon_period_us);
        }
        assert_eq!((sink.queued(), sink.dropped()), (4, 2));
        while sink.transmit().is_some() {}
        sink.poll(6 * config.beacon_period_us);
        assert_eq!((sink.queued(), sink.dropped()), (1, 2));
    }
}
