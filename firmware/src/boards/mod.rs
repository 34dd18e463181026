//! The boards a cell runs on; each exists only for its target and feature.

#[cfg(feature = "qemu")]
pub mod qemu;
pub mod stack;
#[cfg(feature = "stm32f4")]
pub mod stm32f4;
pub mod systick;

/// Starts the program whose vector table is at `vector_table`: its
/// vectors for the core (VTOR), its initial stack pointer, its reset handler.
///
/// # Safety
/// A genuine program's vector table is there, and nothing the caller set
/// up (interrupts, SysTick) is still running.
pub unsafe fn jump(vector_table: u32) -> ! {
    // SAFETY: the caller's promise; VTOR is written before any interrupt can come.
    unsafe {
        (*cortex_m::peripheral::SCB::PTR).vtor.write(vector_table);
        cortex_m::asm::dsb();
        cortex_m::asm::isb();
        cortex_m::asm::bootload(vector_table as usize as *const u32)
    }
}

/// The `main` of a cell binary: takes `$board` (whose `take()` gives the
/// board and its flash, `$flash`), opens the store, the boot record and
/// the spare slot where `$map` (a [`crate::flash_map::FlashMap`]) says,
/// and runs the firmware with `$config`, taking updates for images of
/// `$image_board` whose trial must be confirmed within `$trial_us`.
///
/// The state lives in statics so that `.bss` is the RAM it takes; the
/// boot function is not inlined, so its stack frame (drivers' set-up, the
/// store's first read) is gone before the main loop starts.
#[macro_export]
macro_rules! cell_main {
    ($board:ty, $flash:ty, $map:expr, $image_board:expr, $config:expr, $trial_us:expr) => {
        type SharedCellFlash = $crate::shared_flash::SharedFlash<'static, $flash>;

        #[cortex_m_rt::entry]
        fn main() -> ! {
            boot().run()
        }

        #[inline(never)]
        fn boot() -> &'static mut $crate::board::Firmware<$board, SharedCellFlash> {
            use $crate::board::Board as _;
            type State = core::mem::MaybeUninit<$crate::board::Firmware<$board, SharedCellFlash>>;
            let Some(slot) = cortex_m::singleton!(: State = State::uninit()) else {
                defmt::panic!("firmware state taken twice");
            };
            let (mut board, flash) = <$board>::take();
            let Some(flash) = cortex_m::singleton!(: core::cell::RefCell<$flash> = core::cell::RefCell::new(flash))
            else {
                defmt::panic!("flash taken twice");
            };
            let flash = $crate::shared_flash::SharedFlash::new(flash);
            let map: $crate::flash_map::FlashMap = $map;
            let store = match $crate::store::Store::<_>::open(flash.clone(), map.store.base, map.store.len) {
                Ok(store) => store,
                Err(e) => defmt::panic!("persistent store: {}", e),
            };
            let now_us = board.now_us();
            let key = $crate::UPDATE_KEY;
            let updates = match $crate::boot_control::start(flash, &map, $image_board, key, $trial_us, now_us) {
                Ok(updates) => {
                    let r = updates.0.record();
                    defmt::info!("cell booting version {} from slot {} ({}), stored ID {}", updates.1.running(), r.running(), r.state(), store.state().id);
                    Some(updates)
                }
                Err(e) => {
                    defmt::error!("no updates: {}; stored ID {}", e, store.state().id);
                    None
                }
            };
            $crate::board::Firmware::boot(slot, board, $config, store, updates)
        }
    };
}

/// The `main` of a bootloader binary: takes `$parts`, the board's flash
/// and its hardware watchdog (a value whose `arm(self)` starts it),
/// chooses the slot of the flash (laid out as `$map`) for images of
/// `$image_board`, installs its body into `$exec(shared flash)` (a NOR
/// flash holding the execution region at offset `$exec_base`: code SRAM,
/// or the same flash) and jumps to it, after telling `$started(stack peak
/// in bytes)` and arming the watchdog, so a program that hangs is reset
/// (and a trial image that hangs is left for the old one); if nothing can
/// be booted, `$fail(error)`.
#[macro_export]
macro_rules! boot_main {
    ($parts:expr, $map:expr, $image_board:expr, $exec:expr, $exec_base:expr, $started:expr, $fail:expr) => {
        #[cortex_m_rt::entry]
        fn main() -> ! {
            use $crate::boot::BootRecord;
            use $crate::flash_slot::FlashSlot;
            let map: $crate::flash_map::FlashMap = $map;
            let (flash, watchdog) = $parts;
            let flash = core::cell::RefCell::new(flash);
            let shared = || $crate::shared_flash::SharedFlash::new(&flash);
            let records = $crate::store::Store::<_, BootRecord>::open(shared(), map.records.base, map.records.len);
            let slot = |i: usize| FlashSlot::new(shared(), map.slots[i].base, map.slots[i].len);
            let (mut records, a, b) = match (records, slot(0), slot(1)) {
                (Ok(r), Ok(a), Ok(b)) => (r, a, b),
                _ => $fail($crate::loader::LoadError::Slot),
            };
            let mut exec = $crate::loader::Exec { flash: ($exec)(shared()), base: $exec_base, len: map.exec.len };
            match $crate::loader::load(&mut records, [&a, &b], &mut exec, $image_board, &$crate::UPDATE_KEY) {
                Ok((slot, header)) => {
                    defmt::info!("bootloader: slot {}, version {}, {} bytes", slot, header.version, header.body_len);
                    $started($crate::boards::stack::peak_bytes());
                    watchdog.arm();
                    // SAFETY: the region holds the verified body, linked there; nothing was started.
                    unsafe { $crate::boards::jump(map.exec.base) }
                }
                Err(e) => $fail(e),
            }
        }
    };
}
