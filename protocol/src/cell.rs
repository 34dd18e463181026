//! One cell's network stack: [`Organizer`] and [`Router`] joined.
//!
//! The firmware and the simulator drive a cell the same way: hand it the
//! bytes that arrived on a port ([`Cell::receive`]), let time pass
//! ([`Cell::poll`] at [`Cell::poll_at`]), give it the cell's own messages
//! ([`Cell::send`]), and whenever a port's transmitter is free ask for the
//! next frame ([`Cell::transmit`]).
//!
//! Upstream frames carry metadata of type `M` through the router (see
//! [`crate::router::Meta`]): `()` in the firmware; every call that may queue
//! a frame without metadata takes the [`Stamp`] that makes it.

use core::mem::MaybeUninit;
use core::ptr::addr_of_mut;

use crate::address::Address;
use crate::frame::{Frame, Header, Kind};
use crate::message::{Message, Port};
use crate::organize::{Config, IdStore, Organizer};
use crate::router::{Discard, Meta, Router, Source, Stamp, Stamped};

/// Why [`Cell::send`] refused a message.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum SendError {
    /// The cell has no ID yet, so its frames could not be told apart.
    NoId,
    /// The cell's own queue is full.
    QueueFull,
}

/// The network side of one skin cell. The organizer and the router's
/// bookkeeping, which every frame and deadline reads, come first and
/// together; the router's slots follow (`repr(C)` keeps that order).
#[derive(Debug)]
#[repr(C)]
pub struct Cell<M = ()> {
    organizer: Organizer,
    router: Router<M>,
}

/// A checked frame a cell received (a deframer found it by its CRC, or the
/// simulator knows its bits did not change), as the caller hands it over.
#[derive(Clone, Copy, Debug)]
pub struct Arrived<M> {
    /// The port it came in on.
    pub port: Port,
    /// The frame.
    pub frame: Frame,
    /// Its metadata, when it left the neighbour with some.
    pub meta: Option<M>,
}

/// The bytes of a frame a cell received, as the caller hands them over.
#[derive(Clone, Copy, Debug)]
pub struct Received<'a, M> {
    /// The port it came in on.
    pub port: Port,
    /// The frame's bytes.
    pub bytes: &'a [u8],
    /// Its metadata, when it left the neighbour with some.
    pub meta: Option<M>,
}

impl<M: Meta> Cell<M> {
    /// A cell booting at `now_us` with the ID `store` holds, if any.
    #[allow(unsafe_code)]
    pub fn new(config: Config, store: &impl IdStore, now_us: u64) -> Cell<M> {
        let mut slot = MaybeUninit::uninit();
        Cell::new_in(&mut slot, config, store, now_us);
        // SAFETY: `new_in` wrote every field.
        unsafe { slot.assume_init() }
    }

    /// [`Cell::new`] written in place (see [`crate::app::CellApp::new_in`]).
    #[allow(unsafe_code)]
    pub(crate) fn new_in<'a>(
        slot: &'a mut MaybeUninit<Cell<M>>,
        config: Config,
        store: &impl IdStore,
        now_us: u64,
    ) -> &'a mut Cell<M> {
        let cell = slot.as_mut_ptr();
        // SAFETY: each field is written once through a pointer into `slot`,
        // and the cell is only referred to once both are written.
        unsafe {
            addr_of_mut!((*cell).organizer).write(Organizer::new(config, store, now_us));
            Router::<M>::new_in(&mut *addr_of_mut!((*cell).router).cast());
            slot.assume_init_mut()
        }
    }

    /// Self-organization state.
    pub fn organizer(&self) -> &Organizer {
        &self.organizer
    }

    /// Forwarding state and counters.
    pub fn router(&self) -> &Router<M> {
        &self.router
    }

    /// The next upstream frame given up, with its metadata (see
    /// [`Router::take_discarded`]).
    pub fn take_discarded(&mut self) -> Option<(M, Discard)> {
        self.router.take_discarded()
    }

    /// This cell's address.
    pub fn id(&self) -> Address {
        self.organizer.id()
    }

    /// Takes the bytes of one frame received. Returns a message addressed
    /// to this cell's application (a configuration write).
    pub fn receive(
        &mut self,
        rx: Received<'_, M>,
        now_us: u64,
        store: &mut impl IdStore,
        stamp: &mut impl Stamp<M>,
    ) -> Option<(Header, Message)> {
        match Frame::parse(rx.bytes) {
            Ok(frame) => self.receive_frame(Arrived { port: rx.port, frame, meta: rx.meta }, now_us, store, stamp),
            Err(_) => {
                self.router.count_corrupt();
                None
            }
        }
    }

    /// [`Cell::receive`] for a frame the caller has already checked (a
    /// deframer that found it by its CRC), so the CRC is not computed twice.
    /// A frame with `meta` that does not go upstream is given up as a
    /// reroute (it was bound for the host).
    pub fn receive_frame(
        &mut self,
        rx: Arrived<M>,
        now_us: u64,
        store: &mut impl IdStore,
        stamp: &mut impl Stamp<M>,
    ) -> Option<(Header, Message)> {
        let Arrived { port, frame, meta } = rx;
        self.organizer.heard(port, now_us);
        let header = frame.header();
        let mine = header.dst == self.id() && self.id() != Address::UNASSIGNED;
        if Some(port) != self.organizer.master() && !header.kind.is_link_local() {
            // From below: on toward the host. Drops are counted by the router.
            let _ = self.router.upstream(Source::Port(port), frame, meta, stamp);
            self.sync();
            return None;
        }
        let mut meta = meta;
        let delivered = if header.kind.is_link_local()
            || header.kind == Kind::IdAssign && (mine || header.dst == Address::UNASSIGNED)
        {
            self.control(port, &frame, now_us, store, stamp);
            None
        } else if header.dst == Address::HOST {
            // Bound up but coming down: the tree is changing under it.
            self.router.reroute(meta.take());
            None
        } else if mine {
            self.local(&frame)
        } else if header.dst == Address::BROADCAST {
            self.router.downstream(frame);
            self.local(&frame)
        } else {
            self.router.downstream(frame);
            None
        };
        if let Some(meta) = meta {
            // Sent upstream, taken here as something else: only a corrupted
            // frame that passed its CRC gets here.
            self.router.give_up(meta);
        }
        self.sync();
        delivered
    }

    fn local(&mut self, frame: &Frame) -> Option<(Header, Message)> {
        match frame.message() {
            Ok(m) => Some((frame.header(), m)),
            Err(_) => {
                self.router.count_corrupt();
                None
            }
        }
    }

    fn control(&mut self, port: Port, frame: &Frame, now_us: u64, store: &mut impl IdStore, stamp: &mut impl Stamp<M>) {
        match frame.message() {
            Ok(m) => {
                let outs = &mut Stamped { router: &mut self.router, stamp };
                self.organizer.handle(port, frame.header(), &m, now_us, store, outs)
            }
            Err(_) => self.router.count_corrupt(),
        }
    }

    /// Keeps the router's view of the tree equal to the organizer's.
    fn sync(&mut self) {
        self.router.set_master(self.organizer.master());
        for p in Port::ALL {
            self.router.set_child(p, self.organizer.is_child(p));
        }
    }

    /// Lets time pass: probes, timeouts, retries.
    pub fn poll(&mut self, now_us: u64, stamp: &mut impl Stamp<M>) {
        let busy = if now_us >= self.organizer.next_probe_us() { self.router.take_sent() } else { 0 };
        self.organizer.poll(now_us, busy, &mut Stamped { router: &mut self.router, stamp });
        self.sync();
    }

    /// The next time [`Cell::poll`] has work to do.
    pub fn poll_at(&self) -> u64 {
        self.organizer.poll_at()
    }

    /// Sends one of this cell's own messages (sample, event, ack) upstream.
    pub fn send(&mut self, message: &Message, stamp: &mut impl Stamp<M>) -> Result<(), SendError> {
        if self.id() == Address::UNASSIGNED {
            return Err(SendError::NoId);
        }
        let frame = Frame::new(self.id(), Address::HOST, message);
        self.router.upstream(Source::Own, frame, None, stamp).map_err(|e| match e {
            Discard::QueueFull | Discard::Reroute => SendError::QueueFull,
        })
    }

    /// The next frame for `port`'s transmitter, if any.
    pub fn transmit(&mut self, port: Port) -> Option<Frame> {
        self.router.transmit(port)
    }

    /// [`Cell::transmit`], with the metadata of an upstream frame.
    pub fn transmit_meta(&mut self, port: Port) -> Option<(Frame, Option<M>)> {
        self.router.transmit_meta(port)
    }

    /// True when `port` has a frame waiting.
    pub fn has_pending(&self, port: Port) -> bool {
        self.router.has_pending(port)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::message::ConfigAck;

    /// Sends everything queued; true for each port that sent a probe.
    fn probes_queued(cell: &mut Cell) -> [bool; 4] {
        Port::ALL.map(|p| {
            let sent: std::vec::Vec<Frame> = core::iter::from_fn(|| cell.transmit(p)).collect();
            sent.iter().any(|f| f.kind() == Kind::Probe)
        })
    }

    #[test]
    fn only_ports_that_sent_nothing_are_probed() {
        let mut store = Some(Address(5));
        let mut cell: Cell = Cell::new(Config::default(), &store, 0);
        cell.poll(0, &mut ());
        assert_eq!(probes_queued(&mut cell), [true; 4]);
        // A sink on port 2 sends a wave every 10 ms and makes it the master.
        let mut seq = 0;
        let mut waves_until = |cell: &mut Cell, until_us: u64| {
            while u64::from(seq) * 10_000 < until_us {
                seq += 1;
                let beacon = crate::message::Beacon { interface: 0, seq, hops: 0 };
                let frame = Frame::new(Address(0xFF00), Address::BROADCAST, &Message::Beacon(beacon));
                let now = u64::from(seq) * 10_000 - 9_000;
                cell.receive(
                    Received { port: Port::P2, bytes: frame.as_bytes(), meta: None },
                    now,
                    &mut store,
                    &mut (),
                );
                cell.poll(now, &mut ());
            }
        };
        waves_until(&mut cell, 1);
        assert_eq!(cell.organizer().master(), Some(Port::P2));
        // The cell's own traffic keeps port 2 busy (the neighbour report and
        // its repeat included), and only the other ports are probed.
        waves_until(&mut cell, 60_000);
        let _ = probes_queued(&mut cell);
        cell.send(&Message::ConfigAck(ConfigAck { tag: 1, accepted: true }), &mut ()).unwrap();
        let sent: std::vec::Vec<Kind> = core::iter::from_fn(|| cell.transmit(Port::P2)).map(|f| f.kind()).collect();
        assert!(sent.contains(&Kind::ConfigAck), "{sent:?}");
        let period = Config::default().keepalive_period_us;
        waves_until(&mut cell, period);
        cell.poll(period, &mut ());
        assert_eq!(probes_queued(&mut cell), [true, true, false, true]);
        // Nothing sent since: every port is probed again.
        waves_until(&mut cell, 2 * period);
        cell.poll(2 * period, &mut ());
        assert_eq!(probes_queued(&mut cell), [true; 4]);
    }
}
