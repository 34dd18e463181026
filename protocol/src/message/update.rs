//! The payloads of a firmware update over the skin network (see
//! [`crate::update`]): the host offers an image, its chunks go down every
//! tree as broadcasts, each cell reports what it misses or what became of
//! the image, and the host confirms or rolls back.

use postcard::experimental::max_size::MaxSize;
use serde::{Deserialize, Serialize};

/// Image bytes in one chunk: what is left of a frame's payload after the
/// chunk index.
pub const CHUNK_LEN: usize = 10;

/// The host offers an image: cells that do not run this version make room
/// for it and expect `chunks` chunks. Sent before the chunks and again now
/// and then, so a cell that was off learns of it and catches up.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, MaxSize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct UpdateOffer {
    /// The version the image carries (its header says the same, signed).
    pub version: u32,
    /// Chunks of the whole image, header included.
    pub chunks: u16,
}

/// Bytes `index * CHUNK_LEN ..` of the offered image (the last chunk zero padded).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, MaxSize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ImageChunk {
    /// Which chunk.
    pub index: u16,
    /// Its bytes.
    pub data: [u8; CHUNK_LEN],
}

/// Why a cell refused an image.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize, MaxSize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Refusal {
    /// The header is not an image header, or the offer and header disagree.
    BadHeader,
    /// The signature does not verify under the cell's key.
    BadSignature,
    /// Built for another board.
    WrongBoard,
    /// Longer than the cell's slot.
    TooLong,
    /// The body does not match its signed digest (or is truncated).
    BadBody,
    /// The slot could not be written or read.
    SlotFailed,
}

/// Where a cell is with an update.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize, MaxSize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum UpdateState {
    /// Receiving the offered image; the report names the first missing run.
    Receiving,
    /// The whole image is in the slot and verified: waiting to be told to boot it.
    Ready,
    /// The image was refused and nothing changed.
    Refused(Refusal),
    /// Runs the reported version on trial, not yet confirmed.
    Trial,
    /// Runs the reported version, confirmed.
    Running,
    /// Went back to the reported (old) version: the new one was not confirmed in time.
    RolledBack,
}

/// A cell's answer to an offer, a chunk run it missed, or a command.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, MaxSize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct UpdateReport {
    /// The offered version while receiving, ready or refused; the running one otherwise.
    pub version: u32,
    /// What became of it.
    pub state: UpdateState,
    /// While receiving: the first chunk missing (selective repeat asks for it).
    pub first_missing: u16,
    /// While receiving: the span from `first_missing` to the last chunk
    /// missing within a repair window of it; the host resends the span.
    pub missing: u16,
}

/// What the host tells a cell (or every cell) to do with an image.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize, MaxSize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum UpdateAction {
    /// Boot the ready image on trial.
    Boot,
    /// The trial image works: keep it.
    Confirm,
    /// Go back to the previous image.
    Rollback,
    /// Report where you are.
    Status,
}

/// A command about the image of `version`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, MaxSize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct UpdateCommand {
    /// The version the command is about; a cell ignores a command for another.
    pub version: u32,
    /// What to do.
    pub action: UpdateAction,
}
