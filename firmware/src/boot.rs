//! The bootloader's state and its choice of image: two slots (A and B),
//! a [`BootRecord`] in power-cut-safe records ([`crate::store::Store`]),
//! and every image checked whole (header, board, ed25519 signature, body
//! SHA-256) before it is booted.
//!
//! A new image is booted on trial once: the firmware asks for it
//! ([`BootRecord::request_trial`]), the bootloader marks the trial started
//! before it jumps, and a trial image that is not confirmed
//! ([`BootRecord::confirm`]) before the next boot, because it crashed,
//! hung, was told to roll back or ran out of its confirm time, is left
//! for the old one, and its version is refused from then on.
//!
//! A power cut at any point leaves a bootable cell: the record is either
//! the old one or the new one, and the confirmed slot is never the one an
//! update writes to.

use embedded_storage::nor_flash::NorFlash;
use postcard::experimental::max_size::MaxSize;
use serde::{Deserialize, Serialize};
use skin_protocol::image::{Board, PUBLIC_KEY_LEN};
use skin_protocol::update::{verify_slot, BootState, Slot};

use crate::store::{Record, Store};

/// One of the two image slots.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, MaxSize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum SlotId {
    /// The first slot (the factory image's).
    #[default]
    A,
    /// The second slot.
    B,
}

impl SlotId {
    /// The other slot.
    pub fn other(self) -> SlotId {
        match self {
            SlotId::A => SlotId::B,
            SlotId::B => SlotId::A,
        }
    }
}

/// A new image's trial.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, MaxSize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Trial {
    /// Its slot.
    pub slot: SlotId,
    /// Its version.
    pub version: u32,
    /// True once the bootloader booted it.
    pub started: bool,
}

/// What the bootloader keeps across boots.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, MaxSize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct BootRecord {
    /// The slot of the confirmed image.
    pub confirmed: SlotId,
    /// A new image on trial, asked for or started.
    pub trial: Option<Trial>,
    /// The last version whose trial failed.
    pub failed: Option<u32>,
}

impl Record for BootRecord {}

impl BootRecord {
    /// The slot the running image was booted from.
    pub fn running(&self) -> SlotId {
        match self.trial {
            Some(t) if t.started => t.slot,
            _ => self.confirmed,
        }
    }

    /// The slot an update writes to: never the confirmed one.
    pub fn spare(&self) -> SlotId {
        self.confirmed.other()
    }

    /// How the running image was booted, for the updater.
    pub fn state(&self) -> BootState {
        match (self.trial, self.failed) {
            (Some(t), _) if t.started => BootState::Trial,
            (_, Some(from)) => BootState::RolledBack { from },
            _ => BootState::Confirmed,
        }
    }

    /// The record asking for a trial boot of `version` in the spare slot.
    pub fn request_trial(&self, version: u32) -> BootRecord {
        BootRecord { trial: Some(Trial { slot: self.spare(), version, started: false }), ..*self }
    }

    /// The record keeping the running trial image for good.
    pub fn confirm(&self) -> BootRecord {
        match self.trial {
            Some(t) if t.started => BootRecord { confirmed: t.slot, trial: None, failed: None },
            _ => *self,
        }
    }

    /// The bootloader's choice: the slot to boot and the record to keep
    /// before jumping to it, given the version of the genuine image each
    /// slot holds (`None`: none). `None` when neither slot can boot.
    pub fn choose(&self, mut image: impl FnMut(SlotId) -> Option<u32>) -> Option<(SlotId, BootRecord)> {
        let mut next = *self;
        match self.trial {
            Some(t) if t.started => {
                next.trial = None;
                next.failed = Some(t.version);
            }
            Some(t) if image(t.slot) == Some(t.version) => {
                next.trial = Some(Trial { started: true, ..t });
                return Some((t.slot, next));
            }
            Some(_) => next.trial = None,
            None => {}
        }
        if image(next.confirmed).is_none() {
            // The confirmed image is gone (a fault): the other, if genuine.
            image(next.confirmed.other())?;
            next.confirmed = next.confirmed.other();
        }
        Some((next.confirmed, next))
    }
}

/// Why nothing can be booted.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum BootError {
    /// Neither slot holds a genuine image for this board.
    NoImage,
}

/// The bootloader's work at reset: the record read, both slots checked
/// as needed (a body longer than `max_body`, the room the program runs
/// in, is as good as none), the new record kept; returns the slot to jump to.
pub fn boot<F: NorFlash, S: Slot>(
    store: &mut Store<F, BootRecord>,
    slots: [&S; 2],
    board: Board,
    key: &[u8; PUBLIC_KEY_LEN],
    max_body: u32,
) -> Result<SlotId, BootError> {
    let record = *store.state();
    let genuine = |id: SlotId| {
        let header = verify_slot(slots[id as usize], board, key).ok()?;
        (header.body_len <= max_body).then_some(header.version)
    };
    let (slot, next) = record.choose(genuine).ok_or(BootError::NoImage)?;
    match store.set(next) {
        // A trial that cannot be marked started is not run: the confirmed
        // image is, and the trial is asked for again at the next boot.
        Err(_) if next.trial.is_some_and(|t| t.started) => {
            let (slot, _) = BootRecord { trial: None, ..record }.choose(genuine).ok_or(BootError::NoImage)?;
            Ok(slot)
        }
        // Anything else boots as chosen; the record is written again next time.
        _ => Ok(slot),
    }
}

#[cfg(test)]
mod tests;
