//! A signed firmware image, as the host builds it and a cell checks it.
//!
//! ```text
//! bytes  0..4    magic "SKFW"
//! byte   4       format (1)
//! byte   5       target board (see [`Board`])
//! bytes  6..8    zero
//! bytes  8..12   firmware version, little endian
//! bytes 12..16   body length in bytes, little endian
//! bytes 16..20   CRC-32/ISO-HDLC of the body, little endian
//! bytes 20..32   zero
//! bytes 32..96   ed25519 signature of bytes 0..32 followed by the body
//! bytes 96..     the body: the program a bootloader starts
//! ```
//!
//! The signature covers the header fields and the body, so neither the
//! version nor the board can be changed without the key. The CRC is not a
//! defence but a cheap first check: a transfer or slot error is found
//! without the signature's cost, and a bootloader can check a slot at every
//! boot in microseconds. The signature comes before the body so a cell can
//! start verifying ([`Verifier`]) as soon as it has the header, and hash the
//! body as it reads it back, chunk by chunk, never holding it in RAM.

use ed25519_compact::{PublicKey, Signature};

/// The first four bytes of every image.
pub const MAGIC: [u8; 4] = *b"SKFW";
/// The header format this crate reads and writes.
pub const FORMAT: u8 = 1;
/// Header bytes covered by the signature (with the body).
pub const SIGNED_LEN: usize = 32;
/// Length of an ed25519 signature.
pub const SIGNATURE_LEN: usize = 64;
/// Length of the whole header, signature included; the body follows.
pub const HEADER_LEN: usize = SIGNED_LEN + SIGNATURE_LEN;
/// Length of an ed25519 public key.
pub const PUBLIC_KEY_LEN: usize = 32;

static CRC32: crc::Crc<u32> = crc::Crc::<u32>::new(&crc::CRC_32_ISO_HDLC);

/// The board an image is built for; a cell refuses an image for another.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[repr(u8)]
pub enum Board {
    /// QEMU's mps2-an386 (Cortex-M4F), the simulated cell.
    Mps2An386 = 1,
    /// The real cell's STM32F405.
    Stm32f405 = 2,
}

impl Board {
    /// Every board, in wire order.
    pub const ALL: [Board; 2] = [Board::Mps2An386, Board::Stm32f405];

    /// The board's short name, as the host's `--board` flag spells it.
    pub fn name(self) -> &'static str {
        match self {
            Board::Mps2An386 => "mps2-an386",
            Board::Stm32f405 => "stm32f405",
        }
    }

    /// The board of a short name.
    pub fn from_name(name: &str) -> Option<Board> {
        Board::ALL.into_iter().find(|b| b.name() == name)
    }

    /// The board numbered `b` on the wire.
    pub fn from_u8(b: u8) -> Option<Board> {
        Board::ALL.into_iter().find(|k| *k as u8 == b)
    }
}

/// Why bytes are not an image a cell may boot.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum ImageError {
    /// Fewer bytes than a header.
    TooShort(usize),
    /// Does not start with [`MAGIC`].
    BadMagic,
    /// A header format this build does not read.
    UnknownFormat(u8),
    /// Byte 5 names no board.
    UnknownBoard(u8),
    /// A byte that must be zero is not.
    ReservedNotZero,
    /// Built for another board than this cell's.
    WrongBoard {
        /// The cell's board.
        expected: Board,
        /// The image's board.
        found: Board,
    },
    /// The body is longer than the slot it must fit in.
    TooLong {
        /// Body length in the header.
        len: u32,
        /// Room for a body.
        max: u32,
    },
    /// The body is not as long as the header says.
    LengthMismatch {
        /// Body length in the header.
        expected: u32,
        /// Bytes of body there are.
        found: u32,
    },
    /// The body's CRC-32 differs from the header's: corrupted or truncated.
    BadCrc,
    /// The signature does not match the header and body under the key:
    /// not signed by the holder of the key, or changed since.
    BadSignature,
    /// The public key is not a valid ed25519 point.
    BadKey,
}

impl core::fmt::Display for ImageError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            ImageError::TooShort(n) => write!(f, "{n} bytes is shorter than the {HEADER_LEN}-byte image header"),
            ImageError::BadMagic => f.write_str("not a skin firmware image (no SKFW magic)"),
            ImageError::UnknownFormat(v) => write!(f, "image format {v}, this build reads {FORMAT}"),
            ImageError::UnknownBoard(b) => write!(f, "image names unknown board {b}"),
            ImageError::ReservedNotZero => f.write_str("image header has non-zero reserved bytes"),
            ImageError::WrongBoard { expected, found } => {
                write!(f, "image is for board {}, this is {}", found.name(), expected.name())
            }
            ImageError::TooLong { len, max } => write!(f, "image body of {len} bytes exceeds the {max}-byte slot"),
            ImageError::LengthMismatch { expected, found } => {
                write!(f, "image body is {found} bytes, its header says {expected}")
            }
            ImageError::BadCrc => f.write_str("image body CRC mismatch (corrupted or truncated)"),
            ImageError::BadSignature => f.write_str("image signature does not verify under the update key"),
            ImageError::BadKey => f.write_str("update key is not a valid ed25519 public key"),
        }
    }
}

#[cfg(feature = "std")]
impl std::error::Error for ImageError {}

/// The checked header of an image.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ImageHeader {
    /// The board the body runs on.
    pub board: Board,
    /// The firmware version, chosen by whoever signs.
    pub version: u32,
    /// Length of the body in bytes.
    pub body_len: u32,
    /// CRC-32/ISO-HDLC of the body.
    pub body_crc: u32,
    /// ed25519 signature of the signed fields and the body.
    pub signature: [u8; SIGNATURE_LEN],
}

impl ImageHeader {
    /// A header for `body`, signature still zero (see [`ImageHeader::signed_fields`]).
    pub fn unsigned(board: Board, version: u32, body: &[u8]) -> Result<ImageHeader, ImageError> {
        let body_len = u32::try_from(body.len()).map_err(|_| ImageError::TooLong { len: u32::MAX, max: u32::MAX })?;
        Ok(ImageHeader { board, version, body_len, body_crc: CRC32.checksum(body), signature: [0; SIGNATURE_LEN] })
    }

    /// Checks the first [`HEADER_LEN`] bytes: magic, format, board, zeros.
    /// The signature is only checked with the body ([`Verifier`]).
    pub fn parse(bytes: &[u8]) -> Result<ImageHeader, ImageError> {
        let h: &[u8; HEADER_LEN] =
            bytes.get(..HEADER_LEN).and_then(|h| h.try_into().ok()).ok_or(ImageError::TooShort(bytes.len()))?;
        if h[..4] != MAGIC {
            return Err(ImageError::BadMagic);
        }
        if h[4] != FORMAT {
            return Err(ImageError::UnknownFormat(h[4]));
        }
        let board = Board::from_u8(h[5]).ok_or(ImageError::UnknownBoard(h[5]))?;
        if h[6..8].iter().chain(&h[20..SIGNED_LEN]).any(|b| *b != 0) {
            return Err(ImageError::ReservedNotZero);
        }
        let word = |at: usize| u32::from_le_bytes([h[at], h[at + 1], h[at + 2], h[at + 3]]);
        let mut signature = [0; SIGNATURE_LEN];
        signature.copy_from_slice(&h[SIGNED_LEN..]);
        Ok(ImageHeader { board, version: word(8), body_len: word(12), body_crc: word(16), signature })
    }

    /// The header bytes the signature covers, ahead of the body.
    pub fn signed_fields(&self) -> [u8; SIGNED_LEN] {
        let mut h = [0; SIGNED_LEN];
        h[..4].copy_from_slice(&MAGIC);
        h[4] = FORMAT;
        h[5] = self.board as u8;
        h[8..12].copy_from_slice(&self.version.to_le_bytes());
        h[12..16].copy_from_slice(&self.body_len.to_le_bytes());
        h[16..20].copy_from_slice(&self.body_crc.to_le_bytes());
        h
    }

    /// The header's bytes on the wire and in a slot.
    pub fn to_bytes(&self) -> [u8; HEADER_LEN] {
        let mut h = [0; HEADER_LEN];
        h[..SIGNED_LEN].copy_from_slice(&self.signed_fields());
        h[SIGNED_LEN..].copy_from_slice(&self.signature);
        h
    }

    /// Header and body together, in bytes.
    pub fn image_len(&self) -> u64 {
        HEADER_LEN as u64 + u64::from(self.body_len)
    }
}

/// Verifies an image's body as it is read, chunk by chunk: length, CRC,
/// and the signature under the update key, with one header in RAM.
pub struct Verifier {
    header: ImageHeader,
    crc: crc::Digest<'static, u32>,
    signature: ed25519_compact::VerifyingState,
    seen: u32,
}

impl core::fmt::Debug for Verifier {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("Verifier").field("header", &self.header).field("seen", &self.seen).finish()
    }
}

impl Verifier {
    /// Starts checking an image with this `header` for a cell of `board`
    /// whose slot holds bodies of up to `max_body` bytes, under `key`.
    pub fn new(
        header: &ImageHeader,
        board: Board,
        max_body: u32,
        key: &[u8; PUBLIC_KEY_LEN],
    ) -> Result<Verifier, ImageError> {
        if header.board != board {
            return Err(ImageError::WrongBoard { expected: board, found: header.board });
        }
        if header.body_len > max_body {
            return Err(ImageError::TooLong { len: header.body_len, max: max_body });
        }
        let key = PublicKey::new(*key);
        key.validate().map_err(|_| ImageError::BadKey)?;
        let mut signature =
            key.verify_incremental(&Signature::new(header.signature)).map_err(|_| ImageError::BadSignature)?;
        signature.absorb(header.signed_fields());
        Ok(Verifier { header: *header, crc: CRC32.digest(), signature, seen: 0 })
    }

    /// Takes the next bytes of the body.
    pub fn absorb(&mut self, chunk: &[u8]) -> Result<(), ImageError> {
        let seen = u32::try_from(chunk.len()).unwrap_or(u32::MAX).saturating_add(self.seen);
        if seen > self.header.body_len {
            return Err(ImageError::LengthMismatch { expected: self.header.body_len, found: seen });
        }
        self.seen = seen;
        self.crc.update(chunk);
        self.signature.absorb(chunk);
        Ok(())
    }

    /// Ends the check: the whole body seen, its CRC right, the signature valid.
    pub fn finish(self) -> Result<ImageHeader, ImageError> {
        if self.seen != self.header.body_len {
            return Err(ImageError::LengthMismatch { expected: self.header.body_len, found: self.seen });
        }
        if self.crc.finalize() != self.header.body_crc {
            return Err(ImageError::BadCrc);
        }
        self.signature.verify().map_err(|_| ImageError::BadSignature)?;
        Ok(self.header)
    }
}

/// Checks a whole image in memory (the host's and the tests' way; a cell
/// streams its slot through a [`Verifier`]).
pub fn verify(
    image: &[u8],
    board: Board,
    max_body: u32,
    key: &[u8; PUBLIC_KEY_LEN],
) -> Result<ImageHeader, ImageError> {
    let header = ImageHeader::parse(image)?;
    let body = &image[HEADER_LEN..];
    let found = u32::try_from(body.len()).unwrap_or(u32::MAX);
    if found != header.body_len {
        return Err(ImageError::LengthMismatch { expected: header.body_len, found });
    }
    let mut verifier = Verifier::new(&header, board, max_body, key)?;
    verifier.absorb(body)?;
    verifier.finish()
}

#[cfg(test)]
mod tests;
