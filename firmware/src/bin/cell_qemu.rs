//! A skin cell on QEMU's mps2-an386.
#![no_std]
#![no_main]

use skin_firmware::board::QEMU_CONFIG;
use skin_firmware::boards::qemu::{Qemu, StoreFlash, STORE_LEN};

skin_firmware::cell_main!(Qemu, StoreFlash, 0, STORE_LEN as u32, QEMU_CONFIG);
