//! The 250 Hz cycle of the firmware's `cycle-cost` example
//! ([`skin_firmware::cycle`]) on the robot PC, to count its instructions
//! with callgrind: `process_rounds` and `route_rounds` run it `ROUNDS`
//! times each, and callgrind's inclusive count of each, divided by
//! `ROUNDS`, is the cost of one call (x86-64 instructions: a cross-check of
//! the Cortex-M4 count under QEMU, not the same instruction set):
//!
//! ```text
//! cargo build -p skin-tests --profile firmware --bin cycle-cost-host
//! valgrind --tool=callgrind --callgrind-out-file=cycle.callgrind target/firmware/cycle-cost-host
//! callgrind_annotate --inclusive=yes cycle.callgrind | grep '_rounds \['
//! ```

use std::mem::MaybeUninit;

use skin_firmware::cycle;
use skin_protocol::router::UP_QUEUE;

const ROUNDS: u32 = 200;

#[inline(never)]
fn process_rounds(node: &mut cycle::CycleNode) {
    for round in 0..ROUNDS {
        cycle::process(node, round);
    }
}

#[inline(never)]
fn route_rounds(node: &mut cycle::CycleNode, queue: &[skin_protocol::frame::Frame; UP_QUEUE]) {
    for _ in 0..ROUNDS {
        cycle::route(node, queue);
    }
}

fn main() {
    let mut flash = cycle::CycleFlash::new();
    let mut slot = MaybeUninit::uninit();
    let Some(node) = cycle::boot(&mut slot, &mut flash) else {
        eprintln!("cycle-cost-host: the cell did not organize below the interface port");
        std::process::exit(2);
    };
    process_rounds(node);
    let queue = cycle::queue();
    route_rounds(node, &queue);
    let counters = node.cell().router().counters();
    println!(
        "cycle-cost-host: {ROUNDS} rounds of processing and of routing {UP_QUEUE} frames; forwarded {}, dropped {}",
        counters.forwarded_up, counters.dropped_full
    );
}
