//! Panics at once: QEMU must exit with the panic handler's failure code.
#![no_std]
#![no_main]

use cortex_m_rt::entry;
use skin_firmware::boards::qemu::Qemu;

#[entry]
fn main() -> ! {
    let _board = Qemu::start();
    panic!("deliberate panic: the harness checks that QEMU exits with a failure code");
}
