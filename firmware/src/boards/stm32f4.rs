//! A real cell on an STM32F405 (Cortex-M4F) at 64 MHz from an 8 MHz crystal.
//!
//! | function            | peripheral | pins                    |
//! |---------------------|------------|-------------------------|
//! | port 0..3           | USART1, USART2, USART3, UART4 at 4 Mbit/s, DMA ([`ports`]) | PA9/PA10, PA2/PA3, PB10/PB11, PC10/PC11 |
//! | VCNL4010            | I2C1, 400 kHz | PB8 (SCL), PB9 (SDA) |
//! | BMA250, LM71        | SPI1, 4 MHz, mode 0 | PA5/PA6/PA7, chip selects PA4 (BMA250), PB0 (LM71) |
//! | force pads          | GPIO open drain, 1 MOhm pull-ups | PC0, PC1, PC2 |
//! | persistent store    | flash sectors 5 and 6, used in turn | 0x0802_0000, 2 x 128 KiB |
//! | images              | slots A and B in sectors 7 and 8, boot record in 9 and 10 ([`crate::flash_map::STM32F4`]) | |
//!
//! `boot-stm32f4` in sectors 0 and 1 chooses the image and installs its
//! body in sector 4, where this program is linked, and arms the
//! independent watchdog ([`Watchdog`]), which the main loop feeds.
//!
//! The core sleeps with WFE until a port receives, a DMA interrupt or the
//! tick ([`ports`] says how). Logs go out with defmt over RTT, and so does
//! the stack's peak use whenever it grows; a panic or a fault resets the
//! cell, which comes back with its ID, offsets and settings from flash.

use core::cell::RefCell;

use cortex_m::peripheral::{NVIC, SCB};
use cortex_m_rt::{exception, ExceptionFrame};
use embedded_hal_bus::spi::{NoDelay, RefCellDevice};
use embedded_storage::nor_flash::{ErrorType, NorFlash, ReadNorFlash};
use skin_protocol::message::{AccelRange, Port};
use stm32f4xx_hal::dma::traits::PeriAddress;
use stm32f4xx_hal::flash::{self, FlashExt, LockedFlash};
use stm32f4xx_hal::gpio::{ErasedPin, OpenDrain, Output, PushPull};
use stm32f4xx_hal::i2c::I2c;
use stm32f4xx_hal::pac::{self, Interrupt, I2C1, SPI1};
use stm32f4xx_hal::prelude::*;
use stm32f4xx_hal::rcc::Config as ClockConfig;
use stm32f4xx_hal::rcc::Enable;
use stm32f4xx_hal::serial::{self, config::DmaConfig, Serial};
use stm32f4xx_hal::spi::{Mode, Phase, Polarity, Spi};
use stm32f4xx_hal::watchdog::IndependentWatchdog;

use self::ports::DmaPort;
use super::stack::{self, PeakWatch};
use super::systick::Clock;
use crate::board::Board;
use crate::drivers::bma250::Bma250;
use crate::drivers::force::RcTiming;
use crate::drivers::lm71::Lm71;
use crate::drivers::vcnl4010::Vcnl4010;
use crate::sensors::Chips;

use defmt_rtt as _;

pub mod ports;

/// Core clock.
const SYSCLK_HZ: u32 = 64_000_000;
/// The clock's tick: every millisecond.
const TICK_US: u32 = 1_000;
/// Cell-2-cell bit rate (Table 2).
const PORT_BAUD: u32 = 4_000_000;
/// VCNL4010 LED current: 100 mA.
const LED_CURRENT: u8 = 10;

type Spi1 = Spi<SPI1>;
type SpiDevice = RefCellDevice<'static, Spi1, ErasedPin<Output<PushPull>>, NoDelay>;
/// The sensor chips of the cell.
pub type CellChips = Chips<I2c<I2C1>, SpiDevice, SpiDevice, ErasedPin<Output<OpenDrain>>>;

/// The STM32F405 cell.
pub struct Stm32f4 {
    ports: [DmaPort; 4],
    chips: CellChips,
    clock: Clock,
    stack: PeakWatch,
    watchdog: IndependentWatchdog,
}

impl Stm32f4 {
    /// Sets up clocks, ports, buses and sensors; returns the board and its
    /// persistent store's flash.
    pub fn take() -> (Stm32f4, CellFlash) {
        let (Some(dp), Some(mut cp)) = (pac::Peripherals::take(), cortex_m::Peripherals::take()) else {
            defmt::panic!("board taken twice");
        };
        let mut rcc = dp.RCC.freeze(ClockConfig::hse(8.MHz()).sysclk(SYSCLK_HZ.Hz()));
        let gpioa = dp.GPIOA.split(&mut rcc);
        let gpiob = dp.GPIOB.split(&mut rcc);
        let gpioc = dp.GPIOC.split(&mut rcc);

        pac::DMA1::enable(&mut rcc);
        pac::DMA2::enable(&mut rcc);
        let config = serial::Config::default().baudrate(PORT_BAUD.bps()).dma(DmaConfig::TxRx);
        macro_rules! port {
            ($index:expr, $usart:expr, $tx:expr, $rx:expr, $irq:expr) => {{
                let mut s: Serial<_> = match Serial::new($usart, ($tx, $rx), config, &mut rcc) {
                    Ok(s) => s,
                    Err(_) => defmt::panic!("port UART configuration"),
                };
                s.listen(serial::Event::RxNotEmpty);
                NVIC::unpend($irq);
                // The UART and its pins stay configured when the HAL's
                // handles go: from here on only the DMA touches it.
                let (_, rx) = s.split();
                // SAFETY: once per port, the DMAs clocked above and used by nothing else.
                unsafe { DmaPort::start($index, rx.address()) }
            }};
        }
        let ports = [
            port!(0, dp.USART1, gpioa.pa9, gpioa.pa10, Interrupt::USART1),
            port!(1, dp.USART2, gpioa.pa2, gpioa.pa3, Interrupt::USART2),
            port!(2, dp.USART3, gpiob.pb10, gpiob.pb11, Interrupt::USART3),
            port!(3, dp.UART4, gpioc.pc10, gpioc.pc11, Interrupt::UART4),
        ];
        // Pending receive interrupts wake WFE without running a handler.
        cp.SCB.set_sevonpend();

        let i2c = I2c::new(dp.I2C1, (gpiob.pb8, gpiob.pb9), 400.kHz(), &mut rcc);
        let mode = Mode { polarity: Polarity::IdleLow, phase: Phase::CaptureOnFirstTransition };
        let spi = Spi::new(dp.SPI1, (Some(gpioa.pa5), Some(gpioa.pa6), Some(gpioa.pa7)), mode, 4.MHz(), &mut rcc);
        let Some(bus) = cortex_m::singleton!(: RefCell<Spi1> = RefCell::new(spi)) else {
            defmt::panic!("SPI bus taken twice");
        };
        let device = |cs: ErasedPin<Output<PushPull>>| match RefCellDevice::new(bus, cs, NoDelay) {
            Ok(d) => d,
            Err(_) => defmt::panic!("chip select"),
        };
        let bma_device = device(gpioa.pa4.into_push_pull_output().erase());
        let lm_device = device(gpiob.pb0.into_push_pull_output().erase());
        let mut delay = dp.TIM5.delay_us(&mut rcc);
        let pads = [
            gpioc.pc0.into_open_drain_output().erase(),
            gpioc.pc1.into_open_drain_output().erase(),
            gpioc.pc2.into_open_drain_output().erase(),
        ];
        let chips = match (
            Vcnl4010::new(i2c, LED_CURRENT),
            Bma250::new(bma_device, &mut delay, AccelRange::G2),
            Lm71::new(lm_device),
        ) {
            (Ok(p), Ok(a), Ok(t)) => Chips::new(p, a, t, RcTiming::new(pads)),
            (p, a, t) => defmt::panic!(
                "sensor missing: proximity {}, accelerometer {}, temperature {}",
                p.is_ok(),
                a.is_ok(),
                t.is_ok()
            ),
        };
        let clock = Clock::start(&mut cp.SYST, SYSCLK_HZ, TICK_US);
        // Started by the bootloader; only fed here.
        let watchdog = IndependentWatchdog::new(dp.IWDG);
        (Stm32f4 { ports, chips, clock, stack: PeakWatch::new(), watchdog }, CellFlash(LockedFlash::new(dp.FLASH)))
    }
}

impl Board for Stm32f4 {
    type Port = DmaPort;
    type Sensors = CellChips;

    fn now_us(&mut self) -> u64 {
        self.clock.now_us()
    }

    fn port(&mut self, port: Port) -> &mut DmaPort {
        &mut self.ports[port.index()]
    }

    fn sensors(&mut self) -> &mut CellChips {
        &mut self.chips
    }

    fn feed_watchdog(&mut self) {
        self.watchdog.feed();
    }

    fn restart(&mut self) -> ! {
        SCB::sys_reset()
    }

    fn sleep(&mut self) {
        if let Some(peak) = self.stack.grew(self.clock.now_us()) {
            defmt::info!("stack peak {} bytes of {} reserved", peak, stack::reserved_bytes());
        }
        for irq in [Interrupt::USART1, Interrupt::USART2, Interrupt::USART3, Interrupt::UART4] {
            NVIC::unpend(irq);
        }
        if !self.ports.iter().any(DmaPort::has_byte) {
            // A byte arriving after the check sets the event flag: WFE returns at once.
            cortex_m::asm::wfe();
        }
    }
}

/// What the bootloader takes of the MCU: the flash and the watchdog (the
/// board takes them with the rest).
pub fn boot_parts() -> Option<(CellFlash, Watchdog)> {
    let dp = pac::Peripherals::take()?;
    Some((CellFlash(LockedFlash::new(dp.FLASH)), Watchdog { iwdg: IndependentWatchdog::new(dp.IWDG), dbg: dp.DBGMCU }))
}

/// The independent watchdog (IWDG, on the LSI oscillator), as the
/// bootloader arms it; once started only a reset stops it.
pub struct Watchdog {
    iwdg: IndependentWatchdog,
    dbg: pac::DBGMCU,
}

impl Watchdog {
    /// Its period, nominal (LSI at 32 kHz). The main loop's longest pass
    /// is a 128 KiB sector erase at 8-bit parallelism, as the HAL erases:
    /// at most 4 s (datasheet, t_ERASE128KB); the LSI may run at up to
    /// 47 kHz, which makes 8 s nominal 5.4 s at the shortest.
    pub const PERIOD_MS: u32 = 8_000;

    /// Starts it, for the program about to be started (the bootloader's
    /// last act); stopped while a debugger halts the core.
    pub fn arm(self) {
        let mut iwdg = self.iwdg;
        iwdg.stop_on_debug(&self.dbg, true);
        iwdg.start(Self::PERIOD_MS.millis());
    }
}

/// The MCU's flash as the store's, the boot record's and the slots' NOR
/// flash, unlocked for each operation.
pub struct CellFlash(LockedFlash);

impl ErrorType for CellFlash {
    type Error = flash::Error;
}

impl ReadNorFlash for CellFlash {
    const READ_SIZE: usize = 1;

    fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), flash::Error> {
        ReadNorFlash::read(&mut self.0, offset, bytes)
    }

    fn capacity(&self) -> usize {
        ReadNorFlash::capacity(&self.0)
    }
}

impl NorFlash for CellFlash {
    const WRITE_SIZE: usize = 1;
    const ERASE_SIZE: usize = 128 * 1024;

    fn erase(&mut self, from: u32, to: u32) -> Result<(), flash::Error> {
        NorFlash::erase(&mut self.0.unlocked(), from, to)
    }

    fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), flash::Error> {
        NorFlash::write(&mut self.0.unlocked(), offset, bytes)
    }
}

defmt::timestamp!("{=u64:us}", Clock::log_time_us(SYSCLK_HZ, TICK_US));

#[exception]
unsafe fn HardFault(frame: &ExceptionFrame) -> ! {
    defmt::error!("hard fault at pc {=u32:#x}: resetting", frame.pc());
    SCB::sys_reset()
}

#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    defmt::error!("panic: {}: resetting", defmt::Display2Format(info));
    SCB::sys_reset()
}
