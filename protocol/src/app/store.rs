//! What a cell keeps across power cycles: its ID, its offsets and the
//! settings the host wrote. The firmware keeps them in flash; the simulator
//! and the load generator in a [`MemoryStore`] that outlives the cell.

use crate::address::Address;
use crate::message::{Setting, SETTING_SLOTS};
use crate::organize::IdStore;

/// A write to the store failed (the cell works on, with the value in RAM).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct StoreFailed;

/// Where a cell keeps its ID, offsets and settings.
pub trait SettingsStore: IdStore {
    /// The kept settings, replayed at boot in slot order.
    fn settings(&self) -> impl Iterator<Item = Setting> + '_;
    /// The kept offsets, once calibrated.
    fn offsets(&self) -> Option<[i32; 8]>;
    /// Keeps an accepted setting in its slot ([`Setting::slot`]).
    fn keep_setting(&mut self, setting: Setting) -> Result<(), StoreFailed>;
    /// Keeps calibrated offsets.
    fn keep_offsets(&mut self, offsets: [i32; 8]) -> Result<(), StoreFailed>;
}

/// A store in RAM that survives a simulated reboot when kept outside the cell.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct MemoryStore {
    /// The ID the host assigned.
    pub id: Option<Address>,
    /// Offsets in [`crate::Sample::channels`] order, once calibrated.
    pub offsets: Option<[i32; 8]>,
    /// The latest accepted setting of each kind.
    pub settings: [Option<Setting>; SETTING_SLOTS],
}

impl MemoryStore {
    /// A factory-fresh store of a cell with these `offsets` and `settings`
    /// already kept (the network's defaults, written before the cell ships).
    pub fn with(offsets: Option<[i32; 8]>, settings: impl IntoIterator<Item = Setting>) -> MemoryStore {
        let mut store = MemoryStore { offsets, ..MemoryStore::default() };
        for s in settings {
            let _ = store.keep_setting(s);
        }
        store
    }
}

impl IdStore for MemoryStore {
    fn load(&self) -> Option<Address> {
        self.id
    }

    fn store(&mut self, id: Address) {
        self.id = Some(id);
    }
}

impl SettingsStore for MemoryStore {
    fn settings(&self) -> impl Iterator<Item = Setting> + '_ {
        self.settings.iter().flatten().copied()
    }

    fn offsets(&self) -> Option<[i32; 8]> {
        self.offsets
    }

    fn keep_setting(&mut self, setting: Setting) -> Result<(), StoreFailed> {
        if let Some(slot) = setting.slot() {
            self.settings[slot] = Some(setting);
        }
        Ok(())
    }

    fn keep_offsets(&mut self, offsets: [i32; 8]) -> Result<(), StoreFailed> {
        self.offsets = Some(offsets);
        Ok(())
    }
}
