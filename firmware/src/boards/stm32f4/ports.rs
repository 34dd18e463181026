//! The four cell ports of the STM32F405: U(S)ARTs at 4 Mbit/s whose bytes
//! move by DMA both ways. A byte comes every 2.5 us on a busy link (160
//! cycles at 64 MHz), less than one pass of the main loop, so the main loop
//! never touches a data register.
//!
//! Streams, from the DMA1 and DMA2 request mapping of RM0090 (Rev 18,
//! tables 42 and 43), all on channel 4, eight different streams:
//!
//! | port | UART   | receive (circular) | transmit (normal) |
//! |------|--------|--------------------|-------------------|
//! | 0    | USART1 | DMA2 stream 2      | DMA2 stream 7     |
//! | 1    | USART2 | DMA1 stream 5      | DMA1 stream 6     |
//! | 2    | USART3 | DMA1 stream 1      | DMA1 stream 3     |
//! | 3    | UART4  | DMA1 stream 2      | DMA1 stream 4     |
//!
//! (USART1_RX could also be DMA2 stream 5, USART3_TX DMA1 stream 4 channel
//! 7.) This choice leaves the streams of the sensor buses free should they
//! move to DMA: SPI1 on DMA2 streams 0 and 3 (channel 3), I2C1 on DMA1
//! streams 0 and 7 (channel 1). DMA2 serves only an APB2 peripheral
//! (USART1), which keeps clear of the STM32F405 erratum on DMA2 serving
//! AHB and APB2 peripherals at once (ES0182).
//!
//! Receive: a port's stream writes a ring of [`RX_LEN`] bytes round and
//! round; its half-transfer and transfer-complete interrupts count the
//! halves, and the main loop copies out what arrived ([`crate::ring`]). The
//! ring holds 2.6 ms of a saturated link: more than the longest pass of the
//! main loop, a sample with all three force pads at their 4095-poll limit
//! (estimated at under 2 ms, not measured). A sector erase of the store
//! stalls the core for about a second: the rings overrun then, and the
//! lost bytes are counted and logged.
//!
//! Transmit: frames are queued in a ring of [`TX_LEN`] bytes; the stream
//! sends the longest contiguous run of them, and its transfer-complete
//! interrupt starts the next, so a link stays busy between passes of the
//! main loop.
//!
//! Wake-up: the UARTs' receive interrupts are enabled in the peripheral
//! but not in the NVIC; with SEVONPEND the first byte of a burst makes one
//! pending and wakes WFE, while the DMA empties the data register.

use core::cell::{Cell, UnsafeCell};
use core::ops::Range;
use core::sync::atomic::{AtomicU32, Ordering};

use cortex_m::interrupt::{free, Mutex};
use skin_protocol::frame::FRAME_LEN;
use stm32f4xx_hal::pac::{self, dma2, interrupt, Interrupt};

use crate::board::SerialPort;
use crate::ring::{rx_written, RxRing, TxRing};

/// Bytes of a port's receive ring: 2.6 ms at 4 Mbit/s.
pub const RX_LEN: usize = 1024;
/// Bytes of a port's transmit ring: six frames and a bit.
pub const TX_LEN: usize = 128;

/// Memory a DMA stream reads or writes behind the compiler's back: the CPU
/// only touches it through raw pointers, and only where the DMA is not
/// working (behind a receive stream, outside a transmit run).
#[repr(align(4))]
struct DmaBuffer<const N: usize>(UnsafeCell<[u8; N]>);

// SAFETY: every access goes through raw pointers, in the parts of the
// buffer that [`RxRing`] and [`TxRing`] give the CPU.
unsafe impl<const N: usize> Sync for DmaBuffer<N> {}

impl<const N: usize> DmaBuffer<N> {
    const fn new() -> Self {
        DmaBuffer(UnsafeCell::new([0; N]))
    }

    fn addr(&self) -> u32 {
        self.0.get() as u32
    }

    /// # Safety
    /// No DMA writes `range` meanwhile.
    unsafe fn copy_out(&self, range: Range<usize>, out: &mut [u8]) {
        let from = (self.0.get() as *const u8).add(range.start);
        core::ptr::copy_nonoverlapping(from, out.as_mut_ptr(), range.len());
    }

    /// # Safety
    /// No DMA reads `range` meanwhile.
    unsafe fn copy_in(&self, range: Range<usize>, bytes: &[u8]) {
        let to = (self.0.get() as *mut u8).add(range.start);
        core::ptr::copy_nonoverlapping(bytes.as_ptr(), to, range.len());
    }
}

/// What a port shares with its DMA interrupts.
struct Shared {
    rx: DmaBuffer<RX_LEN>,
    /// Halves of `rx` filled, counted by the receive stream's interrupt.
    rx_halves: AtomicU32,
    tx: DmaBuffer<TX_LEN>,
    tx_ring: Mutex<Cell<TxRing<TX_LEN>>>,
}

impl Shared {
    const fn new() -> Shared {
        Shared {
            rx: DmaBuffer::new(),
            rx_halves: AtomicU32::new(0),
            tx: DmaBuffer::new(),
            tx_ring: Mutex::new(Cell::new(TxRing::new())),
        }
    }
}

static SHARED: [Shared; 4] = [const { Shared::new() }; 4];

#[derive(Clone, Copy)]
enum Controller {
    Dma1,
    Dma2,
}

/// One DMA stream, driven through its registers (RM0090 section 10.5).
#[derive(Clone, Copy)]
struct Stream {
    dma: Controller,
    n: usize,
}

/// A stream's flags in LISR/HISR and LIFCR/HIFCR (RM0090 10.5.1 to
/// 10.5.4): the low registers hold streams 0 to 3, the high ones 4 to 7,
/// each at its offset.
const FLAG_SHIFT: [u32; 4] = [0, 6, 16, 22];
const FEIF: u32 = 1 << 0;
const DMEIF: u32 = 1 << 2;
const TEIF: u32 = 1 << 3;
const HTIF: u32 = 1 << 4;
const TCIF: u32 = 1 << 5;
const ALL_FLAGS: u32 = FEIF | DMEIF | TEIF | HTIF | TCIF;
/// The request channel of every port stream (RM0090 tables 42 and 43).
const CHANNEL: u8 = 4;

impl Stream {
    fn regs(self) -> &'static dma2::RegisterBlock {
        // SAFETY: the controllers' register blocks. Each stream's registers
        // are only used through its own `Stream`; the shared flag registers
        // are read-only (LISR/HISR) or write-one-to-clear (LIFCR/HIFCR), so
        // one stream's access leaves the others' flags alone.
        unsafe {
            match self.dma {
                Controller::Dma1 => &*pac::DMA1::ptr(),
                Controller::Dma2 => &*pac::DMA2::ptr(),
            }
        }
    }

    fn st(self) -> &'static dma2::ST {
        self.regs().st(self.n)
    }

    fn flags(self) -> u32 {
        let r = self.regs();
        let bits = if self.n < 4 { r.lisr().read().bits() } else { r.hisr().read().bits() };
        (bits >> FLAG_SHIFT[self.n % 4]) & ALL_FLAGS
    }

    fn clear(self, flags: u32) {
        let r = self.regs();
        let bits = (flags & ALL_FLAGS) << FLAG_SHIFT[self.n % 4];
        // SAFETY: write-one-to-clear bits of this stream only.
        if self.n < 4 {
            r.lifcr().write(|w| unsafe { w.bits(bits) });
        } else {
            r.hifcr().write(|w| unsafe { w.bits(bits) });
        }
    }

    /// Transfers left: counts down from the length and, in circular mode, reloads.
    fn remaining(self) -> u16 {
        self.st().ndtr().read().ndt().bits()
    }

    /// Sets the stream up for byte transfers between `memory` and the UART
    /// data register at `dr`, disabled, in the order of RM0090's stream
    /// configuration procedure (section 10.3); a receive stream runs in
    /// circular mode.
    fn configure(self, receive: bool, dr: u32, memory: u32, len: usize) {
        let st = self.st();
        st.cr().modify(|_, w| w.en().disabled());
        while st.cr().read().en().is_enabled() {}
        // SAFETY: the data register of this port's UART and a static buffer
        // of `len` bytes, which is all the stream will touch.
        st.par().write(|w| unsafe { w.pa().bits(dr) });
        st.m0ar().write(|w| unsafe { w.m0a().bits(memory) });
        st.ndtr().write(|w| w.ndt().set(len as u16));
        // Direct mode: each request moves one byte at once, no FIFO.
        st.fcr().reset();
        self.clear(ALL_FLAGS);
        st.cr().write(|w| {
            w.chsel().set(CHANNEL);
            w.msize().bits8();
            w.psize().bits8();
            w.minc().incremented();
            w.pinc().fixed();
            w.teie().enabled();
            w.tcie().enabled();
            if receive {
                w.pl().very_high();
                w.dir().peripheral_to_memory();
                w.circ().enabled();
                w.htie().enabled()
            } else {
                w.pl().high();
                w.dir().memory_to_peripheral();
                w.circ().disabled();
                w.htie().disabled()
            }
        });
    }

    fn enable(self) {
        // The buffer writes before this are done before the DMA can see them.
        cortex_m::asm::dmb();
        self.st().cr().modify(|_, w| w.en().enabled());
    }
}

/// Which streams and interrupts serve a port.
struct Wiring {
    rx: Stream,
    tx: Stream,
    irqs: [Interrupt; 2],
}

const WIRING: [Wiring; 4] = [
    Wiring {
        rx: Stream { dma: Controller::Dma2, n: 2 },
        tx: Stream { dma: Controller::Dma2, n: 7 },
        irqs: [Interrupt::DMA2_STREAM2, Interrupt::DMA2_STREAM7],
    },
    Wiring {
        rx: Stream { dma: Controller::Dma1, n: 5 },
        tx: Stream { dma: Controller::Dma1, n: 6 },
        irqs: [Interrupt::DMA1_STREAM5, Interrupt::DMA1_STREAM6],
    },
    Wiring {
        rx: Stream { dma: Controller::Dma1, n: 1 },
        tx: Stream { dma: Controller::Dma1, n: 3 },
        irqs: [Interrupt::DMA1_STREAM1, Interrupt::DMA1_STREAM3],
    },
    Wiring {
        rx: Stream { dma: Controller::Dma1, n: 2 },
        tx: Stream { dma: Controller::Dma1, n: 4 },
        irqs: [Interrupt::DMA1_STREAM2, Interrupt::DMA1_STREAM4],
    },
];

/// One cell port: the reading end of its receive ring; the transmit ring
/// is shared with the interrupt that keeps the stream going.
#[derive(Debug)]
pub struct DmaPort {
    index: usize,
    rx: RxRing<RX_LEN>,
    lost_logged: u32,
}

impl DmaPort {
    /// Starts the DMA of port `index`, whose UART (data register at `dr`)
    /// is configured with its DMA requests on.
    ///
    /// # Safety
    /// Called once per port, with DMA1 and DMA2 clocked and their streams
    /// used by nothing else.
    pub unsafe fn start(index: usize, dr: u32) -> DmaPort {
        let wiring = &WIRING[index];
        let shared = &SHARED[index];
        wiring.rx.configure(true, dr, shared.rx.addr(), RX_LEN);
        wiring.tx.configure(false, dr, shared.tx.addr(), 0);
        for irq in wiring.irqs {
            cortex_m::peripheral::NVIC::unmask(irq);
        }
        wiring.rx.enable();
        DmaPort { index, rx: RxRing::new(), lost_logged: 0 }
    }

    /// Total bytes the receive stream has written: the half count first,
    /// then the position (see [`rx_written`]).
    fn written(&self) -> u32 {
        let halves = SHARED[self.index].rx_halves.load(Ordering::Acquire);
        rx_written(RX_LEN, halves, WIRING[self.index].rx.remaining())
    }

    /// True when received bytes wait.
    pub fn has_byte(&self) -> bool {
        self.rx.pending(self.written())
    }
}

impl SerialPort for DmaPort {
    fn read(&mut self, buf: &mut [u8]) -> usize {
        let range = self.rx.next(self.written(), buf.len());
        let n = range.len();
        // SAFETY: `RxRing::next` keeps the range a guard's length behind
        // the stream's write position.
        unsafe { SHARED[self.index].rx.copy_out(range, &mut buf[..n]) };
        self.rx.consume(n);
        if self.rx.lost() != self.lost_logged {
            defmt::warn!("port {}: {} received bytes overwritten before they were read", self.index, self.rx.lost());
            self.lost_logged = self.rx.lost();
        }
        n
    }

    fn can_send(&mut self) -> bool {
        free(|cs| SHARED[self.index].tx_ring.borrow(cs).get().room() >= FRAME_LEN)
    }

    fn send(&mut self, frame: &[u8; FRAME_LEN]) {
        let shared = &SHARED[self.index];
        free(|cs| {
            let cell = shared.tx_ring.borrow(cs);
            let mut ring = cell.get();
            if let Some((first, second)) = ring.queue(FRAME_LEN) {
                let split = first.len();
                // SAFETY: `TxRing::queue` gives room outside the run being sent.
                unsafe {
                    shared.tx.copy_in(first, &frame[..split]);
                    shared.tx.copy_in(second, &frame[split..]);
                }
                start_run(self.index, &mut ring);
            }
            cell.set(ring);
        });
    }
}

/// Starts the transmit stream of port `index` on the next run of its ring,
/// unless it is sending one.
fn start_run(index: usize, ring: &mut TxRing<TX_LEN>) {
    if let Some(run) = ring.start() {
        let stream = WIRING[index].tx;
        let st = stream.st();
        // The flags of the last run must be clear before the stream is
        // enabled again (RM0090 section 10.3, stream configuration procedure).
        stream.clear(ALL_FLAGS);
        // SAFETY: a run inside the port's static transmit buffer.
        st.m0ar().write(|w| unsafe { w.m0a().bits(SHARED[index].tx.addr() + run.start as u32) });
        st.ndtr().write(|w| w.ndt().set(run.len() as u16));
        stream.enable();
    }
}

/// A receive stream filled a half (HTIF) or the whole ring (TCIF): count it.
fn rx_interrupt(index: usize) {
    let stream = WIRING[index].rx;
    let flags = stream.flags();
    if flags & TEIF != 0 {
        // Only a bad address causes it, and the addresses are fixed.
        defmt::panic!("port {}: receive DMA transfer error", index);
    }
    let halves = u32::from(flags & HTIF != 0) + u32::from(flags & TCIF != 0);
    SHARED[index].rx_halves.fetch_add(halves, Ordering::Release);
    stream.clear(flags);
}

/// A transmit stream finished its run (in normal mode it is now disabled):
/// start the next one.
fn tx_interrupt(index: usize) {
    let stream = WIRING[index].tx;
    let flags = stream.flags();
    stream.clear(flags);
    if flags & TEIF != 0 {
        defmt::panic!("port {}: transmit DMA transfer error", index);
    }
    if flags & TCIF != 0 {
        free(|cs| {
            let cell = SHARED[index].tx_ring.borrow(cs);
            let mut ring = cell.get();
            ring.finished();
            start_run(index, &mut ring);
            cell.set(ring);
        });
    }
}

#[interrupt]
fn DMA2_STREAM2() {
    rx_interrupt(0);
}

#[interrupt]
fn DMA2_STREAM7() {
    tx_interrupt(0);
}

#[interrupt]
fn DMA1_STREAM5() {
    rx_interrupt(1);
}

#[interrupt]
fn DMA1_STREAM6() {
    tx_interrupt(1);
}

#[interrupt]
fn DMA1_STREAM1() {
    rx_interrupt(2);
}

#[interrupt]
fn DMA1_STREAM3() {
    tx_interrupt(2);
}

#[interrupt]
fn DMA1_STREAM2() {
    rx_interrupt(3);
}

#[interrupt]
fn DMA1_STREAM4() {
    tx_interrupt(3);
}
