//! The cell clock of every board: SysTick interrupts count ticks of a
//! board's period (1 ms on the STM32F405, 4 ms on QEMU), and the SysTick
//! counter gives the microseconds between. The tick also wakes the core
//! from its sleep at least once a period.

use core::sync::atomic::{AtomicU32, Ordering};

use cortex_m::peripheral::{syst::SystClkSource, SYST};
use cortex_m_rt::exception;

static TICKS: AtomicU32 = AtomicU32::new(0);

/// Microseconds since boot from SysTick on the core clock, ticking every
/// `tick_us`.
#[derive(Debug)]
pub struct Clock {
    core_hz: u32,
    tick_us: u32,
    wraps: u64,
    last_tick: u32,
}

impl Clock {
    /// Starts SysTick with a period of `tick_us` on a core clocked at
    /// `core_hz` (at most 2^24 core cycles).
    pub fn start(syst: &mut SYST, core_hz: u32, tick_us: u32) -> Clock {
        syst.set_clock_source(SystClkSource::Core);
        syst.set_reload(core_hz / 1_000_000 * tick_us - 1);
        syst.clear_current();
        syst.enable_interrupt();
        syst.enable_counter();
        Clock { core_hz, tick_us, wraps: 0, last_tick: 0 }
    }

    /// Ticks and microseconds into the tick, read consistently.
    fn parts(core_hz: u32) -> (u32, u32) {
        loop {
            let ticks = TICKS.load(Ordering::Acquire);
            let elapsed = SYST::get_reload() - SYST::get_current();
            if TICKS.load(Ordering::Acquire) == ticks {
                return (ticks, elapsed / (core_hz / 1_000_000));
            }
        }
    }

    /// Microseconds since [`Clock::start`], across wraps of the 32-bit
    /// tick count (every 49 days at 1 ms).
    pub fn now_us(&mut self) -> u64 {
        let (ticks, us) = Self::parts(self.core_hz);
        if ticks < self.last_tick {
            self.wraps += 1;
        }
        self.last_tick = ticks;
        ((self.wraps << 32) + u64::from(ticks)) * u64::from(self.tick_us) + u64::from(us)
    }

    /// Microseconds since start for log timestamps (the tick count wraps).
    pub fn log_time_us(core_hz: u32, tick_us: u32) -> u64 {
        let (ticks, us) = Self::parts(core_hz);
        u64::from(ticks) * u64::from(tick_us) + u64::from(us)
    }
}

#[exception]
fn SysTick() {
    TICKS.fetch_add(1, Ordering::Release);
}
