//! A skin cell on an STM32F405; flash it with `cargo fw-flash`.
#![no_std]
#![no_main]

use skin_firmware::boards::stm32f4::{CellFlash, Stm32f4, STORE_BASE, STORE_LEN};
use skin_protocol::organize::Config;

skin_firmware::cell_main!(Stm32f4, CellFlash, STORE_BASE, STORE_LEN, Config::default());
