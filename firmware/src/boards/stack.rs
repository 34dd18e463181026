//! Stack use, measured. cortex-m-rt (`paint-stack`) fills the RAM between
//! the end of the statics (`_stack_end`) and the top of RAM
//! (`_stack_start`) with [`STACK_PAINT_VALUE`] before `main`; the stack grows
//! down from the top, so the lowest word no longer painted marks the deepest
//! the stack has been since boot, interrupts included.
//!
//! The memory layout reserves `_stack_reserve` bytes for the stack and fails
//! the link when the statics leave less (`memory/stack.x`); the peak measured
//! here is what says the reserve is enough.

use core::ptr::addr_of;

use cortex_m_rt::STACK_PAINT_VALUE;

extern "C" {
    static _stack_start: u32;
    static _stack_end: u32;
    /// A linker symbol whose address is the number of bytes reserved.
    static _stack_reserve: u8;
}

/// The stack bounds: (lowest word it may use, one past its top).
fn bounds() -> (*const u32, *const u32) {
    (addr_of!(_stack_end), addr_of!(_stack_start))
}

/// Bytes the memory layout reserves for the stack.
pub fn reserved_bytes() -> usize {
    addr_of!(_stack_reserve) as usize
}

/// Bytes between the end of the statics and the top of RAM.
pub fn room_bytes() -> usize {
    let (bottom, top) = bounds();
    top as usize - bottom as usize
}

/// The deepest the stack has been since boot, in bytes.
pub fn peak_bytes() -> usize {
    let (bottom, top) = bounds();
    let mut p = bottom;
    // SAFETY: every word from the end of the statics to the top of RAM is
    // RAM, painted at boot or written by the stack since.
    while p < top && unsafe { p.read_volatile() } == STACK_PAINT_VALUE {
        p = p.wrapping_add(1);
    }
    top as usize - p as usize
}

/// Reports the peak when it grows, checking at most once per period.
#[derive(Debug)]
pub struct PeakWatch {
    reported: usize,
    next_check_us: u64,
}

impl PeakWatch {
    /// Scans the unused stack (a few thousand instructions) once per this period.
    const PERIOD_US: u64 = 1_000_000;

    /// Nothing reported yet.
    pub const fn new() -> PeakWatch {
        PeakWatch { reported: 0, next_check_us: 0 }
    }

    /// The new peak when it grew since the last report, if a check is due.
    pub fn grew(&mut self, now_us: u64) -> Option<usize> {
        if now_us < self.next_check_us {
            return None;
        }
        self.next_check_us = now_us + Self::PERIOD_US;
        let peak = peak_bytes();
        (peak > self.reported).then(|| {
            self.reported = peak;
            if peak > reserved_bytes() {
                defmt::error!("stack peak {} bytes is over the {} bytes reserved", peak, reserved_bytes());
            }
            peak
        })
    }
}

impl Default for PeakWatch {
    fn default() -> Self {
        PeakWatch::new()
    }
}
