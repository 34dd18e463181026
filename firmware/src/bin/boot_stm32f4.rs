//! The bootloader of an STM32F405 cell, in flash sectors 0 and 1: the boot
//! record and the slots are in sectors 7 to 10, the chosen body is
//! installed in sector 4 (only when it differs) and started there, the
//! independent watchdog armed. Nothing to boot: it logs why and waits for
//! a probe.
#![no_std]
#![no_main]

use skin_firmware::boards::stm32f4::{boot_parts, CellFlash, Watchdog};
use skin_firmware::flash_map::{STM32F4, STM32F4_FLASH};
use skin_firmware::loader::LoadError;
use skin_protocol::image::Board;

fn fail(e: LoadError) -> ! {
    defmt::error!("bootloader: nothing to boot: {}", e);
    loop {
        cortex_m::asm::wfi();
    }
}

fn started(peak: usize) {
    defmt::info!("bootloader: stack peak {} bytes", peak);
}

fn parts() -> (CellFlash, Watchdog) {
    match boot_parts() {
        Some(parts) => parts,
        None => fail(LoadError::Slot),
    }
}

skin_firmware::boot_main!(
    parts(),
    STM32F4,
    Board::Stm32f405,
    |shared| shared,
    STM32F4.exec.base - STM32F4_FLASH,
    started,
    fail
);
