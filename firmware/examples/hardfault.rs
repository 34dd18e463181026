//! Executes an undefined instruction: the hard fault must end QEMU with a
//! failure code.
#![no_std]
#![no_main]

use cortex_m_rt::entry;
use skin_firmware::boards::qemu::Qemu;

#[entry]
fn main() -> ! {
    let _board = Qemu::start();
    cortex_m::asm::udf()
}
