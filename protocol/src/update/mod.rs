//! Firmware update over the skin network. The host's side is the
//! [`Distributor`] (with `std`); the cell's side is the [`Updater`]: an image
//! offered by the host arrives in chunks, broadcast down every tree, into
//! the cell's spare [`Slot`]; the cell checks the header's signature as soon
//! as the header is in (a forged image is refused before its body is
//! written), asks for the chunk runs it missed (selective repeat: the host
//! resends what cells asked for, each chunk once), verifies the whole body against its
//! signed SHA-256, and then waits for the host to tell it to boot the image
//! on trial, confirm it or roll it back ([`BootAction`], done by the board
//! and its bootloader).
//!
//! Chunks travel only downstream, on child ports, while samples travel
//! upstream on the master port: an update never queues ahead of a sensor
//! frame on any link. The cell's own reports are rate-limited to one per
//! [`QUIET_US`].

mod bitmap;
#[cfg(feature = "std")]
pub mod distributor;
#[cfg(feature = "std")]
pub mod rounds;
mod updater;

pub use bitmap::Bitmap;
#[cfg(feature = "std")]
pub use distributor::{Distributor, Outcome, Outgoing};
#[cfg(feature = "std")]
pub use rounds::{Rounds, Via, ROUND_FRAMES, ROUND_TIMEOUT_US};
pub use updater::{BootAction, BootState, Updater, QUIET_US, REPAIR_WINDOW, TRIAL_REPORT_US, TRIAL_US};

use crate::app::StoreFailed;
use crate::image::{Board, ImageError, ImageHeader, Verifier, HEADER_LEN, PUBLIC_KEY_LEN};
use crate::message::{ImageChunk, CHUNK_LEN};

/// Bytes read back from a slot at a time to verify its body.
const READ_LEN: usize = 64;

/// Why the image in a slot cannot be taken.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum SlotImageError {
    /// The slot could not be read.
    Slot(StoreFailed),
    /// The image is not a genuine one for this cell.
    Image(ImageError),
}

/// Reads the body `verifier` checks out of `slot` (after the header) and
/// finishes the check.
pub fn verify_body(slot: &impl Slot, mut verifier: Verifier) -> Result<ImageHeader, SlotImageError> {
    let end = HEADER_LEN as u64 + u64::from(verifier.header().body_len);
    let mut at = HEADER_LEN as u64;
    let mut buf = [0u8; READ_LEN];
    while at < end {
        let n = (end - at).min(READ_LEN as u64) as usize;
        let offset = u32::try_from(at).map_err(|_| SlotImageError::Slot(StoreFailed))?;
        slot.read(offset, &mut buf[..n]).map_err(SlotImageError::Slot)?;
        verifier.absorb(&buf[..n]).map_err(SlotImageError::Image)?;
        at += n as u64;
    }
    verifier.finish().map_err(SlotImageError::Image)
}

/// The image in `slot` checked whole, header, signature under `key`, board
/// and body, as a bootloader does before it boots it.
pub fn verify_slot(slot: &impl Slot, board: Board, key: &[u8; PUBLIC_KEY_LEN]) -> Result<ImageHeader, SlotImageError> {
    let mut bytes = [0u8; HEADER_LEN];
    slot.read(0, &mut bytes).map_err(SlotImageError::Slot)?;
    let header = ImageHeader::parse(&bytes).map_err(SlotImageError::Image)?;
    let room = slot.capacity().saturating_sub(HEADER_LEN as u32);
    let verifier = Verifier::new(&header, board, room, key).map_err(SlotImageError::Image)?;
    verify_body(slot, verifier)
}

/// An image cut into chunks as they travel (the last one zero padded);
/// indices wrap past `u16::MAX` chunks, which the sender must refuse first.
pub fn chunks(image: &[u8]) -> impl Iterator<Item = ImageChunk> + '_ {
    image.chunks(CHUNK_LEN).enumerate().map(|(i, c)| {
        let mut data = [0; CHUNK_LEN];
        data[..c.len()].copy_from_slice(c);
        ImageChunk { index: i as u16, data }
    })
}

/// The spare slot an incoming image is written to (the one not running).
/// A power cut at any point leaves the running slot as it was.
pub trait Slot {
    /// Bytes the slot holds: header, body and the last chunk's padding.
    fn capacity(&self) -> u32;
    /// Blanks the slot for a new image.
    fn erase(&mut self) -> Result<(), StoreFailed>;
    /// Writes `data` at `offset` of a blank part.
    fn write(&mut self, offset: u32, data: &[u8]) -> Result<(), StoreFailed>;
    /// Reads `buf.len()` bytes at `offset`.
    fn read(&self, offset: u32, buf: &mut [u8]) -> Result<(), StoreFailed>;
}

/// A slot in RAM, for the simulator and tests.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct MemorySlot<const N: usize> {
    bytes: [u8; N],
}

impl<const N: usize> Default for MemorySlot<N> {
    fn default() -> Self {
        MemorySlot { bytes: [0xFF; N] }
    }
}

impl<const N: usize> MemorySlot<N> {
    /// The slot's bytes.
    pub fn bytes(&self) -> &[u8; N] {
        &self.bytes
    }

    fn range(offset: u32, len: usize) -> Result<core::ops::Range<usize>, StoreFailed> {
        let start = usize::try_from(offset).map_err(|_| StoreFailed)?;
        let end = start.checked_add(len).filter(|e| *e <= N).ok_or(StoreFailed)?;
        Ok(start..end)
    }
}

impl<const N: usize> Slot for MemorySlot<N> {
    fn capacity(&self) -> u32 {
        u32::try_from(N).unwrap_or(u32::MAX)
    }

    fn erase(&mut self) -> Result<(), StoreFailed> {
        self.bytes = [0xFF; N];
        Ok(())
    }

    fn write(&mut self, offset: u32, data: &[u8]) -> Result<(), StoreFailed> {
        let range = Self::range(offset, data.len())?;
        self.bytes[range].copy_from_slice(data);
        Ok(())
    }

    fn read(&self, offset: u32, buf: &mut [u8]) -> Result<(), StoreFailed> {
        let range = Self::range(offset, buf.len())?;
        buf.copy_from_slice(&self.bytes[range]);
        Ok(())
    }
}

#[cfg(test)]
mod tests;
