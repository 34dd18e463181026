//! The cost of one 250 Hz cycle of a cell, in instructions: the processing
//! of a sample (filter, offsets, events, send) and the routing of a full
//! upstream queue (16 frames received byte by byte on a child port,
//! deframed, checked, queued and handed as frames to the master port's
//! transmitter, which is a DMA stream on a real cell).
//!
//! Run under QEMU with `-icount shift=0`: every instruction then takes 1 ns
//! of virtual time, and SysTick (25 MHz) counts one tick per 40
//! instructions. Each part is repeated `ROUNDS` times, so the tick
//! granularity is below one instruction per cycle. Prints text over
//! semihosting and exits 0.
#![no_std]
#![no_main]

use cortex_m::peripheral::{syst::SystClkSource, SYST};
use cortex_m_rt::entry;
use skin_firmware::boards::qemu::exit;
use skin_firmware::node::Node;
use skin_firmware::store::{RamFlash, Store};
use skin_protocol::frame::Frame;
use skin_protocol::message::{Beacon, Message, Port, Probe};
use skin_protocol::organize::{Config, IdStore};
use skin_protocol::router::UP_QUEUE;
use skin_protocol::{Address, Sample};

const ROUNDS: u32 = 200;
/// Instructions per SysTick tick under `-icount shift=0` at 25 MHz.
const INSTRUCTIONS_PER_TICK: u64 = 40;

/// Instructions `f` takes, averaged over `ROUNDS` calls.
fn measure(mut f: impl FnMut(u32)) -> u64 {
    let mut ticks = 0u64;
    for round in 0..ROUNDS {
        // SAFETY: read-only access to the SysTick counter.
        let start = unsafe { (*SYST::PTR).cvr.read() };
        f(round);
        // SAFETY: as above.
        let end = unsafe { (*SYST::PTR).cvr.read() };
        ticks += u64::from(start.wrapping_sub(end) & 0x00FF_FFFF);
    }
    ticks * INSTRUCTIONS_PER_TICK / u64::from(ROUNDS)
}

#[entry]
fn main() -> ! {
    let Some(mut core) = cortex_m::Peripherals::take() else { exit(2) };
    core.SYST.set_clock_source(SystClkSource::Core);
    core.SYST.set_reload(0x00FF_FFFF);
    core.SYST.clear_current();
    core.SYST.enable_counter();

    // A calibrated cell with ID 5 below an interface port on port 0, with a child on port 1.
    let mut store = Store::open(RamFlash::<1024, 2>::default(), 0, 2048).unwrap_or_else(|_| exit(2));
    store.store(Address(5));
    let _ = store.set_offsets([0; 8]);
    let mut node = Node::new(Config::default(), store, 0);
    let interface = Address::interface(0).unwrap_or(Address::HOST);
    let beacon = Frame::new(interface, Address::BROADCAST, &Message::Beacon(Beacon { interface: 0, seq: 1, hops: 0 }));
    let child = Frame::new(
        Address(9),
        Address::BROADCAST,
        &Message::Probe(Probe { port: Port::P3, id: Address(9), master: true }),
    );
    for (port, frame) in [(Port::P0, beacon), (Port::P1, child)] {
        for b in frame.as_bytes() {
            node.receive(port, *b, 1);
        }
    }
    let drain = |node: &mut Node<_>| {
        for p in Port::ALL {
            while node.transmit(p).is_some() {}
        }
    };
    drain(&mut node);
    if node.cell().organizer().master() != Some(Port::P0) {
        exit(2);
    }

    let empty = measure(|_| {});
    // Scale check: `delay(n)` is a two-instruction loop of n + 1 turns.
    let delay = measure(|_| cortex_m::asm::delay(10_000)).saturating_sub(empty);
    // A press rising and falling, so the filter moves and events fire.
    let processing = measure(|round| {
        let f = ((round % 50) * 80) as u16;
        node.sample(&Sample::saturating(1_000 + f, [f, f / 2, 0], [3, -2, 256], 800, 0));
        drain(&mut node);
    });
    let forwarded: [Frame; UP_QUEUE] = core::array::from_fn(|i| {
        let s = Sample::saturating(i as u16, [1, 2, 3], [0, 0, 256], 800, i as u8);
        Frame::new(Address(9), Address::HOST, &Message::Sample(s))
    });
    let routing = measure(|_| {
        for frame in &forwarded {
            for b in frame.as_bytes() {
                node.receive(Port::P1, *b, 2);
            }
        }
        drain(&mut node);
    });
    let counters = *node.cell().router().counters();
    let processing = processing.saturating_sub(empty);
    let routing = routing.saturating_sub(empty);
    let total = processing + routing;
    // One 4 ms period of a 64 MHz Cortex-M4: 256,000 cycles.
    let budget = 256_000;
    semihosting::println!("cycle-cost: {} rounds each, measurement overhead {} instructions", ROUNDS, empty);
    semihosting::println!(
        "scale check: asm::delay(10000) took {} instructions (expected 20002: 10001 turns of 2)",
        delay
    );
    semihosting::println!("processing of one sample (filter, events, send): {} instructions", processing);
    semihosting::println!(
        "routing of a full queue ({} frames in and out): {} instructions ({} per frame)",
        UP_QUEUE,
        routing,
        routing / UP_QUEUE as u64
    );
    semihosting::println!(
        "one 250 Hz cycle: {} instructions = {}.{:02} % of 4 ms at 64 MHz (1 cycle per instruction)",
        total,
        total * 100 / budget,
        total * 10_000 / budget % 100
    );
    semihosting::println!("forwarded {} frames, dropped {}", counters.forwarded_up, counters.dropped_full);
    exit(0)
}
