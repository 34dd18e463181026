//! The cell clock of every board: SysTick interrupts at 1 kHz count
//! milliseconds, and the SysTick counter gives the microseconds between.
//! The tick also wakes the core from its sleep at least once a millisecond.

use core::sync::atomic::{AtomicU32, Ordering};

use cortex_m::peripheral::{syst::SystClkSource, SYST};
use cortex_m_rt::exception;

static MILLIS: AtomicU32 = AtomicU32::new(0);

/// Microseconds since boot from a 1 kHz SysTick on the core clock.
#[derive(Debug)]
pub struct Clock {
    core_hz: u32,
    wraps: u64,
    last_ms: u32,
}

impl Clock {
    /// Starts SysTick with a 1 ms period on a core clocked at `core_hz`.
    pub fn start(syst: &mut SYST, core_hz: u32) -> Clock {
        syst.set_clock_source(SystClkSource::Core);
        syst.set_reload(core_hz / 1_000 - 1);
        syst.clear_current();
        syst.enable_interrupt();
        syst.enable_counter();
        Clock { core_hz, wraps: 0, last_ms: 0 }
    }

    /// Milliseconds and microseconds into the millisecond, read consistently.
    fn parts(core_hz: u32) -> (u32, u32) {
        loop {
            let ms = MILLIS.load(Ordering::Acquire);
            let elapsed = SYST::get_reload() - SYST::get_current();
            if MILLIS.load(Ordering::Acquire) == ms {
                return (ms, elapsed / (core_hz / 1_000_000));
            }
        }
    }

    /// Microseconds since [`Clock::start`], across wraps of the 32-bit
    /// millisecond count (every 49 days).
    pub fn now_us(&mut self) -> u64 {
        let (ms, us) = Self::parts(self.core_hz);
        if ms < self.last_ms {
            self.wraps += 1;
        }
        self.last_ms = ms;
        ((self.wraps << 32) + u64::from(ms)) * 1_000 + u64::from(us)
    }

    /// Microseconds since start for log timestamps (wraps after 49 days).
    pub fn log_time_us(core_hz: u32) -> u64 {
        let (ms, us) = Self::parts(core_hz);
        u64::from(ms) * 1_000 + u64::from(us)
    }
}

#[exception]
fn SysTick() {
    MILLIS.fetch_add(1, Ordering::Release);
}
