//! The interface ports' side: their sinks, the frames they gather for the
//! host, and the datagrams on the shared Ethernet.

use std::collections::VecDeque;

use skin_protocol::frame::{Frame, Kind, FRAME_LEN};
use skin_protocol::interface::{self, Datagram, DatagramHeader, HEADER_LEN, MAX_FRAMES};
use skin_protocol::organize::Sink;

use super::super::scheduler::Order;
use super::super::topology::PortRef;
use super::cells::Followed;
use super::{Event, HostDatagram, Network};
use crate::network::NetworkError;

/// One interface port: the sink of its trees and what it holds for the host.
#[derive(Debug)]
pub(super) struct Interface {
    pub(super) sink: Sink,
    pub(super) at: Option<PortRef>,
    pub(super) alive: bool,
    pub(super) busy_until_ns: u64,
    pub(super) waking: bool,
    /// Frames for the host waiting for the Ethernet, followed or not.
    pub(super) up: VecDeque<(Frame, Option<Followed>)>,
    pub(super) seq: u32,
    /// Frames received from the cell since measuring began, and how many
    /// of them were sensor data.
    pub(super) from_cell: u64,
    pub(super) data_from_cell: u64,
}

/// A datagram on the Ethernet, at its place in the event order. The
/// Ethernet carries one datagram at a time, so they arrive in the order
/// they were sent: they wait in a queue of their own, not in the
/// scheduler's (15% of a clock-driven HRP-2 run's events).
#[derive(Debug)]
pub(super) struct ToHost {
    pub(super) order: Order,
    bytes: Vec<u8>,
    /// Followed frames in it.
    followed: u64,
}

impl Network {
    /// Hands a datagram from the host to its interface port, now. Frames
    /// the port has no room for are dropped and counted.
    pub fn inject(&mut self, bytes: &[u8]) -> Result<(), NetworkError> {
        let d = Datagram::parse(bytes).map_err(NetworkError::Datagram)?;
        let k = d.header().interface;
        let Some(i) = self.interfaces.get_mut(usize::from(k)) else {
            return Err(NetworkError::NoSuchInterface(k));
        };
        for frame in d.frames() {
            match frame {
                Ok(f) if i.alive => {
                    if i.sink.send(f).is_err() {
                        self.m.ledger.host_frames_refused += 1;
                    }
                }
                _ => self.m.ledger.host_frames_refused += 1,
            }
        }
        self.kick_interface(k);
        Ok(())
    }

    /// Interface port `k`'s sink lets time pass.
    pub(super) fn sink_poll(&mut self, k: u8) {
        let now_us = self.now_us();
        let i = &mut self.interfaces[usize::from(k)];
        if !i.alive {
            return;
        }
        i.sink.poll(now_us);
        let next = i.sink.poll_at().max(now_us + 1) * 1000;
        self.events.at(next, Event::SinkPoll(k));
        self.kick_interface(k);
    }

    /// Sends one datagram to the host when the Ethernet is free: the frames
    /// of the next interface port (round robin) that has any.
    pub(super) fn flush(&mut self) {
        let now_ns = self.events.now_ns();
        if self.ethernet_busy_until_ns > now_ns {
            if !self.ethernet_waking {
                self.ethernet_waking = true;
                self.events.at(self.ethernet_busy_until_ns, Event::EthernetFree);
            }
            return;
        }
        let count = self.interfaces.len();
        let Some(k) = (0..count).map(|j| (self.next_flush + j) % count).find(|k| !self.interfaces[*k].up.is_empty())
        else {
            return;
        };
        self.next_flush = (k + 1) % count;
        let i = &mut self.interfaces[k];
        let take = i.up.len().min(MAX_FRAMES);
        let delay_ns = self.config.timing.datagram_ns(take);
        let at_ns = now_ns + delay_ns;
        let frames = &mut self.datagram;
        frames.clear();
        let mut followed = 0;
        for (frame, f) in i.up.drain(..take) {
            frames.push(frame);
            let Some(f) = f else { continue };
            followed += 1;
            if f.created_ns >= self.measure_from_ns && f.sensor {
                let us = (at_ns - f.created_ns) / 1000;
                self.m.latency.record(us);
                if frame.kind() == Kind::Event {
                    self.m.event_latency.record(us);
                }
            }
        }
        let header = DatagramHeader { interface: k as u8, seq: i.seq, timestamp_us: now_ns / 1000 };
        i.seq = i.seq.wrapping_add(1);
        // Written in place at its length: most datagrams carry one frame.
        let mut bytes = self.spare.pop().unwrap_or_default();
        bytes.clear();
        bytes.resize(HEADER_LEN + frames.len() * FRAME_LEN, 0);
        interface::encode(header, frames, &mut bytes).expect("1..=72 frames fit a datagram");
        self.ethernet_busy_until_ns = at_ns;
        self.followed_on_ethernet += followed;
        let order = self.events.stamp(at_ns);
        debug_assert!(self.to_host.back().is_none_or(|d| d.order < order));
        self.to_host.push_back(ToHost { order, bytes, followed });
        if !self.ethernet_waking && self.interfaces.iter().any(|i| !i.up.is_empty()) {
            self.ethernet_waking = true;
            self.events.after(delay_ns, Event::EthernetFree);
        }
    }

    /// The next datagram on the Ethernet reaches the host: the clock moves
    /// to it, and it counts as an event.
    pub(super) fn reach_host(&mut self) -> Option<HostDatagram> {
        let ToHost { order, bytes, followed } = self.to_host.pop_front()?;
        self.events.pass(order);
        self.m.events += 1;
        self.followed_on_ethernet -= followed;
        self.m.ledger.delivered += followed;
        Some(HostDatagram { at_ns: order.at_ns, bytes })
    }
}
