//! A skin cell on an STM32F405; flash it with `cargo fw-flash`.
#![no_std]
#![no_main]

use cortex_m_rt::entry;
use skin_firmware::board::{Board, Firmware};
use skin_firmware::boards::stm32f4::{Stm32f4, STORE_BASE, STORE_LEN};
use skin_firmware::node::Node;
use skin_firmware::store::Store;
use skin_protocol::organize::Config;

#[entry]
fn main() -> ! {
    let (mut board, flash) = Stm32f4::take();
    let store = match Store::open(flash, STORE_BASE, STORE_LEN) {
        Ok(store) => store,
        Err(e) => defmt::panic!("persistent store: {}", e),
    };
    defmt::info!("cell booting, stored ID {}", store.state().id);
    let now_us = board.now_us();
    Firmware::new(board, Node::new(Config::default(), store, now_us)).run()
}
