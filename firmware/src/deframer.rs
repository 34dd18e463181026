//! Frames out of a UART byte stream.
//!
//! Cell-2-cell links carry bare 20-byte frames, back to back. A receiver
//! that starts mid-frame (a neighbour booting, a link plugged in, a lost
//! byte) slides one byte at a time until a CRC-valid frame lines up, and
//! from then on takes whole frames. A false lock needs the 16-bit CRC and
//! the kind byte to match by chance, and is lost again at the next frame.

use skin_protocol::frame::{Frame, FRAME_LEN};

/// Reassembles frames from received bytes.
#[derive(Clone, Debug, Default)]
pub struct Deframer {
    buf: [u8; FRAME_LEN],
    len: usize,
    slipped: u32,
}

impl Deframer {
    /// An empty receiver.
    pub const fn new() -> Deframer {
        Deframer { buf: [0; FRAME_LEN], len: 0, slipped: 0 }
    }

    /// Takes one received byte; returns a frame when one is complete.
    pub fn push(&mut self, byte: u8) -> Option<Frame> {
        self.buf[self.len] = byte;
        self.len += 1;
        if self.len < FRAME_LEN {
            return None;
        }
        match Frame::parse(&self.buf) {
            Ok(frame) => {
                self.len = 0;
                Some(frame)
            }
            Err(_) => {
                self.buf.copy_within(1.., 0);
                self.len = FRAME_LEN - 1;
                self.slipped += 1;
                None
            }
        }
    }

    /// Bytes skipped to find frame boundaries since start.
    pub fn slipped(&self) -> u32 {
        self.slipped
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;
    use skin_protocol::message::{ConfigAck, Message};
    use skin_protocol::Address;

    fn frame(tag: u8) -> Frame {
        Frame::new(Address(tag.into()), Address::HOST, &Message::ConfigAck(ConfigAck { tag, accepted: true }))
    }

    fn feed(d: &mut Deframer, bytes: &[u8]) -> Vec<Frame> {
        bytes.iter().filter_map(|b| d.push(*b)).collect()
    }

    #[test]
    fn frames_back_to_back_come_out_whole() {
        let mut d = Deframer::new();
        let bytes: Vec<u8> = (1..=5).flat_map(|t| *frame(t).as_bytes()).collect();
        assert_eq!(feed(&mut d, &bytes), (1..=5).map(frame).collect::<Vec<_>>());
        assert_eq!(d.slipped(), 0);
    }

    proptest! {
        /// Any garbage before a stream of frames costs at most the frame it
        /// overlaps: every later frame is found, and nothing panics.
        #[test]
        fn resynchronizes_after_any_garbage(garbage in proptest::collection::vec(any::<u8>(), 0..64)) {
            let mut d = Deframer::new();
            let early = feed(&mut d, &garbage);
            let frames: Vec<Frame> = (10..14).map(frame).collect();
            let bytes: Vec<u8> = frames.iter().flat_map(|f| *f.as_bytes()).collect();
            let got = feed(&mut d, &bytes);
            prop_assert!(early.len() <= garbage.len() / FRAME_LEN);
            prop_assert!(got.ends_with(&frames[1..]), "{:?}", got);
        }
    }
}
