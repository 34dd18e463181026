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

use cortex_m::peripheral::{syst::SystClkSource, SYST};
use cortex_m_rt::entry;
use skin_firmware::boards::qemu::exit;
use skin_firmware::cycle;
use skin_protocol::router::UP_QUEUE;

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

    let mut flash = cycle::CycleFlash::new();
    let mut slot = MaybeUninit::uninit();
    let Some(node) = cycle::boot(&mut slot, &mut flash) else { exit(2) };
    let empty = measure(|_| {});
    // Scale check: `delay(n)` is a two-instruction loop of n + 1 turns.
    let delay = measure(|_| cortex_m::asm::delay(10_000)).saturating_sub(empty);
    let processing = measure(|round| cycle::process(node, round)).saturating_sub(empty);
    let queue = cycle::queue();
    let routing = measure(|_| cycle::route(node, &queue)).saturating_sub(empty);
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
