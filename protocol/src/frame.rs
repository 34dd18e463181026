//! The 20-byte cell-2-cell frame.
//!
//! ```text
//! byte  0      kind
//! bytes 1..3   source address, little endian
//! bytes 3..5   destination address, little endian
//! bytes 5..18  postcard payload, zero padded
//! bytes 18..20 CRC-16/KERMIT over bytes 0..18, little endian
//! ```
//!
//! KERMIT is the reflected CCITT polynomial: on a UART, which sends each
//! byte least significant bit first, the frame with its little-endian CRC is
//! one codeword in transmission order, so every burst error of up to 16 bits
//! and every error of up to 3 bits is detected.

use crate::address::Address;
pub use crate::message::Kind;
use crate::message::{Message, MAX_PAYLOAD};

/// Length of every cell-2-cell frame in bytes (Table 2).
pub const FRAME_LEN: usize = 20;
/// Payload bytes in a frame.
pub const PAYLOAD_LEN: usize = 13;
const PAYLOAD: core::ops::Range<usize> = 5..18;
const CRC_AT: usize = 18;

// Compile-time proof that every payload, at its largest, fits.
const _: () = assert!(MAX_PAYLOAD <= PAYLOAD_LEN);
const _: () = assert!(PAYLOAD.end - PAYLOAD.start == PAYLOAD_LEN && PAYLOAD.end == CRC_AT);

const CRC: crc::Crc<u16> = crc::Crc::<u16>::new(&crc::CRC_16_KERMIT);

impl TryFrom<u8> for Kind {
    type Error = FrameError;
    fn try_from(b: u8) -> Result<Kind, FrameError> {
        Kind::ALL.into_iter().find(|k| *k as u8 == b).ok_or(FrameError::UnknownKind(b))
    }
}

/// Why bytes are not a frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum FrameError {
    /// The input is not exactly [`FRAME_LEN`] bytes long.
    WrongLength(usize),
    /// The CRC does not match: the frame was corrupted on the wire.
    BadCrc,
    /// Byte 0 names no message kind.
    UnknownKind(u8),
    /// The payload does not decode as its kind, or its padding is not zero.
    BadPayload,
}

impl core::fmt::Display for FrameError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            FrameError::WrongLength(n) => write!(f, "frame is {n} bytes, expected {FRAME_LEN}"),
            FrameError::BadCrc => f.write_str("frame CRC mismatch"),
            FrameError::UnknownKind(k) => write!(f, "unknown frame kind {k:#04x}"),
            FrameError::BadPayload => f.write_str("frame payload does not decode"),
        }
    }
}

#[cfg(feature = "std")]
impl std::error::Error for FrameError {}

/// Kind, source and destination of a frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Header {
    /// Message kind.
    pub kind: Kind,
    /// Sender address.
    pub src: Address,
    /// Receiver address.
    pub dst: Address,
}

/// The kind byte and the sender of a frame's bytes, read without any
/// check: for a reader that passes over most frames by who sent them and
/// what they are, and checks ([`Frame::parse`]) only those it keeps.
pub fn peek(bytes: &[u8; FRAME_LEN]) -> (u8, Address) {
    (bytes[0], Address(u16::from_le_bytes([bytes[1], bytes[2]])))
}

/// A frame whose length, CRC and kind have been checked; the payload is
/// decoded on demand with [`Frame::message`], so a cell that only forwards
/// never pays for it.
#[derive(Clone, Copy, PartialEq, Eq, Hash)]
pub struct Frame {
    kind: Kind,
    bytes: [u8; FRAME_LEN],
}

impl core::fmt::Debug for Frame {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("Frame").field("header", &self.header()).field("message", &self.message()).finish()
    }
}

#[cfg(feature = "defmt")]
impl defmt::Format for Frame {
    fn format(&self, f: defmt::Formatter) {
        defmt::write!(f, "Frame {{ {}, {} }}", self.header(), self.message())
    }
}

impl Frame {
    /// Encodes a message from `src` to `dst`.
    pub fn new(src: Address, dst: Address, message: &Message) -> Frame {
        let mut bytes = [0u8; FRAME_LEN];
        bytes[0] = message.kind() as u8;
        bytes[1..3].copy_from_slice(&src.0.to_le_bytes());
        bytes[3..5].copy_from_slice(&dst.0.to_le_bytes());
        // Cannot fail: MAX_PAYLOAD <= PAYLOAD_LEN is checked at compile time.
        let fits = message.encode_payload(&mut bytes[PAYLOAD]);
        debug_assert!(fits.is_ok());
        Frame::seal(message.kind(), bytes)
    }

    fn seal(kind: Kind, mut bytes: [u8; FRAME_LEN]) -> Frame {
        let crc = CRC.checksum(&bytes[..CRC_AT]);
        bytes[CRC_AT..].copy_from_slice(&crc.to_le_bytes());
        Frame { kind, bytes }
    }

    /// Checks length, CRC and kind. The payload is left for [`Frame::message`].
    pub fn parse(bytes: &[u8]) -> Result<Frame, FrameError> {
        let bytes: [u8; FRAME_LEN] = bytes.try_into().map_err(|_| FrameError::WrongLength(bytes.len()))?;
        let crc = u16::from_le_bytes([bytes[CRC_AT], bytes[CRC_AT + 1]]);
        if CRC.checksum(&bytes[..CRC_AT]) != crc {
            return Err(FrameError::BadCrc);
        }
        let kind = Kind::try_from(bytes[0])?;
        Ok(Frame { kind, bytes })
    }

    /// The frame's kind.
    pub fn kind(&self) -> Kind {
        self.kind
    }

    /// The sender.
    pub fn src(&self) -> Address {
        peek(&self.bytes).1
    }

    /// The receiver.
    pub fn dst(&self) -> Address {
        Address(u16::from_le_bytes([self.bytes[3], self.bytes[4]]))
    }

    /// Kind, source and destination.
    pub fn header(&self) -> Header {
        Header { kind: self.kind(), src: self.src(), dst: self.dst() }
    }

    /// Decodes the payload (only the one form its message encodes to).
    pub fn message(&self) -> Result<Message, FrameError> {
        Message::decode_payload(self.kind(), &self.bytes[PAYLOAD]).ok_or(FrameError::BadPayload)
    }

    /// The same frame sent to another destination (with a new CRC).
    pub fn readdressed(&self, dst: Address) -> Frame {
        let mut bytes = self.bytes;
        bytes[3..5].copy_from_slice(&dst.0.to_le_bytes());
        Frame::seal(self.kind, bytes)
    }

    /// The 20 bytes on the wire.
    pub fn as_bytes(&self) -> &[u8; FRAME_LEN] {
        &self.bytes
    }
}

/// Encodes a message from `src` to `dst` into its 20 wire bytes.
pub fn encode(src: Address, dst: Address, message: &Message) -> [u8; FRAME_LEN] {
    *Frame::new(src, dst, message).as_bytes()
}

/// Decodes 20 wire bytes completely: header and payload.
pub fn decode(bytes: &[u8]) -> Result<(Header, Message), FrameError> {
    let frame = Frame::parse(bytes)?;
    Ok((frame.header(), frame.message()?))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn crc_detects_every_burst_of_up_to_16_bits() {
        // The CRC is linear: a corrupted frame passes iff the error pattern
        // alone is a codeword of the zero-initialised CRC. So checking every
        // burst pattern once covers every frame. Bits are numbered in UART
        // order: byte by byte, least significant bit first.
        let zero = crc::Crc::<u16>::new(&crc::Algorithm { init: 0, xorout: 0, ..crc::CRC_16_KERMIT });
        let bits = FRAME_LEN * 8;
        let mut checked = 0u64;
        for len in 1..=16usize {
            let inner = if len <= 2 { 1 } else { 1u32 << (len - 2) };
            for start in 0..=bits - len {
                for pattern in 0..inner {
                    let mut e = [0u8; FRAME_LEN];
                    let mut flip = |bit: usize| e[bit / 8] ^= 1 << (bit % 8);
                    flip(start);
                    if len > 1 {
                        flip(start + len - 1);
                    }
                    for i in 0..len.saturating_sub(2) {
                        if pattern >> i & 1 == 1 {
                            flip(start + 1 + i);
                        }
                    }
                    let undetected = zero.checksum(&e[..CRC_AT]).to_le_bytes() == e[CRC_AT..];
                    assert!(!undetected, "burst of {len} bits at {start} ({pattern:#x}) undetected");
                    checked += 1;
                }
            }
        }
        assert!(checked > 4_000_000);
    }

    #[test]
    fn crc_is_linear_as_the_burst_test_assumes() {
        let zero = crc::Crc::<u16>::new(&crc::Algorithm { init: 0, xorout: 0, ..crc::CRC_16_KERMIT });
        let a = [0x5Au8; CRC_AT];
        let mut e = [0u8; CRC_AT];
        e[7] = 0x81;
        let b: [u8; CRC_AT] = core::array::from_fn(|i| a[i] ^ e[i]);
        assert_eq!(CRC.checksum(&a) ^ CRC.checksum(&b), zero.checksum(&e));
    }

    #[test]
    fn readdressing_keeps_the_frame_valid() {
        let f = Frame::new(
            Address(5),
            Address::HOST,
            &Message::ConfigAck(crate::message::ConfigAck { tag: 1, accepted: true }),
        );
        let g = f.readdressed(Address(9));
        assert_eq!(Frame::parse(g.as_bytes()), Ok(g));
        assert_eq!(g.dst(), Address(9));
        assert_eq!(g.message(), f.message());
    }

    #[test]
    fn an_over_long_varint_is_refused() {
        // Chunk index 0 is `00`; postcard also reads `80 80 00` as 0, with
        // the same (zero) data after it, but that is not the frame of it.
        use crate::message::{ImageChunk, CHUNK_LEN};
        let chunk = Message::ImageChunk(ImageChunk { index: 0, data: [0; CHUNK_LEN] });
        let good = Frame::new(Address(1), Address(2), &chunk);
        let mut bytes = good.bytes;
        bytes[PAYLOAD.start..PAYLOAD.start + 2].copy_from_slice(&[0x80, 0x80]);
        let bad = Frame::parse(Frame::seal(Kind::ImageChunk, bytes).as_bytes()).unwrap();
        assert_eq!(good.message(), Ok(chunk));
        assert_eq!(bad.message(), Err(FrameError::BadPayload));
    }
}
