//! The cell program's side of its bootloader: at start, what the boot
//! record says it runs (the updater's version and state, the spare slot
//! an update goes to); then the updater's boot actions kept in the record,
//! and the trial's time limit.
//!
//! A trial image must be confirmed within the limit of its board: if it
//! does not join the network and hear the host's confirm by then, the cell
//! restarts, and the bootloader, finding the trial started but never
//! confirmed, boots the old image and refuses that version from then on.

use embedded_storage::nor_flash::NorFlash;
use skin_protocol::image::{Board, ImageError, ImageHeader, HEADER_LEN, PUBLIC_KEY_LEN};
use skin_protocol::update::{BootAction, BootState, Slot, Updater};

use crate::boot::BootRecord;
use crate::flash_map::FlashMap;
use crate::flash_slot::{FlashSlot, SlotLayoutError};
use crate::store::{Store, StoreError};

/// Why a program cannot take updates (it still runs; updates are ignored).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ControlError {
    /// The boot record could not be read.
    Records(StoreError),
    /// A slot does not fit the flash.
    Layout(SlotLayoutError),
    /// The running slot could not be read.
    Slot,
    /// The running slot's header is not an image header (the bootloader
    /// would not have started it).
    Running(ImageError),
}

/// What the board must do after [`BootControl::act`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Then {
    /// Carry on.
    Run,
    /// Restart into the bootloader.
    Restart,
}

/// The boot record and the trial's deadline.
#[derive(Debug)]
pub struct BootControl<F> {
    records: Store<F, BootRecord>,
    trial_until_us: Option<u64>,
}

/// The control, the updater and the spare slot of a program started at
/// `now_us` from the boot record in `flash`, laid out as `map`; a trial
/// must be confirmed within `trial_us`.
pub fn start<F: NorFlash + Clone>(
    flash: F,
    map: &FlashMap,
    board: Board,
    key: [u8; PUBLIC_KEY_LEN],
    trial_us: u64,
    now_us: u64,
) -> Result<(BootControl<F>, Updater, FlashSlot<F>), ControlError> {
    let records = Store::<F, BootRecord>::open(flash.clone(), map.records.base, map.records.len)
        .map_err(ControlError::Records)?;
    let record = *records.state();
    let slot = |id: crate::boot::SlotId| {
        let region = map.slots[id as usize];
        FlashSlot::new(flash.clone(), region.base, region.len).map_err(ControlError::Layout)
    };
    let mut header = [0; HEADER_LEN];
    slot(record.running())?.read(0, &mut header).map_err(|_| ControlError::Slot)?;
    let running = ImageHeader::parse(&header).map_err(ControlError::Running)?;
    let state = record.state();
    let updater = Updater::new(board, key, running.version, state);
    let trial_until_us = (state == BootState::Trial).then(|| now_us.saturating_add(trial_us));
    Ok((BootControl { records, trial_until_us }, updater, slot(record.spare())?))
}

impl<F: NorFlash> BootControl<F> {
    /// The record as kept.
    pub fn record(&self) -> &BootRecord {
        self.records.state()
    }

    /// Keeps what `action` asks in the record; `ready` is the version of
    /// the image ready in the spare slot. A record that cannot be written
    /// changes nothing: the host asks again.
    pub fn act(&mut self, action: BootAction, ready: u32) -> Result<Then, StoreError> {
        let record = *self.records.state();
        match action {
            BootAction::BootTrial => {
                self.records.set(record.request_trial(ready))?;
                Ok(Then::Restart)
            }
            BootAction::Confirm => {
                self.records.set(record.confirm())?;
                self.trial_until_us = None;
                Ok(Then::Run)
            }
            // The trial is started and unconfirmed: the bootloader goes back.
            BootAction::Rollback => Ok(Then::Restart),
        }
    }

    /// True once an unconfirmed trial has run out of time.
    pub fn expired(&self, now_us: u64) -> bool {
        self.trial_until_us.is_some_and(|t| now_us >= t)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::boot::SlotId;
    use crate::flash_map::Region;
    use crate::shared_flash::SharedFlash;
    use crate::store::RamFlash;
    use core::cell::RefCell;

    type Flash = RamFlash<1024, 12>;
    const MAP: FlashMap = FlashMap {
        store: Region { base: 0, len: 2048 },
        records: Region { base: 2048, len: 2048 },
        slots: [Region { base: 4096, len: 4096 }, Region { base: 8192, len: 4096 }],
        exec: Region { base: 0x1_0000, len: 3072 },
    };
    const SEED: [u8; 32] = [5; 32];

    fn key() -> [u8; PUBLIC_KEY_LEN] {
        salty::Keypair::from(&SEED).public.to_bytes()
    }

    fn flash() -> RefCell<Flash> {
        let body = [7u8; 500];
        let image = skin_protocol::image::sign(&body, Board::Mps2An386, 4, &SEED).unwrap();
        let mut f = Flash::default();
        f.write(4096, &image).unwrap();
        RefCell::new(f)
    }

    #[test]
    fn a_confirmed_image_runs_without_deadline_and_a_trial_request_restarts() {
        let f = flash();
        let (mut control, updater, spare) =
            start(SharedFlash::new(&f), &MAP, Board::Mps2An386, key(), 1_000, 0).unwrap();
        assert_eq!((updater.running(), updater.report().state), (4, skin_protocol::message::UpdateState::Running));
        assert_eq!(spare.capacity(), 4096);
        assert!(!control.expired(u64::MAX));
        assert_eq!(control.act(BootAction::BootTrial, 5), Ok(Then::Restart));
        let trial = control.record().trial.unwrap();
        assert_eq!((trial.slot, trial.version, trial.started), (SlotId::B, 5, false));
    }

    #[test]
    fn a_trial_expires_unless_confirmed() {
        let f = flash();
        let started = BootRecord::default().request_trial(5);
        let started = BootRecord { trial: started.trial.map(|t| crate::boot::Trial { started: true, ..t }), ..started };
        Store::<_, BootRecord>::open(SharedFlash::new(&f), 2048, 2048).unwrap().set(started).unwrap();
        // Slot B holds the trial image.
        let image = skin_protocol::image::sign(&[9u8; 300], Board::Mps2An386, 5, &SEED).unwrap();
        f.borrow_mut().write(8192, &image).unwrap();
        let (mut control, updater, spare) =
            start(SharedFlash::new(&f), &MAP, Board::Mps2An386, key(), 1_000, 50).unwrap();
        assert_eq!((updater.running(), updater.report().state), (5, skin_protocol::message::UpdateState::Trial));
        // The confirmed image (A) is never the spare, even during a trial.
        let mut header = [0; HEADER_LEN];
        spare.read(0, &mut header).unwrap();
        assert_eq!(ImageHeader::parse(&header).unwrap().version, 5);
        assert!(!control.expired(1_049));
        assert!(control.expired(1_050));
        assert_eq!(control.act(BootAction::Confirm, 0), Ok(Then::Run));
        assert!(!control.expired(u64::MAX));
        assert_eq!((control.record().confirmed, control.record().trial), (SlotId::B, None));
        assert_eq!(control.act(BootAction::Rollback, 0), Ok(Then::Restart));
    }

    #[test]
    fn an_empty_running_slot_is_an_error_not_a_panic() {
        let f = RefCell::new(Flash::default());
        let got = start(SharedFlash::new(&f), &MAP, Board::Mps2An386, key(), 1_000, 0).map(drop);
        assert_eq!(got, Err(ControlError::Running(ImageError::BadMagic)));
    }
}
