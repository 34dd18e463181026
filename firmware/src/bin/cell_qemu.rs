//! A skin cell on QEMU's mps2-an386.
#![no_std]
#![no_main]

use core::mem::MaybeUninit;

use cortex_m_rt::entry;
use skin_firmware::board::{Firmware, QEMU_CONFIG};
use skin_firmware::boards::qemu::{Qemu, StoreFlash, STORE_LEN};
use skin_firmware::store::Store;

#[entry]
fn main() -> ! {
    boot().run()
}

/// Sets the cell up, its whole state in one static so that `.bss` is the
/// RAM it takes. Not inlined: its stack frame (the semihosting command
/// line, the store's first read) is gone before the main loop starts.
#[inline(never)]
fn boot() -> &'static mut Firmware<Qemu, StoreFlash> {
    let Some(slot) = cortex_m::singleton!(: MaybeUninit<Firmware<Qemu, StoreFlash>> = MaybeUninit::uninit()) else {
        defmt::panic!("firmware state taken twice");
    };
    let (board, flash) = Qemu::take();
    let store = match Store::open(flash, 0, STORE_LEN as u32) {
        Ok(store) => store,
        Err(e) => defmt::panic!("persistent store: {}", e),
    };
    defmt::info!("cell booting, stored ID {}", store.state().id);
    Firmware::boot(slot, board, QEMU_CONFIG, store)
}
