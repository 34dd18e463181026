//! One skin cell on a board: the cell application of the protocol crate
//! ([`CellApp`]: network stack, processing, settings) on the cell's flash
//! store, and the byte-level framing of the four ports.
//!
//! The board hands it received bytes, raw samples and the time; it hands
//! back frames to transmit and the settings to apply to the hardware.

use core::mem::MaybeUninit;
use core::ptr::addr_of_mut;

use embedded_storage::nor_flash::NorFlash;
use skin_protocol::app::{CellApp, Delivered, Losses};
use skin_protocol::cell::{Arrived, Cell};
use skin_protocol::frame::Frame;
use skin_protocol::message::{Port, Setting};
use skin_protocol::organize::Config;
use skin_protocol::processing::Processor;
use skin_protocol::{Address, Sample};

use crate::deframer::Deframer;
use crate::store::Store;

/// A skin cell's logic.
#[derive(Debug)]
pub struct Node<F> {
    app: CellApp<Store<F>>,
    rx: [Deframer; 4],
}

impl<F: NorFlash> Node<F> {
    /// Boots with what the store holds: ID, offsets and settings (see
    /// [`skin_protocol::app::App::new`]).
    pub fn new(config: Config, store: Store<F>, now_us: u64) -> Node<F> {
        let mut slot = MaybeUninit::uninit();
        Node::boot(&mut slot, config, store, now_us);
        // SAFETY: `boot` wrote every field.
        unsafe { slot.assume_init() }
    }

    /// [`Node::new`] built in place, in a static: no copy of the state
    /// (kilobytes of queues) passes through the stack at boot.
    pub fn boot(slot: &mut MaybeUninit<Node<F>>, config: Config, store: Store<F>, now_us: u64) -> &mut Node<F> {
        let node = slot.as_mut_ptr();
        // SAFETY: each field is written once through a pointer into `slot`,
        // and the node is only referred to once all are written.
        unsafe {
            addr_of_mut!((*node).app).write(CellApp::new(config, store, now_us));
            addr_of_mut!((*node).rx).write(Default::default());
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

    /// Takes a byte received on `port`. Returns a setting the host wrote and
    /// the cell accepted, for the board to apply to its hardware.
    pub fn receive(&mut self, port: Port, byte: u8, now_us: u64) -> Option<Setting> {
        let frame = self.rx[port.index()].push(byte)?;
        // Update messages wait for the bootloader (issue 18): a cell without
        // a slot ignores them, as a cell of an older firmware would.
        match self.app.receive_frame(Arrived { port, frame, meta: None }, now_us, &mut ())? {
            Delivered::Config(write) => self.app.configure(&write, &mut (), |_, _| {}),
            Delivered::Update(_) => None,
        }
    }

    /// The next time [`Node::poll`] has work.
    pub fn poll_at(&self) -> u64 {
        self.app.poll_at()
    }

    /// Lets time pass for the network stack.
    pub fn poll(&mut self, now_us: u64) {
        self.app.poll(now_us, &mut ());
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

    fn node(flash: Flash, now_us: u64) -> Node<Flash> {
        Node::new(Config::default(), Store::open(flash, 0, 2048).unwrap(), now_us)
    }

    /// A node on port 0 of an interface port: every byte each way, on a
    /// virtual clock in 100 us steps; returns what reached the host.
    fn exchange(node: &mut Node<Flash>, sink: &mut Sink, down: &mut Vec<Frame>, t: &mut u64, until: u64) -> Vec<Frame> {
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
            }
            if *t % 4_000 == 0 {
                node.sample(&Sample::new(500, [100, 100, 100], [0, 0, 256], 800, 0).unwrap());
            }
            *t += 100;
        }
        up
    }

    #[test]
    fn gets_an_id_calibrates_obeys_config_and_keeps_it_all_across_a_reboot() {
        let mut t = 0;
        let mut sink = Sink::new(0, Config::default(), 0).unwrap();
        let mut n = node(Flash::default(), 0);
        let mut down = Vec::new();
        let up = exchange(&mut n, &mut sink, &mut down, &mut t, 100_000);
        let request = up.iter().find_map(|f| match f.message() {
            Ok(Message::IdRequest(r)) => Some(r),
            _ => None,
        });
        let r = request.expect("an ID request reached the host");
        let assign = Message::IdAssign(IdAssign { port: r.port, id: Address(17) });
        down.push(Frame::new(Address::HOST, r.parent, &assign));
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
        let mut n = node(n.into_store().release(), t);
        assert_eq!(n.id(), Address(17));
        assert!(!n.calibrating());
        assert_eq!(n.processor().traffic(), TrafficMode::Event);
        let up = exchange(&mut n, &mut sink, &mut down, &mut t, 700_000);
        assert!(up.iter().all(|f| !matches!(f.message(), Ok(Message::IdRequest(_)))), "no new ID asked for");
    }
}
