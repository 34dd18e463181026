//! One 250 Hz cycle of a cell, the work the cycle-cost programs measure:
//! the `cycle-cost` example in instructions under QEMU, and skin-tests'
//! `cycle-cost-host` with callgrind on the robot PC's build of the same code.

use core::mem::MaybeUninit;

use crate::node::Node;
use crate::store::{RamFlash, Store};
use skin_protocol::frame::Frame;
use skin_protocol::message::{Beacon, Message, Port, Probe};
use skin_protocol::organize::{Config, IdStore};
use skin_protocol::router::UP_QUEUE;
use skin_protocol::{Address, Sample};

/// The measured cell's flash.
pub type CycleFlash = RamFlash<1024, 2>;
/// The measured cell.
pub type CycleNode<'a> = Node<&'a mut CycleFlash>;

/// Boots in `slot`, in place (the node is kilobytes, and the QEMU board
/// has 16 KiB of RAM), a calibrated cell with ID 5 below an interface port
/// on port 0, with a child on port 1; `None` if it did not take port 0 as
/// its master.
pub fn boot<'a>(slot: &'a mut MaybeUninit<CycleNode<'a>>, flash: &'a mut CycleFlash) -> Option<&'a mut CycleNode<'a>> {
    let mut store = Store::<_>::open(flash, 0, 2048).ok()?;
    store.store(Address(5));
    store.set_offsets([0; 8]).ok()?;
    let node = Node::boot(slot, Config::default(), store, 0);
    let interface = Address::interface(0)?;
    let beacon = Frame::new(interface, Address::BROADCAST, &Message::Beacon(Beacon { interface: 0, seq: 1, hops: 0 }));
    let probe = Message::Probe(Probe { port: Port::P3, id: Address(9), master: true, known: false, lost: true });
    let child = Frame::new(Address(9), Address::BROADCAST, &probe);
    for (port, frame) in [(Port::P0, beacon), (Port::P1, child)] {
        for b in frame.as_bytes() {
            node.receive(port, *b, 1);
        }
    }
    drain(node);
    (node.cell().organizer().master() == Some(Port::P0)).then_some(node)
}

/// Hands every frame the node has to its transmitters.
pub fn drain(node: &mut CycleNode) {
    for p in Port::ALL {
        while node.transmit(p).is_some() {}
    }
}

/// The processing of one sample (filter, offsets, events, send): a press
/// rising and falling over the rounds, so the filter moves and events fire.
pub fn process(node: &mut CycleNode, round: u32) {
    let f = ((round % 50) * 80) as u16;
    node.sample(&Sample::saturating(1_000 + f, [f, f / 2, 0], [3, -2, 256], 800, 0));
    drain(node);
}

/// A full upstream queue of the child's samples.
pub fn queue() -> [Frame; UP_QUEUE] {
    core::array::from_fn(|i| {
        let s = Sample::saturating(i as u16, [1, 2, 3], [0, 0, 256], 800, i as u8);
        Frame::new(Address(9), Address::HOST, &Message::Sample(s))
    })
}

/// The routing of a full queue: received byte by byte on the child's
/// port, deframed, checked, queued and handed as frames to the master
/// port's transmitter.
pub fn route(node: &mut CycleNode, queue: &[Frame; UP_QUEUE]) {
    for frame in queue {
        for b in frame.as_bytes() {
            node.receive(Port::P1, *b, 2);
        }
    }
    drain(node);
}
