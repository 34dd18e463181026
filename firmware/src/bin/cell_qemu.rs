//! A skin cell on QEMU's mps2-an386, started by `boot-qemu`.
#![no_std]
#![no_main]

use skin_firmware::board::{QEMU_CONFIG, QEMU_TRIAL_US};
use skin_firmware::boards::qemu::{FlashFile, Qemu};
use skin_firmware::flash_map::QEMU;
use skin_protocol::image::Board;

skin_firmware::cell_main!(Qemu, FlashFile, QEMU, Board::Mps2An386, QEMU_CONFIG, QEMU_TRIAL_US);
