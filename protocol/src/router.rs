//! One cell's forwarding: bounded queues and a round-robin scheduler.
//!
//! Upstream traffic (toward the host) waits in one queue per input port plus
//! one for the cell's own frames; whenever the master port's transmitter is
//! free, the scheduler serves the next non-empty queue after the one it
//! served last, so no queue waits more than one round. Downstream traffic
//! (from the host, arriving on the master port) is copied to every child
//! port. Link-local frames (probes, beacons) go first on their port.
//!
//! Every frame handed to the router is, at any time, either transmitted,
//! dropped with a reason, or still queued: [`Counters`] and
//! [`Router::queued`] account for all of them.
//!
//! Beside each upstream frame the router carries metadata of the caller's
//! type ([`Meta`]), as smoltcp's `PacketMeta`: `()` in the firmware, where it
//! costs nothing; the simulator follows every frame with it from its making
//! to the host, and learns of every upstream frame given up with its
//! metadata ([`Router::take_discarded`]) instead of guessing from queue
//! lengths.

mod ring;

use core::mem::MaybeUninit;
use core::ptr::addr_of_mut;

use ring::Ring;

use crate::frame::Frame;
use crate::message::Port;
use crate::organize::{Out, Outbox};

/// Metadata carried beside an upstream frame through the router's queues.
pub trait Meta: Copy {
    /// The frame entered an upstream queue behind `ahead` frames.
    fn queued(&mut self, _ahead: usize) {}
}

/// No metadata: the firmware's choice, zero bytes per frame.
impl Meta for () {}

/// Makes the metadata of an upstream frame that arrived without any: one
/// the cell made, or one received without metadata.
pub trait Stamp<M> {
    /// The metadata of `frame`, entering from `from`.
    fn made(&mut self, frame: &Frame, from: Source) -> M;
}

/// The stamp of `()` metadata.
impl Stamp<()> for () {
    fn made(&mut self, _: &Frame, _: Source) {}
}

/// Upstream frames given up whose metadata the caller has not taken yet:
/// enough for one call of a cell (one frame refused, one queue cleared).
const DISCARD_LOG: usize = UP_QUEUE + 1;

/// Capacity of each upstream input queue (4 ports + own), in frames.
pub const UP_QUEUE: usize = 16;
/// Capacity of each port's downstream queue, in frames.
pub const DOWN_QUEUE: usize = 8;
/// Capacity of each port's link-local queue, in frames.
pub const LINK_QUEUE: usize = 4;

const OWN: usize = 4;

/// Where an upstream frame entered the cell.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Source {
    /// Received on a port from a neighbour.
    Port(Port),
    /// Made by this cell.
    Own,
}

/// Why the router gave up a frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Discard {
    /// Its queue was full.
    QueueFull,
    /// The tree changed under it: it would have gone back where it came from,
    /// or its port stopped being a child or went down.
    Reroute,
}

/// Frame counts since start.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Counters {
    /// Upstream frames of neighbours sent on the master port.
    pub forwarded_up: u32,
    /// Downstream copies sent on child ports.
    pub forwarded_down: u32,
    /// Own upstream frames sent on the master port.
    pub sent_own: u32,
    /// Link-local frames sent.
    pub sent_link: u32,
    /// Frames dropped because a queue was full.
    pub dropped_full: u32,
    /// Frames dropped because the tree changed under them.
    pub dropped_reroute: u32,
    /// Received bytes that were not a valid frame.
    pub corrupt: u32,
}

/// The forwarding state of one cell, with metadata `M` on upstream frames.
///
/// What every visit reads (the tree, the queues' bookkeeping, the counters)
/// comes first, in a few cache lines; the slots follow, each touched only
/// where a frame is. `repr(C)` keeps that order.
#[derive(Debug)]
#[repr(C)]
pub struct Router<M = ()> {
    /// Frames in all of `up`, so the master port's check is one compare.
    up_total: usize,
    counters: Counters,
    up: [Ring; 5],
    down: [Ring; 4],
    link: [Ring; 4],
    /// Upstream frames given up, with their metadata, not taken yet.
    discarded: Ring,
    /// Bit `p`: port `p`'s link-local or downstream queue holds a frame, so
    /// that asking a port for work reads one byte, not two queues.
    waiting: u8,
    next: u8,
    master: Option<Port>,
    children: [bool; 4],
    /// Bit `p`: port `p` sent something other than a probe since the last
    /// [`Router::take_sent`], so the neighbour heard from us anyway.
    sent: u8,
    link_slots: [[Option<Frame>; LINK_QUEUE]; 4],
    down_slots: [[Option<Frame>; DOWN_QUEUE]; 4],
    up_slots: [[Option<(Frame, M)>; UP_QUEUE]; 5],
    discarded_slots: [Option<(M, Discard)>; DISCARD_LOG],
}

/// Writes `None` into every slot of `slots`, one at a time: an array of
/// them written whole is built on the stack first.
///
/// # Safety
/// `slots` is valid for writes.
#[allow(unsafe_code)]
unsafe fn empty<T, const N: usize>(slots: *mut [Option<T>; N]) {
    let first = slots.cast::<Option<T>>();
    for k in 0..N {
        // SAFETY: slot `k` of the array the caller vouches for.
        unsafe { first.add(k).write(None) };
    }
}

impl<M: Meta> Default for Router<M> {
    fn default() -> Self {
        Router::new()
    }
}

impl<M: Meta> Router<M> {
    /// An empty router with no master port and no children.
    #[allow(unsafe_code)]
    pub fn new() -> Router<M> {
        let mut slot = MaybeUninit::uninit();
        Router::new_in(&mut slot);
        // SAFETY: `new_in` wrote every field.
        unsafe { slot.assume_init() }
    }

    /// [`Router::new`] written in place (see [`crate::app::CellApp::new_in`]):
    /// its slots are kilobytes, too many for a cell's stack at boot.
    #[allow(unsafe_code)]
    pub(crate) fn new_in(slot: &mut MaybeUninit<Router<M>>) -> &mut Router<M> {
        let r = slot.as_mut_ptr();
        // SAFETY: each field is written once through a pointer into `slot`
        // (a field added must be written here), and the router is only
        // referred to once all are written.
        unsafe {
            addr_of_mut!((*r).up_total).write(0);
            addr_of_mut!((*r).counters).write(Counters::default());
            addr_of_mut!((*r).up).write(Default::default());
            addr_of_mut!((*r).down).write(Default::default());
            addr_of_mut!((*r).link).write(Default::default());
            addr_of_mut!((*r).discarded).write(Ring::default());
            addr_of_mut!((*r).waiting).write(0);
            addr_of_mut!((*r).next).write(0);
            addr_of_mut!((*r).master).write(None);
            addr_of_mut!((*r).children).write([false; 4]);
            addr_of_mut!((*r).sent).write(0);
            for p in 0..4 {
                empty(addr_of_mut!((*r).link_slots[p]));
                empty(addr_of_mut!((*r).down_slots[p]));
            }
            for q in 0..5 {
                empty(addr_of_mut!((*r).up_slots[q]));
            }
            empty(addr_of_mut!((*r).discarded_slots));
            slot.assume_init_mut()
        }
    }

    /// Keeps the metadata of an upstream frame given up, for the caller.
    fn discard(&mut self, meta: M, why: Discard) {
        // Without metadata there is nothing to tell: the counters have it.
        if core::mem::size_of::<M>() > 0 {
            let _ = self.discarded.push_back(&mut self.discarded_slots, (meta, why));
        }
    }

    /// The next upstream frame given up since the last call, with its
    /// metadata (only for metadata that is not zero-sized).
    pub fn take_discarded(&mut self) -> Option<(M, Discard)> {
        self.discarded.pop_front(&self.discarded_slots)
    }

    /// The port upstream traffic leaves on.
    pub fn master(&self) -> Option<Port> {
        self.master
    }

    /// Sets the master port. Frames that came in on the new master port
    /// would go straight back, so they are dropped as reroutes.
    pub fn set_master(&mut self, master: Option<Port>) {
        if self.master == master {
            return;
        }
        self.master = master;
        if let Some(m) = master {
            let q = m.index();
            self.counters.dropped_reroute += self.up[q].len() as u32;
            self.up_total -= self.up[q].len();
            while let Some((_, meta)) = self.up[q].pop_front(&self.up_slots[q]) {
                self.discard(meta, Discard::Reroute);
            }
        }
    }

    /// Marks `port` as leading to a child (a neighbour whose master port
    /// faces us). A port that stops being a child loses its queued
    /// downstream frames.
    pub fn set_child(&mut self, port: Port, child: bool) {
        if self.children[port.index()] == child {
            return;
        }
        self.children[port.index()] = child;
        if !child {
            let q = &mut self.down[port.index()];
            self.counters.dropped_reroute += q.len() as u32;
            q.clear();
            self.recount(port);
        }
    }

    /// Queues an upstream frame from a neighbour or from this cell, with
    /// its `meta`data, or, when it has none, what `stamp` makes for it as
    /// it is queued. A refused frame with metadata is kept for
    /// [`Router::take_discarded`]; one without never entered the books.
    pub fn upstream(
        &mut self,
        from: Source,
        frame: Frame,
        meta: Option<M>,
        stamp: &mut impl Stamp<M>,
    ) -> Result<(), Discard> {
        let q = match from {
            Source::Port(p) if Some(p) == self.master => {
                self.counters.dropped_reroute += 1;
                return self.refuse(meta, Discard::Reroute);
            }
            Source::Port(p) => p.index(),
            Source::Own => OWN,
        };
        if self.up[q].is_full(&self.up_slots[q]) {
            self.counters.dropped_full += 1;
            return self.refuse(meta, Discard::QueueFull);
        }
        let mut meta = meta.unwrap_or_else(|| stamp.made(&frame, from));
        meta.queued(self.up[q].len());
        // Not full: checked above.
        let _ = self.up[q].push_back(&mut self.up_slots[q], (frame, meta));
        self.up_total += 1;
        Ok(())
    }

    /// An upstream frame refused: its metadata, if any, is kept.
    fn refuse(&mut self, meta: Option<M>, why: Discard) -> Result<(), Discard> {
        if let Some(meta) = meta {
            self.discard(meta, why);
        }
        Err(why)
    }

    /// Copies a downstream frame to every child port. Returns how many copies
    /// were queued; a full child queue drops its copy.
    pub fn downstream(&mut self, frame: Frame) -> usize {
        let mut queued = 0;
        for p in 0..self.children.len() {
            if !self.children[p] {
                continue;
            }
            self.waiting |= 1 << p;
            match self.down[p].push_back(&mut self.down_slots[p], frame) {
                Ok(()) => queued += 1,
                Err(_) => self.counters.dropped_full += 1,
            }
        }
        queued
    }

    /// Downstream frames every child port's queue still takes: the most a
    /// cell may take from its master port without dropping a copy (a cell
    /// without children takes any number). A cell that reads its master
    /// port only while this is enough leaves the rest on the link, where
    /// the sender waits (a QEMU UART's socket) instead of this cell
    /// dropping copies its children cannot take yet.
    pub fn downstream_room(&self) -> usize {
        (0..self.children.len())
            .filter(|p| self.children[*p])
            .map(|p| DOWN_QUEUE - self.down[p].len())
            .min()
            .unwrap_or(usize::MAX)
    }

    /// Queues a link-local frame (probe, beacon, ...) for one port.
    pub fn link(&mut self, port: Port, frame: Frame) -> Result<(), Discard> {
        let p = port.index();
        self.waiting |= 1 << p;
        self.link[p].push_back(&mut self.link_slots[p], frame).map_err(|_| {
            self.counters.dropped_full += 1;
            Discard::QueueFull
        })
    }

    /// Brings bit `port` of `waiting` up to date after its queues shrank.
    fn recount(&mut self, port: Port) {
        let p = port.index();
        if self.link[p].is_empty() && self.down[p].is_empty() {
            self.waiting &= !(1 << p);
        }
    }

    /// The next frame to put on `port`'s wire, when its transmitter is free:
    /// link-local first, then on the master port the round robin over the
    /// upstream queues, then downstream copies on a child port.
    pub fn transmit(&mut self, port: Port) -> Option<Frame> {
        self.transmit_meta(port).map(|(frame, _)| frame)
    }

    /// [`Router::transmit`], with the metadata of an upstream frame.
    #[inline]
    pub fn transmit_meta(&mut self, port: Port) -> Option<(Frame, Option<M>)> {
        let p = port.index();
        if let Some(f) = self.link[p].pop_front(&self.link_slots[p]) {
            self.counters.sent_link += 1;
            if f.kind() != crate::frame::Kind::Probe {
                self.sent |= 1 << p;
            }
            self.recount(port);
            return Some((f, None));
        }
        let sent = self.next_data(port)?;
        self.sent |= 1 << p;
        self.recount(port);
        Some(sent)
    }

    #[inline]
    fn next_data(&mut self, port: Port) -> Option<(Frame, Option<M>)> {
        let p = port.index();
        if self.master == Some(port) && self.up_total > 0 {
            for k in 0..self.up.len() {
                let i = (usize::from(self.next) + k) % self.up.len();
                if let Some((f, meta)) = self.up[i].pop_front(&self.up_slots[i]) {
                    self.up_total -= 1;
                    // Below 5.
                    self.next = ((i + 1) % self.up.len()) as u8;
                    if i == OWN {
                        self.counters.sent_own += 1;
                    } else {
                        self.counters.forwarded_up += 1;
                    }
                    return Some((f, Some(meta)));
                }
            }
        }
        let f = self.down[p].pop_front(&self.down_slots[p])?;
        self.counters.forwarded_down += 1;
        Some((f, None))
    }

    /// True when `port` has something to send.
    pub fn has_pending(&self, port: Port) -> bool {
        let p = port.index();
        debug_assert_eq!(self.waiting & 1 << p != 0, !self.link[p].is_empty() || !self.down[p].is_empty());
        self.waiting & 1 << p != 0 || (self.master == Some(port) && self.up_total > 0)
    }

    /// Bit `p` set for each port with something to send.
    pub fn pending_ports(&self) -> u8 {
        Port::ALL.iter().filter(|p| self.has_pending(**p)).fold(0, |m, p| m | 1 << p.index())
    }

    /// The ports that sent anything but a probe since the last call, as bits.
    pub fn take_sent(&mut self) -> u8 {
        core::mem::take(&mut self.sent)
    }

    /// Counts a frame that the tree's shape made pointless: bound for the
    /// host but arriving from the master port (a transient loop), or a
    /// frame with metadata that did not go upstream.
    pub fn reroute(&mut self, meta: Option<M>) {
        self.counters.dropped_reroute += 1;
        if let Some(meta) = meta {
            self.discard(meta, Discard::Reroute);
        }
    }

    /// Frames waiting in all queues.
    pub fn queued(&self) -> usize {
        self.up.iter().chain(&self.down).chain(&self.link).map(|r| r.len()).sum()
    }

    /// Frames waiting upstream in all inputs.
    pub fn upstream_queued(&self) -> usize {
        self.up_total
    }

    /// Frames waiting upstream, per input (ports 0..4, then own).
    pub fn upstream_lens(&self) -> [usize; 5] {
        core::array::from_fn(|i| self.up[i].len())
    }

    /// The metadata of every frame waiting upstream.
    pub fn upstream_metas(&self) -> impl Iterator<Item = &M> {
        self.up.iter().zip(&self.up_slots).flat_map(|(q, slots)| q.iter(slots).map(|(_, meta)| meta))
    }

    /// Keeps the metadata of an upstream frame the cell took in as
    /// something else (a corrupted frame that passed its CRC), as given up.
    pub fn give_up(&mut self, meta: M) {
        self.discard(meta, Discard::Reroute);
    }

    /// Counts a received frame that failed to parse.
    pub fn count_corrupt(&mut self) {
        self.counters.corrupt += 1;
    }

    /// Frame counts since start.
    pub fn counters(&self) -> &Counters {
        &self.counters
    }
}

/// A router and the stamp of the frames the organizer makes.
pub struct Stamped<'a, M, S> {
    /// Where the frames go.
    pub router: &'a mut Router<M>,
    /// What metadata they get.
    pub stamp: &'a mut S,
}

/// The organizer's frames go straight into the queues; a full queue drops
/// and counts, and the organizer repeats everything that matters.
impl<M: Meta, S: Stamp<M>> Outbox for Stamped<'_, M, S> {
    fn send(&mut self, out: Out) {
        let _ = match out {
            Out::Link(p, f) => self.router.link(p, f),
            Out::Up(f) => self.router.upstream(Source::Own, f, None, self.stamp),
        };
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::address::Address;
    use crate::message::{ConfigAck, Message};
    use proptest::prelude::*;

    fn frame(tag: u8) -> Frame {
        Frame::new(Address(1), Address::HOST, &Message::ConfigAck(ConfigAck { tag, accepted: true }))
    }

    #[derive(Clone, Debug)]
    enum Op {
        Push(usize),
        Serve,
        Master(usize),
    }

    fn op() -> impl Strategy<Value = Op> {
        prop_oneof![
            4 => (0..5usize).prop_map(Op::Push),
            4 => Just(Op::Serve),
            1 => (0..4usize).prop_map(Op::Master),
        ]
    }

    proptest! {
        /// Fairness: while an upstream queue is non-empty, the master port
        /// serves at most one frame of each other queue before it. Bounds:
        /// no queue ever holds more than its capacity, and every frame is
        /// sent, dropped or still queued.
        #[test]
        fn round_robin_is_fair_and_bounded(ops in proptest::collection::vec(op(), 1..600)) {
            let mut r: Router = Router::new();
            r.set_master(Some(Port::P0));
            let mut waited = [0usize; 5];
            let mut pushed = 0u32;
            for op in ops {
                match op {
                    Op::Push(i) => {
                        let from = if i == OWN { Source::Own } else { Source::Port(Port::ALL[i]) };
                        pushed += 1;
                        let _ = r.upstream(from, frame(i as u8), None, &mut ());
                    }
                    Op::Serve => {
                        let before = r.upstream_lens();
                        let master = r.master().unwrap();
                        if let Some(f) = r.transmit(master) {
                            let served = f.message().map(|m| match m {
                                Message::ConfigAck(a) => a.tag as usize,
                                _ => unreachable!(),
                            }).unwrap();
                            for i in 0..5 {
                                if i == served || before[i] == 0 {
                                    waited[i] = 0;
                                } else {
                                    waited[i] += 1;
                                    prop_assert!(waited[i] <= 4, "queue {} waited {} services", i, waited[i]);
                                }
                            }
                        }
                    }
                    Op::Master(p) => {
                        r.set_master(Some(Port::ALL[p]));
                        waited = [0; 5];
                    }
                }
                prop_assert!(r.upstream_lens().iter().all(|n| *n <= UP_QUEUE));
                prop_assert_eq!(r.upstream_lens().iter().sum::<usize>(), r.up_total);
                let c = r.counters();
                prop_assert_eq!(pushed, c.forwarded_up + c.sent_own + c.dropped_full + c.dropped_reroute + r.queued() as u32);
            }
        }
    }

    #[test]
    fn downstream_goes_to_children_only_and_link_frames_go_first() {
        let mut r: Router = Router::new();
        r.set_master(Some(Port::P0));
        r.set_child(Port::P1, true);
        r.set_child(Port::P3, true);
        assert_eq!(r.downstream(frame(7)), 2);
        r.link(Port::P1, frame(9)).unwrap();
        assert_eq!(r.transmit(Port::P2), None);
        assert_eq!(r.transmit(Port::P1), Some(frame(9)));
        assert_eq!(r.transmit(Port::P1), Some(frame(7)));
        r.set_child(Port::P3, false);
        assert_eq!(r.transmit(Port::P3), None);
        assert_eq!(r.counters().dropped_reroute, 1);
        assert_eq!(r.queued(), 0);
    }

    #[test]
    fn downstream_room_is_the_fullest_child_queues_room() {
        let mut r: Router = Router::new();
        assert_eq!(r.downstream_room(), usize::MAX, "no child: nothing is dropped");
        r.set_child(Port::P1, true);
        r.set_child(Port::P2, true);
        r.downstream(frame(1));
        r.downstream(frame(2));
        r.transmit(Port::P2);
        assert_eq!(r.downstream_room(), DOWN_QUEUE - 2, "port 1 holds two");
        while r.downstream(frame(3)) > 0 {}
        assert_eq!((r.downstream_room(), r.counters().dropped_full), (0, 3), "port 1 full first, then both");
    }

    /// A frame's tag, and how many frames were ahead of it when queued.
    #[derive(Clone, Copy, Debug, PartialEq, Eq)]
    struct Tag(u8, usize);

    impl Meta for Tag {
        fn queued(&mut self, ahead: usize) {
            self.1 = ahead;
        }
    }

    impl Stamp<Tag> for u8 {
        fn made(&mut self, _: &Frame, _: Source) -> Tag {
            Tag(*self, 0)
        }
    }

    #[test]
    fn metadata_travels_with_its_frame_and_comes_back_when_given_up() {
        let mut r: Router<Tag> = Router::new();
        r.set_master(Some(Port::P0));
        r.upstream(Source::Port(Port::P1), frame(1), Some(Tag(1, 9)), &mut 0).unwrap();
        r.upstream(Source::Port(Port::P1), frame(2), Some(Tag(2, 9)), &mut 0).unwrap();
        r.upstream(Source::Own, frame(3), None, &mut 3).unwrap();
        r.upstream(Source::Port(Port::P2), frame(4), Some(Tag(4, 9)), &mut 0).unwrap();
        assert_eq!(r.upstream(Source::Port(Port::P0), frame(5), Some(Tag(5, 0)), &mut 0), Err(Discard::Reroute));
        assert_eq!(r.take_discarded(), Some((Tag(5, 0), Discard::Reroute)));
        assert_eq!(r.transmit_meta(Port::P0), Some((frame(1), Some(Tag(1, 0)))));
        assert_eq!(r.transmit_meta(Port::P0), Some((frame(4), Some(Tag(4, 0)))));
        assert_eq!(r.transmit_meta(Port::P0), Some((frame(3), Some(Tag(3, 0)))));
        // Port 1 becomes the master: what came in on it is given up.
        r.set_master(Some(Port::P1));
        assert_eq!(r.take_discarded(), Some((Tag(2, 1), Discard::Reroute)));
        assert_eq!(r.take_discarded(), None);
        assert_eq!(r.queued(), 0);
        r.link(Port::P1, frame(6)).unwrap();
        assert_eq!(r.transmit_meta(Port::P1), Some((frame(6), None)), "link-local frames carry none");
    }

    #[test]
    fn full_queues_drop_and_count() {
        let mut r: Router = Router::new();
        for _ in 0..UP_QUEUE {
            r.upstream(Source::Own, frame(0), None, &mut ()).unwrap();
        }
        assert_eq!(r.upstream(Source::Own, frame(0), None, &mut ()), Err(Discard::QueueFull));
        assert_eq!(r.counters().dropped_full, 1);
        // Without a master, upstream frames wait.
        assert_eq!(r.transmit(Port::P0), None);
        r.set_master(Some(Port::P0));
        assert!(r.transmit(Port::P0).is_some());
    }
}
