//! A skin cell on an STM32F405; flash it with `cargo fw-flash`.
#![no_std]
#![no_main]

use core::mem::MaybeUninit;

use cortex_m_rt::entry;
use skin_firmware::board::Firmware;
use skin_firmware::boards::stm32f4::{CellFlash, Stm32f4, STORE_BASE, STORE_LEN};
use skin_firmware::store::Store;
use skin_protocol::organize::Config;

#[entry]
fn main() -> ! {
    boot().run()
}

/// Sets the cell up, its whole state in one static so that `.bss` is the
/// RAM it takes. Not inlined: its stack frame (the drivers' set-up, the
/// store's first read) is gone before the main loop starts.
#[inline(never)]
fn boot() -> &'static mut Firmware<Stm32f4, CellFlash> {
    let Some(slot) = cortex_m::singleton!(: MaybeUninit<Firmware<Stm32f4, CellFlash>> = MaybeUninit::uninit()) else {
        defmt::panic!("firmware state taken twice");
    };
    let (board, flash) = Stm32f4::take();
    let store = match Store::open(flash, STORE_BASE, STORE_LEN) {
        Ok(store) => store,
        Err(e) => defmt::panic!("persistent store: {}", e),
    };
    defmt::info!("cell booting, stored ID {}", store.state().id);
    Firmware::boot(slot, board, Config::default(), store)
}
