//! QEMU's `mps2-an386` (Cortex-M4F, 25 MHz): a cell without sensors.
//!
//! - CMSDK APB UART1..UART4 are ports 0..3; UART0 carries the stimulus
//!   frames of the test harness ([`crate::stimulus`]).
//! - [`crate::board::QEMU_CONFIG`] are its self-organization timings.
//! - SysTick every 4 ms ([`TICK_US`]) is the clock; with the UART receive
//!   interrupts it wakes the core from WFI. Each wake costs the host
//!   QEMU's time, so an idle cell is not free: an idle cell of a 12-cell
//!   patch (its links kept alive) took 7.3% of a host core at a 1 ms tick,
//!   4.6% at 4 ms.
//! - Logs go out with defmt over semihosting (QEMU's stdout). The stack's
//!   peak use, whenever it grows, goes out as a text line on semihosting's
//!   stderr (QEMU's stderr): `stack peak N bytes of R reserved`.
//! - Flash is a file on the host named by `flash=PATH` in QEMU's
//!   `-append`, accessed through semihosting ([`FlashFile`]): the store,
//!   the boot record and the image slots ([`crate::flash_map::QEMU`])
//!   survive the QEMU process as real flash survives a power cycle, and a
//!   killed QEMU is a power cut. The bootloader (`boot-qemu`, at 0x0)
//!   copies the chosen image's body into code SRAM ([`CodeSram`]), which
//!   QEMU does not keep.
//! - The CMSDK APB watchdog (QEMU maps it at 0x4000_8000 on the AN386,
//!   clocked at 25 MHz; [`Watchdog`]): `boot-qemu` arms it just before it
//!   starts a program, the cell's main loop feeds it. Its first expiry is
//!   the NMI, its second resets the machine (QEMU's `-watchdog-action`,
//!   `reset` by default), as `SCB::sys_reset` does: the flash file stays.
//! - A panic, a hard fault or any unexpected exception ends QEMU with a
//!   failure exit code.

use core::ffi::CStr;
use core::sync::atomic::{AtomicBool, Ordering};

use cortex_m::interrupt::InterruptNumber;
use cortex_m::peripheral::{NVIC, SCB};
use cortex_m_rt::{exception, ExceptionFrame};
use embedded_storage::nor_flash::{ErrorType, NorFlash, NorFlashErrorKind, ReadNorFlash};
use semihosting::fs::File;
use semihosting::io::{Read, Seek, SeekFrom, Write};
use skin_protocol::frame::FRAME_LEN;
use skin_protocol::message::Port;

use super::stack::{self, PeakWatch};
use super::systick::Clock;
use crate::board::{Board, SerialPort};
use crate::flash_map::{QEMU as MAP, QEMU_FILE_LEN, QEMU_SECTOR};
use crate::sensors::{SensorError, Sensors};
use crate::stimulus::Stimulated;

use defmt_semihosting as _;

/// Core and peripheral clock of the board.
const SYSCLK_HZ: u32 = 25_000_000;
/// The clock's tick, one sampling period: the main loop has nothing to do
/// more often unless a byte arrives, which wakes it anyway.
const TICK_US: u32 = 4_000;
/// Bytes of an erase sector of the flash file (four store records).
const SECTOR: usize = QEMU_SECTOR as usize;
/// Bytes of the flash file.
const FILE_LEN: usize = QEMU_FILE_LEN as usize;

/// A CMSDK APB UART, with the frame it is sending: it takes one byte at a
/// time (QEMU passes each on to its chardev at once).
#[derive(Debug)]
pub struct Uart {
    base: usize,
    tx: [u8; FRAME_LEN],
    tx_at: usize,
}

impl Uart {
    const DATA: usize = 0x00;
    const STATE: usize = 0x04;
    const CTRL: usize = 0x08;
    const INTCLEAR: usize = 0x0C;
    const BAUDDIV: usize = 0x10;
    const TX_FULL: u32 = 1 << 0;
    const RX_FULL: u32 = 1 << 1;
    const TX_EN: u32 = 1 << 0;
    const RX_EN: u32 = 1 << 1;
    const RX_INT_EN: u32 = 1 << 3;

    /// # Safety
    /// `base` is a CMSDK UART that nothing else uses.
    unsafe fn new(base: usize) -> Uart {
        let uart = Uart { base, tx: [0; FRAME_LEN], tx_at: FRAME_LEN };
        // The smallest divider the CMSDK UART accepts; QEMU ignores the rate.
        uart.set(Self::BAUDDIV, 16);
        uart.set(Self::CTRL, Self::TX_EN | Self::RX_EN | Self::RX_INT_EN);
        uart
    }

    fn get(&self, reg: usize) -> u32 {
        // SAFETY: a register of the UART this value owns.
        unsafe { core::ptr::read_volatile((self.base + reg) as *const u32) }
    }

    fn set(&self, reg: usize, value: u32) {
        // SAFETY: a register of the UART this value owns.
        unsafe { core::ptr::write_volatile((self.base + reg) as *mut u32, value) }
    }

    fn rx_ready(&self) -> bool {
        self.get(Self::STATE) & Self::RX_FULL != 0
    }

    fn read_byte(&mut self) -> Option<u8> {
        self.rx_ready().then(|| self.get(Self::DATA) as u8)
    }
}

impl SerialPort for Uart {
    fn read(&mut self, buf: &mut [u8]) -> usize {
        let mut n = 0;
        while n < buf.len() {
            match self.read_byte() {
                Some(byte) => buf[n] = byte,
                None => break,
            }
            n += 1;
        }
        n
    }

    fn can_send(&mut self) -> bool {
        while self.tx_at < FRAME_LEN && self.get(Self::STATE) & Self::TX_FULL == 0 {
            self.set(Self::DATA, u32::from(self.tx[self.tx_at]));
            self.tx_at += 1;
        }
        self.tx_at == FRAME_LEN
    }

    fn send(&mut self, frame: &[u8; FRAME_LEN]) {
        self.tx = *frame;
        self.tx_at = 0;
        self.can_send();
    }
}

/// Base addresses of UART0..UART4.
const UART_BASE: [usize; 5] = [0x4000_4000, 0x4000_5000, 0x4000_6000, 0x4000_7000, 0x4000_9000];

/// Receive interrupt of a port's UART (UART1..UART4).
#[derive(Clone, Copy, Debug)]
struct RxInterrupt(u16);

// SAFETY: the numbers are the board's UART1..UART4 receive interrupts.
unsafe impl InterruptNumber for RxInterrupt {
    fn number(self) -> u16 {
        self.0
    }
}

/// Receive interrupts of UART0..UART4.
const RX_IRQ: [u16; 5] = [0, 2, 4, 18, 20];

/// The sensors of a QEMU cell: the latest stimulus from UART0.
#[derive(Debug)]
pub struct QemuSensors {
    uart: Uart,
    stimulus: Stimulated,
}

impl QemuSensors {
    fn drain(&mut self) {
        while let Some(byte) = self.uart.read_byte() {
            self.stimulus.feed(byte);
        }
    }
}

impl Sensors for QemuSensors {
    fn read(&mut self, now_us: u64) -> Result<skin_protocol::Sample, SensorError> {
        self.drain();
        self.stimulus.read(now_us)
    }

    fn set_accel_range(&mut self, range: skin_protocol::message::AccelRange) -> Result<(), SensorError> {
        self.stimulus.set_accel_range(range)
    }
}

/// The mps2-an386 board.
#[derive(Debug)]
pub struct Qemu {
    ports: [Uart; 4],
    sensors: QemuSensors,
    clock: Clock,
    stack: PeakWatch,
}

impl Qemu {
    /// The board and its flash file ([`Qemu::start`], [`FlashFile::open`]).
    pub fn take() -> (Qemu, FlashFile) {
        (Qemu::start(), FlashFile::open())
    }

    /// Takes the core peripherals and sets up the UARTs, the tick and the
    /// interrupts: the board alone, for programs that keep nothing.
    pub fn start() -> Qemu {
        let Some(mut core) = cortex_m::Peripherals::take() else {
            defmt::panic!("board taken twice");
        };
        // SAFETY: the UARTs of the board, each owned by one value from here on.
        let [stimulus_uart, ports @ ..] = UART_BASE.map(|base| unsafe { Uart::new(base) });
        let clock = Clock::start(&mut core.SYST, SYSCLK_HZ, TICK_US);
        for irq in RX_IRQ {
            // SAFETY: the handler (DefaultHandler) clears these interrupts.
            unsafe { NVIC::unmask(RxInterrupt(irq)) };
        }
        let sensors = QemuSensors { uart: stimulus_uart, stimulus: Stimulated::new() };
        Qemu { ports, sensors, clock, stack: PeakWatch::new() }
    }
}

impl Board for Qemu {
    type Port = Uart;
    type Sensors = QemuSensors;

    fn now_us(&mut self) -> u64 {
        self.clock.now_us()
    }

    fn port(&mut self, port: Port) -> &mut Uart {
        &mut self.ports[port.index()]
    }

    fn sensors(&mut self) -> &mut QemuSensors {
        &mut self.sensors
    }

    fn sleep(&mut self) {
        if let Some(peak) = self.stack.grew(self.clock.now_us()) {
            semihosting::eprintln!("stack peak {} bytes of {} reserved", peak, stack::reserved_bytes());
        }
        if WATCHDOG_WARNED.swap(false, Ordering::Relaxed) {
            defmt::warn!("watchdog: the main loop missed a period (NMI); fed again in time");
        }
        // With interrupts masked, a byte arriving after the check still
        // wakes the WFI (it is pending), so none waits for the next tick.
        cortex_m::interrupt::free(|_| {
            self.sensors.drain();
            if !self.ports.iter().any(Uart::rx_ready) {
                cortex_m::asm::wfi();
            }
        });
    }

    fn feed_watchdog(&mut self) {
        Watchdog::feed();
    }

    fn restart(&mut self) -> ! {
        // QEMU resets the core and loads the bootloader's image again; the
        // flash file and the UARTs' sockets stay.
        SCB::sys_reset()
    }
}

defmt::timestamp!("{=u64:us}", Clock::log_time_us(SYSCLK_HZ, TICK_US));

/// The board's CMSDK APB watchdog. It counts down from its load value at
/// 25 MHz; the first time it reaches zero it raises its interrupt (the
/// NMI) and starts again, the second time it resets the machine; a feed
/// (a write to its interrupt clear register) starts the count again.
#[derive(Debug)]
pub struct Watchdog;

impl Watchdog {
    const BASE: usize = 0x4000_8000;
    const LOAD: usize = 0x00;
    const CONTROL: usize = 0x08;
    const INTCLR: usize = 0x0C;
    const INTEN: u32 = 1 << 0;
    const RESEN: u32 = 1 << 1;
    /// Ticks to the first expiry, 2 s: the reset comes 4 s after the last
    /// feed. A QEMU cell's longest pass of its main loop (a slot erase or
    /// an image read back through semihosting) is far shorter, but its
    /// process may wait for a core on a loaded machine while the clock runs.
    const PERIOD_TICKS: u32 = 2 * SYSCLK_HZ;

    fn set(reg: usize, value: u32) {
        // SAFETY: a register of the watchdog, which only this type touches.
        unsafe { core::ptr::write_volatile((Self::BASE + reg) as *mut u32, value) }
    }

    /// Starts it, for the program about to be started (the bootloader's
    /// last act); the program must feed it from then on.
    pub fn arm(self) {
        Self::set(Self::LOAD, Self::PERIOD_TICKS);
        Self::set(Self::CONTROL, Self::INTEN | Self::RESEN);
    }

    /// Starts the count again (harmless when it was never armed: a cell
    /// program started without the bootloader).
    fn feed() {
        Self::set(Self::INTCLR, 1);
    }
}

/// Set by the watchdog's first expiry, reported by the main loop if it
/// ever runs again.
static WATCHDOG_WARNED: AtomicBool = AtomicBool::new(false);

/// The watchdog's first expiry: the main loop has not fed it for a
/// period. Nothing is logged here (an NMI may interrupt a log line); if
/// the loop does not feed it within another period, the machine resets.
///
/// # Safety
/// cortex-m-rt's rule for NMI handlers: it touches only an atomic.
#[exception]
unsafe fn NonMaskableInt() {
    WATCHDOG_WARNED.store(true, Ordering::Relaxed);
}

/// The cell's flash: the semihosting file named by `flash=PATH`.
#[derive(Debug)]
pub struct FlashFile(File);

impl FlashFile {
    /// Opens the file, or creates it erased; without one the cell cannot
    /// run (it keeps its images there) and QEMU exits with code 5.
    pub fn open() -> FlashFile {
        let mut path = [0u8; 192];
        match flash_path(&mut path).and_then(open_file) {
            Some(file) => FlashFile(file),
            None => {
                defmt::error!("no flash=PATH in QEMU's -append, or the file cannot be opened");
                exit(5)
            }
        }
    }
}

/// The NUL-terminated path of `flash=PATH` among the semihosting arguments.
fn flash_path(buf: &mut [u8; 192]) -> Option<&CStr> {
    let args = semihosting::experimental::env::args::<256>().ok()?;
    let path = (&args).flatten().find_map(|a| a.strip_prefix("flash="))?;
    let bytes = path.as_bytes();
    if bytes.len() >= buf.len() {
        defmt::error!("flash path longer than {} bytes", buf.len() - 1);
        return None;
    }
    buf[..bytes.len()].copy_from_slice(bytes);
    buf[bytes.len()] = 0;
    CStr::from_bytes_until_nul(buf).ok()
}

/// Opens the flash file, or creates it erased.
fn open_file(path: &CStr) -> Option<File> {
    if let Ok(file) = File::options().read(true).write(true).open(path) {
        return Some(file);
    }
    let mut file = File::options().read(true).write(true).create(true).truncate(true).open(path).ok()?;
    let erased = [0xFF; 256];
    for _ in 0..FILE_LEN / erased.len() {
        file.write_all(&erased).ok()?;
    }
    Some(file)
}

impl ErrorType for FlashFile {
    type Error = NorFlashErrorKind;
}

fn check(offset: u32, len: usize, capacity: usize) -> Result<(), NorFlashErrorKind> {
    match (offset as usize).checked_add(len) {
        Some(end) if end <= capacity => Ok(()),
        _ => Err(NorFlashErrorKind::OutOfBounds),
    }
}

impl ReadNorFlash for FlashFile {
    const READ_SIZE: usize = 1;

    fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), Self::Error> {
        check(offset, bytes.len(), FILE_LEN)?;
        bytes.fill(0xFF);
        self.0.seek(SeekFrom::Start(offset.into())).map_err(|_| NorFlashErrorKind::Other)?;
        // A short file reads as erased past its end.
        let mut got = 0;
        while got < bytes.len() {
            match self.0.read(&mut bytes[got..]) {
                Ok(0) => break,
                Ok(n) => got += n,
                Err(_) => return Err(NorFlashErrorKind::Other),
            }
        }
        Ok(())
    }

    fn capacity(&self) -> usize {
        FILE_LEN
    }
}

impl NorFlash for FlashFile {
    const WRITE_SIZE: usize = 1;
    const ERASE_SIZE: usize = SECTOR;

    fn erase(&mut self, from: u32, to: u32) -> Result<(), Self::Error> {
        if !(from as usize).is_multiple_of(SECTOR) || !(to as usize).is_multiple_of(SECTOR) || from > to {
            return Err(NorFlashErrorKind::NotAligned);
        }
        check(from, (to - from) as usize, FILE_LEN)?;
        self.0.seek(SeekFrom::Start(from.into())).map_err(|_| NorFlashErrorKind::Other)?;
        let erased = [0xFF; 256];
        let mut left = (to - from) as usize;
        while left > 0 {
            let n = left.min(erased.len());
            self.0.write_all(&erased[..n]).map_err(|_| NorFlashErrorKind::Other)?;
            left -= n;
        }
        Ok(())
    }

    /// Writes as NOR flash does: bits can only be cleared.
    fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), Self::Error> {
        check(offset, bytes.len(), FILE_LEN)?;
        let mut at = offset;
        for chunk in bytes.chunks(64) {
            let mut merged = [0u8; 64];
            let merged = &mut merged[..chunk.len()];
            self.read(at, merged)?;
            for (m, b) in merged.iter_mut().zip(chunk) {
                *m &= *b;
            }
            self.0.seek(SeekFrom::Start(at.into())).map_err(|_| NorFlashErrorKind::Other)?;
            self.0.write_all(merged).map_err(|_| NorFlashErrorKind::Other)?;
            at += chunk.len() as u32;
        }
        Ok(())
    }
}

/// The execution region in code SRAM ([`crate::flash_map::QEMU`]`.exec`),
/// as the bootloader fills it: RAM that reads, erases and writes like flash.
#[derive(Debug)]
pub struct CodeSram(());

impl CodeSram {
    /// The region; only the bootloader writes it, before it starts the program.
    ///
    /// # Safety
    /// Nothing runs from the region, and no other value refers to it.
    pub unsafe fn take() -> CodeSram {
        CodeSram(())
    }

    fn at(offset: u32, len: usize) -> Result<*mut u8, NorFlashErrorKind> {
        let end = MAP.exec.end() as usize;
        match (offset as usize).checked_add(len) {
            Some(e) if offset >= MAP.exec.base && e <= end => Ok(offset as usize as *mut u8),
            _ => Err(NorFlashErrorKind::OutOfBounds),
        }
    }
}

impl ErrorType for CodeSram {
    type Error = NorFlashErrorKind;
}

impl ReadNorFlash for CodeSram {
    const READ_SIZE: usize = 1;

    fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), Self::Error> {
        let at = Self::at(offset, bytes.len())?;
        // SAFETY: inside the execution region, which this value owns.
        unsafe { core::ptr::copy_nonoverlapping(at, bytes.as_mut_ptr(), bytes.len()) };
        Ok(())
    }

    fn capacity(&self) -> usize {
        MAP.exec.end() as usize
    }
}

impl NorFlash for CodeSram {
    const WRITE_SIZE: usize = 1;
    const ERASE_SIZE: usize = 1;

    fn erase(&mut self, from: u32, to: u32) -> Result<(), Self::Error> {
        let at = Self::at(from, to.saturating_sub(from) as usize)?;
        // SAFETY: as in `read`.
        unsafe { core::ptr::write_bytes(at, 0xFF, to.saturating_sub(from) as usize) };
        Ok(())
    }

    fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), Self::Error> {
        let at = Self::at(offset, bytes.len())?;
        // SAFETY: as in `read`.
        unsafe { core::ptr::copy_nonoverlapping(bytes.as_ptr(), at, bytes.len()) };
        Ok(())
    }
}

/// Ends QEMU with `code` (0 is success).
pub fn exit(code: i32) -> ! {
    semihosting::process::exit(code)
}

/// Instructions per SysTick tick under QEMU's `-icount shift=0` (one
/// instruction per ns) with SysTick on the 25 MHz core clock.
pub const INSTRUCTIONS_PER_TICK: u64 = 40;

/// Instruction counts for the measuring examples: SysTick counting down
/// freely over its 24 bits, read before and after.
#[derive(Debug)]
pub struct Ticks;

impl Ticks {
    /// Starts SysTick free-running on the core clock.
    pub fn start(syst: &mut cortex_m::peripheral::SYST) -> Ticks {
        syst.set_clock_source(cortex_m::peripheral::syst::SystClkSource::Core);
        syst.set_reload(0x00FF_FFFF);
        syst.clear_current();
        syst.enable_counter();
        Ticks
    }

    /// Runs `f` and returns its result and the SysTick ticks it took.
    pub fn count<R>(&self, f: impl FnOnce() -> R) -> (R, u64) {
        // SAFETY: read-only access to the SysTick counter.
        let start = unsafe { (*cortex_m::peripheral::SYST::PTR).cvr.read() };
        let result = f();
        // SAFETY: as above.
        let end = unsafe { (*cortex_m::peripheral::SYST::PTR).cvr.read() };
        (result, u64::from(start.wrapping_sub(end) & 0x00FF_FFFF))
    }
}

#[exception]
unsafe fn HardFault(frame: &ExceptionFrame) -> ! {
    defmt::error!("hard fault at pc {=u32:#x}, cfsr {=u32:#x}", frame.pc(), (*SCB::PTR).cfsr.read());
    exit(3)
}

/// Interrupts: the UARTs' receive interrupts, only there to wake the main
/// loop; anything else is a fault.
#[exception]
unsafe fn DefaultHandler(irqn: i16) {
    match RX_IRQ.iter().position(|i| *i as i16 == irqn) {
        Some(i) => core::ptr::write_volatile((UART_BASE[i] + Uart::INTCLEAR) as *mut u32, 0xF),
        None => {
            defmt::error!("unexpected exception or interrupt {}", irqn);
            exit(4)
        }
    }
}

#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    defmt::error!("panic: {}", defmt::Display2Format(info));
    exit(101)
}
