//! The bootloader of QEMU's mps2-an386 cells: the boot record and the
//! slots are in the semihosting flash file, the chosen body goes to code
//! SRAM at 0x0001_0000 and is started there, the board's watchdog armed.
//! Nothing to boot: QEMU exits with code 6.
#![no_std]
#![no_main]

use skin_firmware::boards::qemu::{exit, CodeSram, FlashFile, Watchdog};
use skin_firmware::boards::stack;
use skin_firmware::flash_map::QEMU;
use skin_firmware::loader::LoadError;
use skin_protocol::image::Board;

/// The stack peak on QEMU's stderr, beside the cell's own reports.
fn started(peak: usize) {
    semihosting::eprintln!("bootloader stack peak {} bytes of {} reserved", peak, stack::reserved_bytes());
}

fn fail(e: LoadError) -> ! {
    defmt::error!("bootloader: nothing to boot: {}", e);
    exit(6)
}

// SAFETY: nothing runs from the execution region until the jump.
skin_firmware::boot_main!(
    (FlashFile::open(), Watchdog),
    QEMU,
    Board::Mps2An386,
    |_| unsafe { CodeSram::take() },
    QEMU.exec.base,
    started,
    fail
);
