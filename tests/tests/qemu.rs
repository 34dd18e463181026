//! Firmware under QEMU. These need the thumb build of the firmware and
//! `qemu-system-arm`, so they are ignored by a plain `cargo test`:
//!
//! ```text
//! cargo build -p skin-firmware --profile firmware --target thumbv7em-none-eabihf --features qemu --bin cell-qemu --examples
//! cargo test -p skin-tests --test qemu -- --ignored
//! ```

use std::time::Duration;

use skin_tests::qemu::cells::run_alone;
use skin_tests::qemu::default_elf_dir;
use skin_tests::qemu::net::{run, NetOptions};

fn exit_code(example: &str) -> Option<i32> {
    let elf = default_elf_dir().join("examples").join(example);
    let run = run_alone(&elf, &[], Duration::from_secs(20)).unwrap_or_else(|e| panic!("{e}"));
    run.status.expect("QEMU hung instead of exiting").code()
}

/// Runs a measuring example with one instruction per ns (`-icount`); it
/// must exit 0. Returns what it printed.
fn counted(example: &str) -> String {
    let elf = default_elf_dir().join("examples").join(example);
    let run = run_alone(&elf, &["-icount", "shift=0"], Duration::from_secs(60)).unwrap_or_else(|e| panic!("{e}"));
    let out = String::from_utf8_lossy(&run.stdout).into_owned();
    assert_eq!(run.status.and_then(|s| s.code()), Some(0), "{out}");
    out
}

#[test]
#[ignore]
fn a_panic_ends_qemu_with_the_panic_code() {
    assert_eq!(exit_code("panic"), Some(101));
}

#[test]
#[ignore]
fn a_hard_fault_ends_qemu_with_the_fault_code() {
    assert_eq!(exit_code("hardfault"), Some(3));
}

/// The cycle-cost measurement runs to the end (its node fits the board's
/// RAM), its scale check holds, and the cell forwards every frame.
#[test]
#[ignore]
fn the_cycle_cost_program_measures_a_whole_cycle() {
    let out = counted("cycle-cost");
    let delay = out.lines().find_map(|l| l.strip_prefix("scale check: asm::delay(10000) took "));
    let delay: u64 = delay.and_then(|d| d.split(' ').next()?.parse().ok()).unwrap_or_else(|| panic!("{out}"));
    assert!(delay.abs_diff(20_002) <= 40, "one SysTick tick of error at most: {out}");
    assert!(out.contains("forwarded 3200 frames, dropped 0"), "{out}");
}

/// The cell's CPU checks a signed image (RFC 8032's TEST 1 key): the
/// genuine one passes; a changed bit, a missing byte and a wrong board are
/// refused.
#[test]
#[ignore]
fn the_cell_cpu_verifies_a_signed_image_and_refuses_altered_ones() {
    let out = counted("image-verify");
    assert!(out.contains("verdicts Ok(2) Err(BadDigest)"), "{out}");
}

#[test]
#[ignore]
fn seven_qemu_cells_organize_deliver_and_survive_a_death() {
    let opts = NetOptions { cells: 7, elf: default_elf_dir().join("cell-qemu"), keep: false };
    let report = run(&opts, &mut |_| {}).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(report.ids.len(), 7);
    let stack = report.stack.expect("the cells report their stack peak in their QEMU logs");
    assert!(stack.peak_bytes <= stack.reserved_bytes, "stack {stack:?}: the memory layout reserves too little");
}
