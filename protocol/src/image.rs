//! A signed firmware image, as the host builds it and a cell checks it.
//!
//! ```text
//! bytes   0..4    magic "SKFW"
//! byte    4       format (1)
//! byte    5       target board (see [`Board`])
//! bytes   6..8    zero
//! bytes   8..12   firmware version, little endian
//! bytes  12..16   body length in bytes, little endian
//! bytes  16..48   SHA-256 of the body
//! bytes  48..64   zero
//! bytes  64..128  ed25519 signature (RFC 8032) of bytes 0..64
//! bytes 128..     the body: the program a bootloader starts
//! ```
//!
//! The signature covers the header fields, the body through its SHA-256, so
//! neither version, board nor a byte of the body can change without the
//! key. Signing the hash rather than the body (as MCUboot does) lets a cell
//! check the signature as soon as the header arrives, refusing a forged
//! image before a single chunk is written, and then hash the body as it
//! reads its slot back ([`Verifier`]), chunk by chunk, never holding it in
//! RAM.

use sha2::{Digest, Sha256};

/// The first four bytes of every image.
pub const MAGIC: [u8; 4] = *b"SKFW";
/// The header format this crate reads and writes.
pub const FORMAT: u8 = 1;
/// Header bytes covered by the signature.
pub const SIGNED_LEN: usize = 64;
/// Length of an ed25519 signature.
pub const SIGNATURE_LEN: usize = 64;
/// Length of the whole header, signature included; the body follows.
pub const HEADER_LEN: usize = SIGNED_LEN + SIGNATURE_LEN;
/// Length of an ed25519 public key.
pub const PUBLIC_KEY_LEN: usize = 32;
/// Length of the body's SHA-256.
pub const DIGEST_LEN: usize = 32;
const DIGEST_AT: usize = 16;
/// The order L of the ed25519 base point, little endian: a signature's S
/// must be below it (RFC 8032 section 5.1.7), or it could be forged anew.
const ORDER: [u8; 32] = [
    0xed, 0xd3, 0xf5, 0x5c, 0x1a, 0x63, 0x12, 0x58, 0xd6, 0x9c, 0xf7, 0xa2, 0xde, 0xf9, 0xde, 0x14, 0, 0, 0, 0, 0, 0,
    0, 0, 0, 0, 0, 0, 0, 0, 0, 0x10,
];

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
    /// The body's SHA-256 differs from the signed one: corrupted or changed.
    BadDigest,
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
            ImageError::BadDigest => f.write_str("image body does not match its signed SHA-256 (corrupted or changed)"),
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
    /// SHA-256 of the body.
    pub body_sha256: [u8; DIGEST_LEN],
    /// ed25519 signature of the signed fields.
    pub signature: [u8; SIGNATURE_LEN],
}

impl ImageHeader {
    /// A header for `body`, signature still zero: the signer signs
    /// [`ImageHeader::signed_fields`] and puts the signature in.
    pub fn unsigned(board: Board, version: u32, body: &[u8]) -> Result<ImageHeader, ImageError> {
        let body_len = u32::try_from(body.len()).map_err(|_| ImageError::TooLong { len: u32::MAX, max: u32::MAX })?;
        let body_sha256 = Sha256::digest(body).into();
        Ok(ImageHeader { board, version, body_len, body_sha256, signature: [0; SIGNATURE_LEN] })
    }

    /// Checks the first [`HEADER_LEN`] bytes: magic, format, board, zeros.
    /// The signature is checked by [`Verifier::new`].
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
        if h[6..8].iter().chain(&h[DIGEST_AT + DIGEST_LEN..SIGNED_LEN]).any(|b| *b != 0) {
            return Err(ImageError::ReservedNotZero);
        }
        let word = |at: usize| u32::from_le_bytes([h[at], h[at + 1], h[at + 2], h[at + 3]]);
        let mut body_sha256 = [0; DIGEST_LEN];
        body_sha256.copy_from_slice(&h[DIGEST_AT..DIGEST_AT + DIGEST_LEN]);
        let mut signature = [0; SIGNATURE_LEN];
        signature.copy_from_slice(&h[SIGNED_LEN..]);
        Ok(ImageHeader { board, version: word(8), body_len: word(12), body_sha256, signature })
    }

    /// The header bytes the signature covers.
    pub fn signed_fields(&self) -> [u8; SIGNED_LEN] {
        let mut h = [0; SIGNED_LEN];
        h[..4].copy_from_slice(&MAGIC);
        h[4] = FORMAT;
        h[5] = self.board as u8;
        h[8..12].copy_from_slice(&self.version.to_le_bytes());
        h[12..16].copy_from_slice(&self.body_len.to_le_bytes());
        h[DIGEST_AT..DIGEST_AT + DIGEST_LEN].copy_from_slice(&self.body_sha256);
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

/// Checks an ed25519 signature of `message` under `key` (RFC 8032, with
/// S below the group order).
pub fn signature_valid(
    key: &[u8; PUBLIC_KEY_LEN],
    message: &[u8],
    signature: &[u8; SIGNATURE_LEN],
) -> Result<(), ImageError> {
    let key = salty::PublicKey::try_from(key).map_err(|_| ImageError::BadKey)?;
    // S is little endian: compare from the most significant byte down.
    let s = &signature[32..];
    let below_order = s.iter().rev().zip(ORDER.iter().rev()).find(|(a, b)| a != b).is_some_and(|(a, b)| a < b);
    if !below_order {
        return Err(ImageError::BadSignature);
    }
    key.verify(message, &salty::Signature::from(signature)).map_err(|_| ImageError::BadSignature)
}

/// Checks an image's header at once (board, room, signature) and its body
/// as it is read, chunk by chunk, against the signed SHA-256.
#[derive(Clone, Debug)]
pub struct Verifier {
    header: ImageHeader,
    digest: Sha256,
    seen: u32,
}

impl Verifier {
    /// Checks `header` for a cell of `board` whose slot holds bodies of up
    /// to `max_body` bytes, and its signature under `key`.
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
        signature_valid(key, &header.signed_fields(), &header.signature)?;
        Ok(Verifier { header: *header, digest: Sha256::new(), seen: 0 })
    }

    /// The header being checked.
    pub fn header(&self) -> &ImageHeader {
        &self.header
    }

    /// Takes the next bytes of the body.
    pub fn absorb(&mut self, chunk: &[u8]) -> Result<(), ImageError> {
        let seen = u32::try_from(chunk.len()).unwrap_or(u32::MAX).saturating_add(self.seen);
        if seen > self.header.body_len {
            return Err(ImageError::LengthMismatch { expected: self.header.body_len, found: seen });
        }
        self.seen = seen;
        self.digest.update(chunk);
        Ok(())
    }

    /// Ends the check: the whole body seen, its SHA-256 the signed one.
    pub fn finish(self) -> Result<ImageHeader, ImageError> {
        if self.seen != self.header.body_len {
            return Err(ImageError::LengthMismatch { expected: self.header.body_len, found: self.seen });
        }
        if <[u8; DIGEST_LEN]>::from(self.digest.finalize()) != self.header.body_sha256 {
            return Err(ImageError::BadDigest);
        }
        Ok(self.header)
    }
}

/// The image of `body` for `board` at `version`, signed with the ed25519
/// secret key `seed` (RFC 8032: deterministic, so the same program, version
/// and key always give the same image).
#[cfg(feature = "std")]
pub fn sign(body: &[u8], board: Board, version: u32, seed: &[u8; 32]) -> Result<std::vec::Vec<u8>, ImageError> {
    let mut header = ImageHeader::unsigned(board, version, body)?;
    header.signature = salty::Keypair::from(seed).sign(&header.signed_fields()).to_bytes();
    let mut image = header.to_bytes().to_vec();
    image.extend_from_slice(body);
    Ok(image)
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
