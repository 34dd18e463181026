//! Index arithmetic of the DMA rings behind a board's ports, apart from the
//! registers so that it is tested on the host.
//!
//! Receive ([`RxRing`]): a DMA stream in circular mode writes a buffer of
//! `N` bytes round and round; its half-transfer and transfer-complete
//! interrupts count the halves it has filled, and its count of remaining
//! transfers (NDTR) says where in the buffer it is. The reader follows
//! behind, and skips (and counts) what the DMA overwrote before it was read.
//!
//! Transmit ([`TxRing`]): frames are queued in a buffer of `N` bytes; a DMA
//! stream in normal mode sends the longest contiguous run of queued bytes,
//! and its transfer-complete interrupt starts the next run.
//!
//! Counts are totals since start in wrapping `u32`s; `N` is a power of two,
//! so a position in the buffer is the total modulo `N` across the wrap.

use core::ops::Range;

/// Total bytes a circular DMA has written into a ring of `n` bytes, from
/// the halves its interrupts counted (read first) and its count of
/// remaining transfers (NDTR, which counts down from `n` and reloads).
///
/// The position in the ring is the truth; the half count only says which
/// lap it is on, and may lag by one half whose interrupt has not run yet.
/// Interrupts that lag more (masked for over `n / 2` bytes' time) leave
/// the count short by whole laps, which the reader takes as an overrun.
pub fn rx_written(n: usize, halves: u32, remaining: u16) -> u32 {
    let n = n as u32;
    let at = n.wrapping_sub(u32::from(remaining)) % n;
    let counted = halves.wrapping_mul(n / 2);
    counted.wrapping_add(at.wrapping_sub(counted) % n)
}

/// The reading end of a circular receive buffer of `N` bytes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RxRing<const N: usize> {
    read: u32,
    lost: u32,
}

impl<const N: usize> RxRing<N> {
    /// Bytes next to the DMA's write position that are taken as lost: they
    /// are still there, but the DMA may overwrite them while they are
    /// copied out (it writes one byte every 2.5 us at 4 Mbit/s; a copy of
    /// [`RxRing::next`] bytes takes well under a microsecond).
    pub const GUARD: usize = 32;
    const VALID: () = assert!(N.is_power_of_two() && N > 2 * Self::GUARD);

    /// Nothing read yet.
    pub const fn new() -> Self {
        let () = Self::VALID;
        RxRing { read: 0, lost: 0 }
    }

    /// Where the next unread bytes are in the buffer, at most `max` of them
    /// and none past its end, given the DMA's total `written`. Bytes the DMA
    /// has overwritten, or is about to, are skipped and counted as lost.
    pub fn next(&mut self, written: u32, max: usize) -> Range<usize> {
        let keep = (N - Self::GUARD) as u32;
        let behind = written.wrapping_sub(self.read);
        if behind > keep {
            self.lost = self.lost.wrapping_add(behind - keep);
            self.read = written.wrapping_sub(keep);
        }
        let unread = written.wrapping_sub(self.read) as usize;
        let start = self.read as usize % N;
        start..start + unread.min(N - start).min(max)
    }

    /// Marks `n` bytes from [`RxRing::next`] read.
    pub fn consume(&mut self, n: usize) {
        self.read = self.read.wrapping_add(n as u32);
    }

    /// True when bytes wait, given the DMA's total `written`.
    pub fn pending(&self, written: u32) -> bool {
        written != self.read
    }

    /// Bytes overwritten before they could be read, since start.
    pub fn lost(&self) -> u32 {
        self.lost
    }
}

/// The queue of a transmit buffer of `N` bytes, emptied by a DMA stream.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct TxRing<const N: usize> {
    queued: u32,
    sent: u32,
    sending: u32,
}

impl<const N: usize> TxRing<N> {
    const VALID: () = assert!(N.is_power_of_two());

    /// Empty and idle.
    pub const fn new() -> Self {
        let () = Self::VALID;
        TxRing { queued: 0, sent: 0, sending: 0 }
    }

    /// Bytes that can be queued now.
    pub fn room(&self) -> usize {
        N - self.queued.wrapping_sub(self.sent) as usize
    }

    /// Queues `len` bytes: where to copy them in the buffer (the second
    /// range, maybe empty, after the wrap); `None` when there is no room.
    pub fn queue(&mut self, len: usize) -> Option<(Range<usize>, Range<usize>)> {
        if len > self.room() {
            return None;
        }
        let start = self.queued as usize % N;
        let first = len.min(N - start);
        self.queued = self.queued.wrapping_add(len as u32);
        Some((start..start + first, 0..len - first))
    }

    /// When the DMA is idle and bytes are queued, the longest contiguous run
    /// of them for it to send, which is then being sent.
    pub fn start(&mut self) -> Option<Range<usize>> {
        let waiting = self.queued.wrapping_sub(self.sent) as usize;
        if self.sending != 0 || waiting == 0 {
            return None;
        }
        let start = self.sent as usize % N;
        let len = waiting.min(N - start);
        self.sending = len as u32;
        Some(start..start + len)
    }

    /// The run being sent is out: its room is free again.
    pub fn finished(&mut self) {
        self.sent = self.sent.wrapping_add(self.sending);
        self.sending = 0;
    }

    /// True while the DMA sends a run.
    pub fn sending(&self) -> bool {
        self.sending != 0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    const N: usize = 128;

    /// A circular DMA writing a stream of numbered bytes, and the
    /// interrupts counting its halves.
    struct Dma {
        buf: [u8; N],
        written: u32,
        halves: u32,
    }

    impl Dma {
        fn new() -> Dma {
            Dma { buf: [0; N], written: 0, halves: 0 }
        }

        /// Writes `n` bytes; with `interrupts` off, a crossed half stays uncounted.
        fn write(&mut self, n: usize, interrupts: bool) {
            for _ in 0..n {
                self.buf[self.written as usize % N] = self.written as u8;
                self.written += 1;
            }
            if interrupts {
                self.halves = self.written / (N as u32 / 2);
            }
        }

        fn remaining(&self) -> u16 {
            (N - self.written as usize % N) as u16
        }
    }

    #[test]
    fn the_written_count_follows_the_dma_even_before_its_interrupt_runs() {
        let mut dma = Dma::new();
        assert_eq!(rx_written(N, dma.halves, dma.remaining()), 0);
        dma.write(N / 2 - 1, true);
        assert_eq!(rx_written(N, dma.halves, dma.remaining()), N as u32 / 2 - 1);
        // The stream crosses the half and the end; the interrupts lag one half behind.
        for _ in 0..4 {
            dma.write(1, false);
            assert_eq!(rx_written(N, dma.halves, dma.remaining()), dma.written);
            dma.write(N / 2 - 1, true);
        }
        // NDTR reads 0 for a moment at the end of the buffer, before it reloads.
        assert_eq!(rx_written(N, 1, 0), N as u32);
        assert_eq!(rx_written(N, 2, N as u16), N as u32);
    }

    #[test]
    fn the_counts_may_wrap() {
        let halves = u32::MAX;
        let written = rx_written(N, halves, (N / 2 - 3) as u16);
        assert_eq!(written, halves.wrapping_mul(N as u32 / 2).wrapping_add(3));
        let mut rx = RxRing::<N> { read: written.wrapping_sub(10), lost: 0 };
        assert_eq!(rx.next(written, N).len(), 10);
        rx.consume(10);
        assert!(!rx.pending(written));
    }

    proptest! {
        /// Whatever the DMA writes between reads, the reader gets the bytes in
        /// order, and exactly those it missed are counted lost.
        #[test]
        fn the_reader_gets_every_byte_it_keeps_up_with(bursts in proptest::collection::vec((0..3 * N, 1..N), 1..40)) {
            let mut dma = Dma::new();
            let mut rx = RxRing::<N>::new();
            let mut got: Vec<u8> = Vec::new();
            for (burst, max) in bursts {
                dma.write(burst, true);
                let written = rx_written(N, dma.halves, dma.remaining());
                prop_assert_eq!(written, dma.written);
                let mut this: Vec<u8> = Vec::new();
                loop {
                    let r = rx.next(written, max);
                    if r.is_empty() {
                        break;
                    }
                    prop_assert!(r.len() <= max && r.end <= N);
                    this.extend_from_slice(&dma.buf[r.clone()]);
                    rx.consume(r.len());
                }
                prop_assert!(!rx.pending(written));
                // What was read is the newest bytes, in order, never more than the buffer minus the guard.
                prop_assert!(this.len() <= N - RxRing::<N>::GUARD);
                let first = (dma.written as usize - this.len()) as u32;
                let expected: Vec<u8> = (first..dma.written).map(|b| b as u8).collect();
                prop_assert_eq!(&this, &expected);
                got.extend(this);
                prop_assert_eq!(got.len() + rx.lost() as usize, dma.written as usize);
            }
        }

        /// Frames queued in a transmit ring come out of the DMA runs whole and
        /// in order, and the ring never hands out room that is being sent.
        #[test]
        fn queued_bytes_are_sent_in_order(ops in proptest::collection::vec(0u8..3, 1..200)) {
            const FRAME: usize = 20;
            let mut tx = TxRing::<N>::new();
            let mut buf = [0u8; N];
            let mut next = 0u8;
            let (mut sent, mut expected) = (Vec::new(), Vec::new());
            let mut run: Option<Range<usize>> = None;
            for op in ops {
                match op {
                    0 => {
                        let frame: Vec<u8> = (0..FRAME).map(|_| { next = next.wrapping_add(1); next }).collect();
                        if let Some((a, b)) = tx.queue(FRAME) {
                            if let Some(r) = &run {
                                prop_assert!(a.end <= r.start || a.start >= r.end, "{a:?} overlaps the run {r:?}");
                                prop_assert!(b.end <= r.start || b.start >= r.end, "{b:?} overlaps the run {r:?}");
                            }
                            buf[a.clone()].copy_from_slice(&frame[..a.len()]);
                            buf[b.clone()].copy_from_slice(&frame[a.len()..]);
                            expected.extend(frame);
                        } else {
                            prop_assert!(tx.room() < FRAME);
                        }
                    }
                    1 => {
                        if run.is_none() {
                            run = tx.start();
                            prop_assert_eq!(run.is_some(), tx.sending());
                        } else {
                            prop_assert_eq!(tx.start(), None);
                        }
                    }
                    _ => {
                        if let Some(r) = run.take() {
                            sent.extend_from_slice(&buf[r]);
                            tx.finished();
                        }
                    }
                }
            }
            while let Some(r) = run.take().or_else(|| tx.start()) {
                sent.extend_from_slice(&buf[r]);
                tx.finished();
            }
            prop_assert_eq!(tx.room(), N);
            prop_assert_eq!(sent, expected);
        }
    }
}
