//! A skin cell on an STM32F405, started by `boot-stm32f4` (see the README
//! for flashing both and the first image).
#![no_std]
#![no_main]

use skin_firmware::boards::stm32f4::{CellFlash, Stm32f4};
use skin_firmware::flash_map::STM32F4;
use skin_protocol::image::Board;
use skin_protocol::organize::Config;
use skin_protocol::update::TRIAL_US;

skin_firmware::cell_main!(Stm32f4, CellFlash, STM32F4, Board::Stm32f405, Config::default(), TRIAL_US);
