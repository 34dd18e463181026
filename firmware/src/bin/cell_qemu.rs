//! A skin cell on QEMU's mps2-an386.
#![no_std]
#![no_main]

use cortex_m_rt::entry;
use skin_firmware::board::{Board, Firmware, QEMU_CONFIG};
use skin_firmware::boards::qemu::{Qemu, STORE_LEN};
use skin_firmware::node::Node;
use skin_firmware::store::Store;

#[entry]
fn main() -> ! {
    let (mut board, flash) = Qemu::take();
    let store = match Store::open(flash, 0, STORE_LEN as u32) {
        Ok(store) => store,
        Err(e) => defmt::panic!("persistent store: {}", e),
    };
    defmt::info!("cell booting, stored ID {}", store.state().id);
    let now_us = board.now_us();
    Firmware::new(board, Node::new(QEMU_CONFIG, store, now_us)).run()
}
