//! Persistent memory of a cell (section 2.1.4): its unique ID, the sensor
//! offsets measured at its first boot, and the settings the host wrote.
//!
//! The state is one postcard record with a CRC-16, appended to a flash
//! region slot after slot; the newest valid record wins, and the region is
//! erased only when every slot has been used, which spreads the wear. A
//! record torn by a power loss fails its CRC and the one before it stands.

use embedded_storage::nor_flash::{ErrorType, NorFlash, NorFlashError, NorFlashErrorKind, ReadNorFlash};
use postcard::experimental::max_size::MaxSize;
use serde::{Deserialize, Serialize};
use skin_protocol::message::Setting;
use skin_protocol::organize::IdStore;
use skin_protocol::Address;

/// Bytes per record slot.
pub const SLOT: usize = 256;
/// Length prefix and CRC around a record.
const OVERHEAD: usize = 4;
const CRC: crc::Crc<u16> = crc::Crc::<u16>::new(&crc::CRC_16_KERMIT);

/// One slot per kind of [`Setting`] (and per level, channel or cell).
pub const SETTING_SLOTS: usize = 24;

/// Where a setting is kept: a later write of the same kind replaces it.
/// `None` for a command (calibrate), which is not state to restore.
fn setting_slot(s: &Setting) -> Option<usize> {
    Some(match *s {
        Setting::SampleRateHz(_) => 0,
        Setting::Traffic(_) => 1,
        Setting::FilterCutoffHz(_) => 2,
        Setting::ForceLevel { level, .. } => 2 + usize::from(level.clamp(1, 4)),
        Setting::ProximityLevel { level, .. } => 6 + usize::from(level.clamp(1, 4)),
        Setting::Hysteresis(_) => 11,
        Setting::Delta { channel, .. } => 12 + usize::from(channel.min(7)),
        Setting::ForceGain { cell, .. } => 20 + usize::from(cell.min(2)),
        Setting::AccelRange(_) => 23,
        Setting::Calibrate => return None,
    })
}

/// Everything a cell keeps across power cycles.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize, MaxSize)]
pub struct Persistent {
    /// The ID the host assigned.
    pub id: Option<Address>,
    /// Offsets in [`skin_protocol::Sample::channels`] order, once calibrated.
    pub offsets: Option<[i32; 8]>,
    /// The latest accepted setting of each kind, replayed at boot.
    pub settings: [Option<Setting>; SETTING_SLOTS],
}

const _: () = assert!(Persistent::POSTCARD_MAX_SIZE + OVERHEAD <= SLOT);

/// Why the store could not be opened or written.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum StoreError {
    /// The region is not whole erase sectors, or slots do not fit the
    /// flash's read and write sizes.
    Layout,
    /// The flash refused an operation.
    Flash(NorFlashErrorKind),
}

#[cfg(feature = "defmt")]
impl defmt::Format for StoreError {
    fn format(&self, f: defmt::Formatter) {
        match self {
            StoreError::Layout => defmt::write!(f, "store region does not fit the flash's sectors"),
            StoreError::Flash(kind) => defmt::write!(f, "flash error {}", defmt::Debug2Format(kind)),
        }
    }
}

/// The cell's persistent state on a flash region.
#[derive(Debug)]
pub struct Store<F> {
    flash: F,
    base: u32,
    slots: u32,
    next: u32,
    state: Persistent,
}

impl<F: NorFlash> Store<F> {
    /// Opens the region of `len` bytes at `base` and loads the newest record.
    pub fn open(mut flash: F, base: u32, len: u32) -> Result<Store<F>, StoreError> {
        let aligned = |v: u32, to: usize| v as usize % to == 0;
        let layout_ok = len as usize >= SLOT
            && aligned(base, F::ERASE_SIZE)
            && aligned(len, F::ERASE_SIZE)
            && SLOT % F::READ_SIZE == 0
            && SLOT % F::WRITE_SIZE == 0
            && (base + len) as usize <= flash.capacity();
        if !layout_ok {
            return Err(StoreError::Layout);
        }
        let slots = len / SLOT as u32;
        let mut state = Persistent::default();
        let mut next = slots;
        let mut buf = [0u8; SLOT];
        for i in 0..slots {
            flash.read(base + i * SLOT as u32, &mut buf).map_err(|e| StoreError::Flash(e.kind()))?;
            // Only a wholly erased slot can take a record: one torn before
            // its length was written still has programmed bytes.
            if buf.iter().all(|b| *b == 0xFF) {
                next = i;
                break;
            }
            let n = u16::from_le_bytes([buf[0], buf[1]]);
            if let Some(record) = decode(&buf, usize::from(n)) {
                state = record;
            }
        }
        Ok(Store { flash, base, slots, next, state })
    }

    /// The state as last stored.
    pub fn state(&self) -> &Persistent {
        &self.state
    }

    /// Keeps the calibrated offsets.
    pub fn set_offsets(&mut self, offsets: [i32; 8]) -> Result<(), StoreError> {
        self.update(|p| p.offsets = Some(offsets))
    }

    /// Keeps an accepted setting, replacing the last one of its kind;
    /// commands are not kept.
    pub fn set_setting(&mut self, setting: Setting) -> Result<(), StoreError> {
        match setting_slot(&setting) {
            Some(slot) => self.update(|p| p.settings[slot] = Some(setting)),
            None => Ok(()),
        }
    }

    /// Writes the state changed by `change`; an unchanged state costs no write.
    fn update(&mut self, change: impl FnOnce(&mut Persistent)) -> Result<(), StoreError> {
        let mut next = self.state.clone();
        change(&mut next);
        if next == self.state {
            return Ok(());
        }
        self.state = next;
        let flash_err = |e: F::Error| StoreError::Flash(e.kind());
        let mut buf = [0xFFu8; SLOT];
        // Cannot fail: the record's maximum size fits a slot (checked above).
        let n = postcard::to_slice(&self.state, &mut buf[2..SLOT - 2]).map(|b| b.len()).unwrap_or(0);
        buf[..2].copy_from_slice(&(n as u16).to_le_bytes());
        let crc = CRC.checksum(&buf[..2 + n]);
        buf[2 + n..2 + n + 2].copy_from_slice(&crc.to_le_bytes());
        if self.next == self.slots {
            self.flash.erase(self.base, self.base + self.slots * SLOT as u32).map_err(flash_err)?;
            self.next = 0;
        }
        let used = (n + OVERHEAD).div_ceil(F::WRITE_SIZE) * F::WRITE_SIZE;
        let at = self.base + self.next * SLOT as u32;
        self.next += 1;
        self.flash.write(at, &buf[..used]).map_err(flash_err)
    }

    /// Gives the flash back.
    pub fn release(self) -> F {
        self.flash
    }
}

/// A record of `n` payload bytes in a slot, if its CRC and payload are valid.
fn decode(slot: &[u8; SLOT], n: usize) -> Option<Persistent> {
    if n + OVERHEAD > SLOT {
        return None;
    }
    let crc = u16::from_le_bytes([slot[2 + n], slot[3 + n]]);
    if CRC.checksum(&slot[..2 + n]) != crc {
        return None;
    }
    postcard::from_bytes(&slot[2..2 + n]).ok()
}

/// The ID goes to flash the moment it is assigned. A failed write leaves
/// the ID in RAM: the cell keeps working and asks again after a reboot.
impl<F: NorFlash> IdStore for Store<F> {
    fn load(&self) -> Option<Address> {
        self.state.id
    }

    fn store(&mut self, id: Address) {
        if let Err(_e) = self.update(|p| p.id = Some(id)) {
            #[cfg(feature = "defmt")]
            defmt::error!("storing ID {} failed: {}", id, _e);
        }
    }
}

/// NOR flash in RAM, one erase sector of `N` bytes: a write can only clear
/// bits, as on the real part. The store of a board without flash, and of
/// the tests.
#[derive(Clone, Debug)]
pub struct RamFlash<const N: usize> {
    bytes: [u8; N],
}

impl<const N: usize> Default for RamFlash<N> {
    fn default() -> Self {
        RamFlash::new()
    }
}

impl<const N: usize> RamFlash<N> {
    /// Erased flash.
    pub const fn new() -> Self {
        RamFlash { bytes: [0xFF; N] }
    }

    fn range(offset: u32, len: usize) -> Result<core::ops::Range<usize>, NorFlashErrorKind> {
        let start = offset as usize;
        match start.checked_add(len) {
            Some(end) if end <= N => Ok(start..end),
            _ => Err(NorFlashErrorKind::OutOfBounds),
        }
    }

    /// The raw contents.
    pub fn bytes(&self) -> &[u8; N] {
        &self.bytes
    }

    /// Mutable raw contents, to simulate corruption.
    pub fn bytes_mut(&mut self) -> &mut [u8; N] {
        &mut self.bytes
    }
}

impl<const N: usize> ErrorType for RamFlash<N> {
    type Error = NorFlashErrorKind;
}

impl<const N: usize> ReadNorFlash for RamFlash<N> {
    const READ_SIZE: usize = 1;

    fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), Self::Error> {
        bytes.copy_from_slice(&self.bytes[Self::range(offset, bytes.len())?]);
        Ok(())
    }

    fn capacity(&self) -> usize {
        N
    }
}

impl<const N: usize> NorFlash for RamFlash<N> {
    const WRITE_SIZE: usize = 1;
    const ERASE_SIZE: usize = N;

    fn erase(&mut self, from: u32, to: u32) -> Result<(), Self::Error> {
        if from != 0 || to as usize != N {
            return Err(NorFlashErrorKind::NotAligned);
        }
        self.bytes = [0xFF; N];
        Ok(())
    }

    fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), Self::Error> {
        for (d, s) in self.bytes[Self::range(offset, bytes.len())?].iter_mut().zip(bytes) {
            *d &= *s;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;
    use skin_protocol::message::{AccelRange, TrafficMode};

    type Flash = RamFlash<1024>;

    fn open(flash: Flash) -> Store<Flash> {
        Store::open(flash, 0, 1024).unwrap()
    }

    #[test]
    fn state_survives_reopening_and_wraps_around_the_region() {
        let mut s = open(Flash::default());
        assert_eq!(s.state(), &Persistent::default());
        s.store(Address(42));
        s.set_offsets([1, 2, 3, 4, 0, 0, 0, 0]).unwrap();
        // 1024 bytes hold 4 slots: these writes wrap around twice.
        for gain in 1..10 {
            s.set_setting(Setting::ForceGain { cell: 1, gain: gain as f32 }).unwrap();
        }
        s.set_setting(Setting::Traffic(TrafficMode::Event)).unwrap();
        s.set_setting(Setting::AccelRange(AccelRange::G16)).unwrap();
        let expected = s.state().clone();
        let s = open(s.release());
        assert_eq!(s.state(), &expected);
        assert_eq!(s.load(), Some(Address(42)));
        assert_eq!(
            s.state().settings[setting_slot(&Setting::ForceGain { cell: 1, gain: 0.0 }).unwrap()],
            Some(Setting::ForceGain { cell: 1, gain: 9.0 })
        );
    }

    #[test]
    fn unchanged_state_costs_no_write() {
        let mut s = open(Flash::default());
        s.store(Address(7));
        let before = s.release().bytes().to_vec();
        let mut s = open(Flash::default());
        s.store(Address(7));
        s.store(Address(7));
        assert_eq!(s.release().bytes().to_vec(), before);
    }

    #[test]
    fn a_torn_record_leaves_the_previous_one() {
        let mut s = open(Flash::default());
        s.store(Address(5));
        s.set_offsets([9; 8]).unwrap();
        let mut flash = s.release();
        flash.bytes_mut()[SLOT + 5] ^= 0x10;
        let s = open(flash);
        assert_eq!(s.state().id, Some(Address(5)));
        assert_eq!(s.state().offsets, None);
    }

    #[test]
    fn bad_layouts_are_refused() {
        assert_eq!(Store::open(Flash::default(), 0, 512).unwrap_err(), StoreError::Layout);
        assert_eq!(Store::open(RamFlash::<128>::default(), 0, 128).unwrap_err(), StoreError::Layout);
    }

    #[test]
    fn every_setting_kind_has_its_own_slot() {
        let all = [Setting::SampleRateHz(1.0), Setting::Traffic(TrafficMode::Clock), Setting::FilterCutoffHz(1.0)]
            .into_iter()
            .chain((1..=4).map(|level| Setting::ForceLevel { level, value: 0.0 }))
            .chain((1..=4).map(|level| Setting::ProximityLevel { level, value: 0.0 }))
            .chain([Setting::Hysteresis(0.0)])
            .chain((0..8).map(|channel| Setting::Delta { channel, counts: 0 }))
            .chain((0..3).map(|cell| Setting::ForceGain { cell, gain: 1.0 }))
            .chain([Setting::AccelRange(AccelRange::G2)]);
        let mut slots: Vec<usize> = all.map(|s| setting_slot(&s).unwrap()).collect();
        slots.sort();
        assert_eq!(slots, (0..SETTING_SLOTS).collect::<Vec<_>>());
    }

    proptest! {
        /// Any flash contents open as some state or a layout error, never a panic.
        #[test]
        fn any_flash_contents_open(bytes in proptest::collection::vec(any::<u8>(), 1024)) {
            let mut flash = Flash::default();
            flash.bytes_mut().copy_from_slice(&bytes);
            let mut s = open(flash);
            s.store(Address(3));
            prop_assert_eq!(open(s.release()).load(), Some(Address(3)));
        }
    }
}
