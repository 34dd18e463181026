//! The physics of a link: how long a frame takes on a cell-2-cell UART and
//! on the interface's Ethernet, and bit errors on the wire.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use skin_protocol::frame::FRAME_LEN;
use skin_protocol::interface::HEADER_LEN;

/// Ethernet, IP and UDP bytes around a datagram's payload on the wire:
/// preamble 8, MAC header 14, IPv4 20, UDP 8, FCS 4, inter-frame gap 12.
pub const ETHERNET_OVERHEAD_BYTES: usize = 8 + 14 + 20 + 8 + 4 + 12;
/// Smallest Ethernet payload (IP packet); shorter ones are padded.
const ETHERNET_MIN_PAYLOAD: usize = 46;

/// Link timing.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LinkTiming {
    /// Cell-2-cell bit rate (Table 2: 4 Mbit/s).
    pub uart_bit_rate_bps: f64,
    /// Line bits per byte: start, 8 data, stop.
    pub uart_bits_per_byte: u32,
    /// From the last bit of a frame received to the frame being in a
    /// queue, ready to go out: interrupt, CRC check and routing decision on
    /// the cell's MCU. The paper does not give it; 25 us is about 1,800
    /// cycles of a 72 MHz Cortex-M4.
    pub processing_ns: u64,
    /// Interface-to-host bit rate (Table 2: 1 Gbit/s).
    pub ethernet_bit_rate_bps: f64,
}

impl Default for LinkTiming {
    fn default() -> Self {
        LinkTiming { uart_bit_rate_bps: 4e6, uart_bits_per_byte: 10, processing_ns: 25_000, ethernet_bit_rate_bps: 1e9 }
    }
}

impl LinkTiming {
    /// Time of one 20-byte frame on a cell-2-cell link (50 us at 4 Mbit/s).
    pub fn frame_ns(&self) -> u64 {
        (FRAME_LEN as f64 * f64::from(self.uart_bits_per_byte) / self.uart_bit_rate_bps * 1e9).round() as u64
    }

    /// Frames per second one cell-2-cell link carries.
    pub fn frames_per_s(&self) -> f64 {
        1e9 / self.frame_ns() as f64
    }

    /// Time of a datagram of `frames` frames on the interface's Ethernet.
    pub fn datagram_ns(&self, frames: usize) -> u64 {
        let payload = (HEADER_LEN + frames * FRAME_LEN + 28).max(ETHERNET_MIN_PAYLOAD);
        let bytes = payload - 28 + ETHERNET_OVERHEAD_BYTES;
        crate::round::round(bytes as f64 * 8.0 / self.ethernet_bit_rate_bps * 1e9) as u64
    }
}

/// Independent bit errors at a fixed rate on the data bits of every frame.
///
/// The gap to the next error is drawn from the geometric distribution, so
/// an error-free frame costs one comparison.
#[derive(Clone, Debug)]
pub struct BitErrors {
    rng: ChaCha8Rng,
    ber: f64,
    /// Data bits still to pass before the next flipped one.
    gap: u64,
}

impl BitErrors {
    /// Errors at bit-error rate `ber` (0 for none; at most 0.5).
    pub fn new(ber: f64, seed: u64) -> BitErrors {
        let mut e = BitErrors { rng: ChaCha8Rng::seed_from_u64(seed), ber, gap: 0 };
        e.gap = e.draw();
        e
    }

    fn draw(&mut self) -> u64 {
        if self.ber <= 0.0 {
            return u64::MAX;
        }
        let u: f64 = self.rng.random::<f64>();
        // P(gap >= k) = (1 - ber)^k.
        ((1.0 - u).ln() / (1.0 - self.ber).ln()).floor().min(u64::MAX as f64 / 2.0) as u64
    }

    /// Flips the bits of `bytes` that the wire corrupts; returns how many.
    pub fn corrupt(&mut self, bytes: &mut [u8]) -> u32 {
        let bits = bytes.len() as u64 * 8;
        let mut at = 0u64;
        let mut flipped = 0;
        while self.gap < bits - at {
            at += self.gap;
            bytes[(at / 8) as usize] ^= 1 << (at % 8);
            flipped += 1;
            at += 1;
            self.gap = self.draw();
        }
        self.gap -= bits - at;
        flipped
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn table_2_timings() {
        let t = LinkTiming::default();
        assert_eq!(t.frame_ns(), 50_000);
        assert_eq!(t.frames_per_s(), 20_000.0);
        // One frame per datagram: 36 payload bytes + 66 of headers and gaps.
        assert_eq!(t.datagram_ns(1), 816);
        assert_eq!(t.datagram_ns(72), (16 + 72 * 20 + 66) * 8);
    }

    #[test]
    fn bit_errors_come_at_their_rate() {
        let mut e = BitErrors::new(1e-3, 1);
        let mut flipped = 0u64;
        let frames = 20_000;
        for _ in 0..frames {
            let mut b = [0u8; 20];
            let n = e.corrupt(&mut b);
            assert_eq!(b.iter().map(|x| x.count_ones()).sum::<u32>(), n);
            flipped += u64::from(n);
        }
        let expected = frames as f64 * 160.0 * 1e-3;
        assert!((flipped as f64 - expected).abs() < 4.0 * expected.sqrt(), "{flipped} vs {expected}");
        let mut none = BitErrors::new(0.0, 1);
        assert_eq!(none.corrupt(&mut [0u8; 20]), 0);
    }
}
