//! The boards a cell runs on; each exists only for its target and feature.

#[cfg(feature = "qemu")]
pub mod qemu;
pub mod stack;
#[cfg(feature = "stm32f4")]
pub mod stm32f4;
pub mod systick;

/// The `main` of a cell binary: takes `$board` (whose `take()` gives the
/// board and its flash), opens the store in `$store_len` bytes of that
/// flash from `$store_base`, and runs the firmware with `$config`.
///
/// The state lives in one static so that `.bss` is the RAM it takes; the
/// boot function is not inlined, so its stack frame (drivers' set-up, the
/// store's first read) is gone before the main loop starts.
#[macro_export]
macro_rules! cell_main {
    ($board:ty, $flash:ty, $store_base:expr, $store_len:expr, $config:expr) => {
        #[cortex_m_rt::entry]
        fn main() -> ! {
            boot().run()
        }

        #[inline(never)]
        fn boot() -> &'static mut $crate::board::Firmware<$board, $flash> {
            type State = core::mem::MaybeUninit<$crate::board::Firmware<$board, $flash>>;
            let Some(slot) = cortex_m::singleton!(: State = State::uninit()) else {
                defmt::panic!("firmware state taken twice");
            };
            let (board, flash) = <$board>::take();
            let store = match $crate::store::Store::<_>::open(flash, $store_base, $store_len) {
                Ok(store) => store,
                Err(e) => defmt::panic!("persistent store: {}", e),
            };
            defmt::info!("cell booting, stored ID {}", store.state().id);
            $crate::board::Firmware::boot(slot, board, $config, store)
        }
    };
}
