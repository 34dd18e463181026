//! The cost of one 250 Hz cycle of a cell, in instructions: the processing
//! of a sample and the routing of a full upstream queue
//! ([`skin_firmware::cycle`]).
//!
//! Run under QEMU with `-icount shift=0`: every instruction then takes 1 ns
//! of virtual time, and SysTick (25 MHz) counts one tick per 40
//! instructions. Each part is repeated `ROUNDS` times, so the tick
//! granularity is below one instruction per cycle. Prints text over
//! semihosting and exits 0.
#![no_std]
#![no_main]

use core::mem::MaybeUninit;

use cortex_m_rt::entry;
use skin_firmware::boards::qemu::{exit, Ticks, INSTRUCTIONS_PER_TICK};
use skin_firmware::cycle;
use skin_protocol::router::UP_QUEUE;

const ROUNDS: u32 = 200;

/// Instructions `f` takes, averaged over `ROUNDS` calls.
fn measure(ticks: &Ticks, mut f: impl FnMut(u32)) -> u64 {
    let total: u64 = (0..ROUNDS).map(|round| ticks.count(|| f(round)).1).sum();
    total * INSTRUCTIONS_PER_TICK / u64::from(ROUNDS)
}

#[entry]
fn main() -> ! {
    let Some(mut core) = cortex_m::Peripherals::take() else { exit(2) };
    let ticks = Ticks::start(&mut core.SYST);

    let mut flash = cycle::CycleFlash::new();
    let mut slot = MaybeUninit::uninit();
    let Some(node) = cycle::boot(&mut slot, &mut flash) else { exit(2) };
    let empty = measure(&ticks, |_| {});
    // Scale check: `delay(n)` is a two-instruction loop of n + 1 turns.
    let delay = measure(&ticks, |_| cortex_m::asm::delay(10_000)).saturating_sub(empty);
    let processing = measure(&ticks, |round| cycle::process(node, round)).saturating_sub(empty);
    let queue = cycle::queue();
    let routing = measure(&ticks, |_| cycle::route(node, &queue)).saturating_sub(empty);
    let counters = *node.cell().router().counters();
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
