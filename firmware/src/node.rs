//! One skin cell on a board: the cell application of the protocol crate
//! ([`CellApp`]: network stack, processing, settings) on the cell's flash
//! store, and the byte-level framing of the four ports.
//!
//! The board hands it received bytes, raw samples and the time; it hands
//! back frames to transmit, the settings to apply to the hardware and,
//! once the board gave it an [`Updater`] and a spare slot
//! ([`Node::take_updates`]), what its bootloader must do for an update.

use core::mem::MaybeUninit;
use core::ptr::addr_of_mut;

use embedded_storage::nor_flash::NorFlash;
use skin_protocol::app::{CellApp, Delivered, Losses, StoreFailed, UpdateInput};
use skin_protocol::cell::{Arrived, Cell};
use skin_protocol::frame::Frame;
use skin_protocol::message::{Port, Setting};
use skin_protocol::organize::Config;
use skin_protocol::processing::Processor;
use skin_protocol::update::{BootAction, Slot, Updater};
use skin_protocol::{Address, Sample};

use crate::deframer::Deframer;
use crate::store::Store;

/// The spare slot of a board without a bootloader: it holds nothing, so
/// every update offer is refused as too long.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct NoSlot;

impl Slot for NoSlot {
    fn capacity(&self) -> u32 {
        0
    }

    fn erase(&mut self) -> Result<(), StoreFailed> {
        Err(StoreFailed)
    }

    fn write(&mut self, _: u32, _: &[u8]) -> Result<(), StoreFailed> {
        Err(StoreFailed)
    }

    fn read(&self, _: u32, _: &mut [u8]) -> Result<(), StoreFailed> {
        Err(StoreFailed)
    }
}

/// Update messages a node holds between [`Node::receive`] and
/// [`Node::handle_updates`]: the frames that end in one 64-byte read of a port.
pub const PENDING_UPDATES: usize = 4;

/// A skin cell's logic; `S` is the spare image slot.
#[derive(Debug)]
pub struct Node<F, S = NoSlot> {
    app: CellApp<Store<F>>,
    rx: [Deframer; 4],
    update: Option<(Updater, S)>,
    pending: [Option<UpdateInput>; PENDING_UPDATES],
    dropped_updates: u32,
    boot_action: Option<BootAction>,
}

impl<F: NorFlash, S: Slot> Node<F, S> {
    /// Boots with what the store holds: ID, offsets and settings (see
    /// [`skin_protocol::app::App::new`]).
    pub fn new(config: Config, store: Store<F>, now_us: u64) -> Node<F, S> {
        let mut slot = MaybeUninit::uninit();
        Node::boot(&mut slot, config, store, now_us);
        // SAFETY: `boot` wrote every field.
        unsafe { slot.assume_init() }
    }

    /// [`Node::new`] built in place, in a static: no copy of the state
    /// (kilobytes of queues) passes through the stack at boot.
    pub fn boot(slot: &mut MaybeUninit<Node<F, S>>, config: Config, store: Store<F>, now_us: u64) -> &mut Node<F, S> {
        let node = slot.as_mut_ptr();
        // SAFETY: each field is written once through a pointer into `slot`,
        // and the node is only referred to once all are written.
        unsafe {
            CellApp::<_, ()>::new_in(&mut *addr_of_mut!((*node).app).cast(), config, store, now_us);
            addr_of_mut!((*node).rx).write(Default::default());
            addr_of_mut!((*node).update).write(None);
            addr_of_mut!((*node).pending).write([None; PENDING_UPDATES]);
            addr_of_mut!((*node).dropped_updates).write(0);
            addr_of_mut!((*node).boot_action).write(None);
            slot.assume_init_mut()
        }
    }

    /// This cell's address.
    pub fn id(&self) -> Address {
        self.app.id()
    }

    /// The network stack.
    pub fn cell(&self) -> &Cell {
        self.app.cell()
    }

    /// The local processing.
    pub fn processor(&self) -> &Processor {
        self.app.processor()
    }

    /// The persistent store.
    pub fn store(&self) -> &Store<F> {
        self.app.store()
    }

    /// What was given up so far.
    pub fn losses(&self) -> Losses {
        self.app.losses()
    }

    /// True while a calibration runs (nothing is sent).
    pub fn calibrating(&self) -> bool {
        self.app.processor().calibrating()
    }

    /// Takes updates from here on: `updater` knows the board, the key and
    /// the running image; `spare` is the slot not running.
    pub fn take_updates(&mut self, updater: Updater, spare: S) {
        self.update = Some((updater, spare));
    }

    /// The updater and its slot, once given.
    pub fn updates(&self) -> Option<&(Updater, S)> {
        self.update.as_ref()
    }

    /// What the bootloader must do, once (the board keeps the boot record
    /// and restarts as the action says).
    pub fn take_boot_action(&mut self) -> Option<BootAction> {
        self.boot_action.take()
    }

    /// Takes a byte received on `port`. Returns a setting the host wrote and
    /// the cell accepted, for the board to apply to its hardware. Update
    /// messages wait for [`Node::handle_updates`] (a node without an
    /// updater ignores them, as a cell of an older firmware would).
    pub fn receive(&mut self, port: Port, byte: u8, now_us: u64) -> Option<Setting> {
        let frame = self.rx[port.index()].push(byte)?;
        match self.app.receive_frame(Arrived { port, frame, meta: None }, now_us, &mut ())? {
            Delivered::Config(write) => self.app.configure(&write, &mut (), |_, _| {}),
            Delivered::Update(input) if self.update.is_some() => {
                match self.pending.iter_mut().find(|p| p.is_none()) {
                    Some(free) => *free = Some(input),
                    // The host repeats what a cell reports missing.
                    None => self.dropped_updates = self.dropped_updates.saturating_add(1),
                }
                None
            }
            Delivered::Update(_) => None,
        }
    }

    /// True when `frames` more received on `port` drop nothing here. What
    /// comes down the master port is copied to every child port, so while a
    /// child's queue is nearly full the master port is left unread: its
    /// bytes wait on the link (a QEMU UART holds its sender back; a DMA
    /// ring holds them for a while), and an update's broadcast flows at the
    /// pace of the slowest child instead of being dropped and asked for
    /// again. Upstream ports are always read: sensor data never waits.
    pub fn can_take(&self, port: Port, frames: usize) -> bool {
        let cell = self.app.cell();
        cell.organizer().master() != Some(port) || cell.router().downstream_room() >= frames
    }

    /// True when update messages wait for [`Node::handle_updates`].
    pub fn has_updates(&self) -> bool {
        self.pending.iter().any(Option::is_some)
    }

    /// Update messages dropped because [`PENDING_UPDATES`] were waiting.
    pub fn dropped_updates(&self) -> u32 {
        self.dropped_updates
    }

    /// Hands the waiting update messages to the updater, in order; a boot
    /// action waits in [`Node::take_boot_action`]. The signature and image
    /// checks behind them need kilobytes of stack: call this from the top
    /// of the main loop, not from deep in the byte path (out of line, so
    /// no caller reserves its frame).
    #[inline(never)]
    pub fn handle_updates(&mut self, now_us: u64) {
        for i in 0..PENDING_UPDATES {
            if let Some(input) = self.pending[i].take() {
                self.update(&input, now_us);
            }
        }
    }

    /// An update message to the updater.
    #[inline(never)]
    fn update(&mut self, input: &UpdateInput, now_us: u64) {
        if let Some((updater, slot)) = self.update.as_mut() {
            let action = self.app.update(input, updater, slot, now_us, &mut (), |_, _| {});
            self.boot_action = action.or(self.boot_action);
        }
    }

    /// The next time [`Node::poll`] has work.
    pub fn poll_at(&self) -> u64 {
        self.app.poll_at()
    }

    /// Lets time pass for the network stack and the updater.
    pub fn poll(&mut self, now_us: u64) {
        self.app.poll(now_us, &mut ());
        if let Some((updater, _)) = self.update.as_mut() {
            self.app.poll_update(updater, now_us, &mut (), |_, _| {});
        }
    }

    /// The sampling period.
    pub fn period_us(&self) -> u64 {
        self.app.processor().period_us()
    }

    /// Takes one raw sample: filters it and sends what the processing
    /// decides, or adds it to a running calibration and keeps the offsets.
    pub fn sample(&mut self, raw: &Sample) {
        self.app.sample(raw, &mut (), |_, _| {});
    }

    /// True when `port` has frames to transmit.
    pub fn has_pending(&self, port: Port) -> bool {
        self.app.has_pending(port)
    }

    /// The next frame for `port`, whose transmitter has room for it.
    pub fn transmit(&mut self, port: Port) -> Option<Frame> {
        self.app.transmit(port)
    }

    /// Gives the store back (a reboot keeps it).
    pub fn into_store(self) -> Store<F> {
        self.app.into_store()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::store::RamFlash;
    use skin_protocol::frame::{self, Frame};
    use skin_protocol::message::{ConfigAck, ConfigWrite, IdAssign, Message, TrafficMode};
    use skin_protocol::organize::{FromCell, Sink};

    type Flash = RamFlash<1024, 2>;

    fn node<S: Slot>(flash: Flash, now_us: u64) -> Node<Flash, S> {
        Node::new(Config::default(), Store::open(flash, 0, 2048).unwrap(), now_us)
    }

    /// A node on port 0 of an interface port: every byte each way, on a
    /// virtual clock in 100 us steps; returns what reached the host.
    fn exchange<S: Slot>(
        node: &mut Node<Flash, S>,
        sink: &mut Sink,
        down: &mut Vec<Frame>,
        t: &mut u64,
        until: u64,
    ) -> Vec<Frame> {
        let mut up = Vec::new();
        while *t < until {
            if node.poll_at() <= *t {
                node.poll(*t);
            }
            sink.poll(*t);
            for f in down.drain(..) {
                sink.send(f).unwrap();
            }
            while let Some(frame) = node.transmit(Port::P0) {
                if let Ok(FromCell::Host(f)) = sink.receive(frame.as_bytes(), *t) {
                    up.push(f);
                }
            }
            while let Some(f) = sink.transmit() {
                for b in f.as_bytes() {
                    node.receive(Port::P0, *b, *t);
                }
                node.handle_updates(*t);
            }
            if t.is_multiple_of(4_000) {
                node.sample(&Sample::new(500, [100, 100, 100], [0, 0, 256], 800, 0).unwrap());
            }
            *t += 100;
        }
        up
    }

    /// Lets `node` ask for an ID and gives it 17.
    fn join<S: Slot>(node: &mut Node<Flash, S>, sink: &mut Sink, down: &mut Vec<Frame>, t: &mut u64) {
        let up = exchange(node, sink, down, t, *t + 100_000);
        let request = up.iter().find_map(|f| match f.message() {
            Ok(Message::IdRequest(r)) => Some(r),
            _ => None,
        });
        let r = request.expect("an ID request reached the host");
        let assign = Message::IdAssign(IdAssign { port: r.port, id: Address(17) });
        down.push(Frame::new(Address::HOST, r.parent, &assign));
    }

    #[test]
    fn gets_an_id_calibrates_obeys_config_and_keeps_it_all_across_a_reboot() {
        let mut t = 0;
        let mut sink = Sink::new(0, Config::default(), 0).unwrap();
        let mut n: Node<Flash> = node(Flash::default(), 0);
        let mut down = Vec::new();
        join(&mut n, &mut sink, &mut down, &mut t);
        let write = Message::ConfigWrite(ConfigWrite { tag: 9, setting: Setting::Traffic(TrafficMode::Event) });
        let up = exchange(&mut n, &mut sink, &mut down, &mut t, 300_000);
        assert_eq!(n.id(), Address(17));
        assert!(!n.calibrating());
        assert_eq!(n.store().state().offsets, Some([500, 100, 100, 100, 0, 0, 0, 0]));
        let sample = up.iter().rev().find_map(|f| match f.message() {
            Ok(Message::Sample(s)) if f.src() == Address(17) => Some(s),
            _ => None,
        });
        let s = sample.expect("samples flow once the cell has an ID");
        assert_eq!((s.proximity(), s.force(), s.accel(), s.temperature()), (0, [0; 3], [0, 0, 256], 800));

        down.push(Frame::new(Address::HOST, Address(17), &write));
        let up = exchange(&mut n, &mut sink, &mut down, &mut t, 400_000);
        let ack = Frame::new(Address(17), Address::HOST, &Message::ConfigAck(ConfigAck { tag: 9, accepted: true }));
        assert!(up.contains(&ack));
        let samples_after_ack = up.iter().skip_while(|f| **f != ack).filter(|f| f.kind() == frame::Kind::Sample);
        assert!(samples_after_ack.count() <= 1, "event traffic: a still sample is sent once at most");

        // Reboot: same flash, new RAM.
        let mut n: Node<Flash> = node(n.into_store().release(), t);
        assert_eq!(n.id(), Address(17));
        assert!(!n.calibrating());
        assert_eq!(n.processor().traffic(), TrafficMode::Event);
        let up = exchange(&mut n, &mut sink, &mut down, &mut t, 700_000);
        assert!(up.iter().all(|f| !matches!(f.message(), Ok(Message::IdRequest(_)))), "no new ID asked for");
    }

    mod update;
}
