//! The UDP datagram between an interface port and the host (Table 2).
//!
//! ```text
//! bytes 0..2   magic "SK"
//! byte  2      version (1)
//! byte  3      interface port number
//! bytes 4..8   datagram sequence number, little endian, per port and direction
//! bytes 8..16  timestamp in microseconds of the interface clock, little endian
//! bytes 16..   1 to 72 frames of 20 bytes
//! ```
//!
//! The same format goes both ways: frames from the skin up to the host, and
//! frames from the host down into the skin. The sequence number lets the
//! receiver see loss, duplication and reordering. 72 frames keep a datagram
//! within a 1500-byte Ethernet MTU.

use crate::frame::{Frame, FrameError, FRAME_LEN};

/// Magic bytes at the start of every datagram.
pub const MAGIC: [u8; 2] = *b"SK";
/// The version this crate speaks.
pub const VERSION: u8 = 1;
/// Header length in bytes.
pub const HEADER_LEN: usize = 16;
/// Most frames in one datagram.
pub const MAX_FRAMES: usize = 72;
/// Largest datagram in bytes.
pub const MAX_DATAGRAM: usize = HEADER_LEN + MAX_FRAMES * FRAME_LEN;

/// Why bytes are not a datagram.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum DatagramError {
    /// Shorter than a header plus one frame, longer than [`MAX_DATAGRAM`],
    /// or the frames part is not a whole number of frames.
    BadLength(usize),
    /// Does not start with [`MAGIC`].
    BadMagic,
    /// A version this crate does not speak.
    UnknownVersion(u8),
}

impl core::fmt::Display for DatagramError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            DatagramError::BadLength(n) => {
                write!(f, "datagram of {n} bytes is not a header plus 1..={MAX_FRAMES} frames")
            }
            DatagramError::BadMagic => f.write_str("datagram does not start with the skin magic"),
            DatagramError::UnknownVersion(v) => write!(f, "datagram version {v}, this build speaks {VERSION}"),
        }
    }
}

#[cfg(feature = "std")]
impl std::error::Error for DatagramError {}

/// The header of a datagram.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct DatagramHeader {
    /// The interface port the frames came from or go to.
    pub interface: u8,
    /// Sequence number, per port and direction.
    pub seq: u32,
    /// Interface clock when the first frame arrived, in microseconds.
    pub timestamp_us: u64,
}

impl DatagramHeader {
    /// The header's bytes, as they open a datagram.
    pub fn to_bytes(&self) -> [u8; HEADER_LEN] {
        let mut b = [0; HEADER_LEN];
        b[0..2].copy_from_slice(&MAGIC);
        b[2] = VERSION;
        b[3] = self.interface;
        b[4..8].copy_from_slice(&self.seq.to_le_bytes());
        b[8..16].copy_from_slice(&self.timestamp_us.to_le_bytes());
        b
    }
}

/// A checked datagram borrowing its bytes; frames are checked one by one
/// as they are read, so one corrupt frame does not hide the others.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Datagram<'a> {
    header: DatagramHeader,
    frames: &'a [u8],
}

impl<'a> Datagram<'a> {
    /// Checks length, magic and version.
    pub fn parse(bytes: &'a [u8]) -> Result<Datagram<'a>, DatagramError> {
        let len = bytes.len();
        if !(HEADER_LEN + FRAME_LEN..=MAX_DATAGRAM).contains(&len) || !(len - HEADER_LEN).is_multiple_of(FRAME_LEN) {
            return Err(DatagramError::BadLength(len));
        }
        if bytes[0..2] != MAGIC {
            return Err(DatagramError::BadMagic);
        }
        if bytes[2] != VERSION {
            return Err(DatagramError::UnknownVersion(bytes[2]));
        }
        let mut seq = [0; 4];
        seq.copy_from_slice(&bytes[4..8]);
        let mut ts = [0; 8];
        ts.copy_from_slice(&bytes[8..16]);
        let header =
            DatagramHeader { interface: bytes[3], seq: u32::from_le_bytes(seq), timestamp_us: u64::from_le_bytes(ts) };
        Ok(Datagram { header, frames: &bytes[HEADER_LEN..] })
    }

    /// The header.
    pub fn header(&self) -> DatagramHeader {
        self.header
    }

    /// Number of frames.
    pub fn len(&self) -> usize {
        self.frames.len() / FRAME_LEN
    }

    /// Never true: a datagram holds at least one frame.
    pub fn is_empty(&self) -> bool {
        self.frames.is_empty()
    }

    /// The frames, each checked on its own.
    pub fn frames(&self) -> impl Iterator<Item = Result<Frame, FrameError>> + 'a {
        self.frames.chunks_exact(FRAME_LEN).map(Frame::parse)
    }
}

/// Writes a datagram of `frames` into `buf`; returns its length, or `None`
/// when there are no frames, more than [`MAX_FRAMES`], or `buf` is too small.
pub fn encode(header: DatagramHeader, frames: &[Frame], buf: &mut [u8]) -> Option<usize> {
    let len = HEADER_LEN + frames.len() * FRAME_LEN;
    if frames.is_empty() || frames.len() > MAX_FRAMES || buf.len() < len {
        return None;
    }
    buf[..HEADER_LEN].copy_from_slice(&header.to_bytes());
    for (chunk, f) in buf[HEADER_LEN..len].chunks_exact_mut(FRAME_LEN).zip(frames) {
        chunk.copy_from_slice(f.as_bytes());
    }
    Some(len)
}
