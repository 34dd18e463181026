//! Persistent memory of a cell (section 2.1.4): its unique ID, the sensor
//! offsets measured at its first boot, and the settings the host wrote;
//! the same records keep the bootloader's state ([`crate::boot`]).
//!
//! The state is one postcard record with a sequence number and a CRC-32,
//! written to the next free slot of a flash region; the valid record with
//! the highest sequence number wins. The region is two halves of whole
//! erase sectors used in turn: when the active half is full, the next
//! record goes to the other half and only then is the full one erased. A
//! power cut at any point therefore leaves the state either as it was or
//! as it was being written: a torn record fails its CRC and the one before
//! it stands, and the newest record is never in the half being erased.

use embedded_storage::nor_flash::{ErrorType, NorFlash, NorFlashError, NorFlashErrorKind, ReadNorFlash};
use postcard::experimental::max_size::MaxSize;
use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};
use skin_protocol::app::{SettingsStore, StoreFailed};
use skin_protocol::message::{Setting, SETTING_SLOTS};
use skin_protocol::organize::IdStore;
use skin_protocol::Address;

/// Bytes per record slot.
pub const SLOT: usize = 256;
/// Around a record: its length (2 bytes), sequence number (4) and CRC (4).
const OVERHEAD: usize = 10;
const CRC: crc::Crc<u32, crc::NoTable> = crc::Crc::<u32, crc::NoTable>::new(&crc::CRC_32_ISO_HDLC);

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

/// A state kept in records: its largest encoding fits a slot.
pub trait Record: Clone + Default + PartialEq + Serialize + DeserializeOwned + MaxSize {
    /// Checked when a store of the record is opened (a build-time error).
    const FITS: () = assert!(Self::POSTCARD_MAX_SIZE + OVERHEAD <= SLOT);
}

impl Record for Persistent {}

/// Why the store could not be opened or written.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum StoreError {
    /// The region is not two halves of whole erase sectors, or slots do
    /// not fit the flash's read and write sizes.
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

/// A state on a flash region, by default the cell's [`Persistent`] state.
#[derive(Debug)]
pub struct Store<F, T = Persistent> {
    flash: F,
    base: u32,
    half_len: u32,
    /// The half that holds the newest record.
    active: u32,
    /// Its first slot after every used one.
    next: u32,
    /// Sequence number of the newest record; 0 before the first.
    seq: u32,
    state: T,
}

impl<F, T> Store<F, T> {
    fn slots(&self) -> u32 {
        self.half_len / SLOT as u32
    }

    fn slot_at(&self, half: u32, slot: u32) -> u32 {
        self.base + half * self.half_len + slot * SLOT as u32
    }
}

impl<F: NorFlash, T: Record> Store<F, T> {
    /// Opens the region of `len` bytes at `base` and loads the newest record.
    pub fn open(mut flash: F, base: u32, len: u32) -> Result<Store<F, T>, StoreError> {
        #[allow(clippy::let_unit_value)]
        let () = T::FITS;
        let half_len = len / 2;
        let aligned = |v: u32, to: usize| (v as usize).is_multiple_of(to);
        let layout_ok = half_len as usize >= SLOT
            && aligned(base, F::ERASE_SIZE)
            && aligned(half_len, F::ERASE_SIZE)
            && len == 2 * half_len
            && SLOT.is_multiple_of(F::READ_SIZE)
            && SLOT.is_multiple_of(F::WRITE_SIZE)
            && base as usize + len as usize <= flash.capacity();
        if !layout_ok {
            return Err(StoreError::Layout);
        }
        let mut store = Store { flash: (), base, half_len, active: 0, next: 0, seq: 0, state: T::default() };
        let mut ends = [0; 2];
        let mut buf = [0u8; SLOT];
        for half in 0..2 {
            for i in 0..store.slots() {
                flash.read(store.slot_at(half, i), &mut buf).map_err(flash_error)?;
                if is_erased(&buf) {
                    continue;
                }
                // Written or torn: never written again before an erase.
                ends[half as usize] = i + 1;
                match decode(&buf) {
                    Some((seq, state)) if seq > store.seq => {
                        (store.active, store.seq, store.state) = (half, seq, state);
                    }
                    _ => {}
                }
            }
        }
        store.next = ends[store.active as usize];
        let Store { base, half_len, active, next, seq, state, .. } = store;
        Ok(Store { flash, base, half_len, active, next, seq, state })
    }

    /// The state as last stored.
    pub fn state(&self) -> &T {
        &self.state
    }

    /// Gives the flash back.
    pub fn release(self) -> F {
        self.flash
    }

    /// Keeps `state`; an unchanged state costs no write. The state in RAM
    /// changes even when the write fails.
    pub fn set(&mut self, state: T) -> Result<(), StoreError> {
        self.update(|s| *s = state)
    }

    /// Writes the state changed by `change`; an unchanged state costs no
    /// write. The state in RAM changes even when the write fails.
    fn update(&mut self, change: impl FnOnce(&mut T)) -> Result<(), StoreError> {
        let mut next = self.state.clone();
        change(&mut next);
        if next == self.state {
            return Ok(());
        }
        self.state = next;
        let mut record = [0xFFu8; SLOT];
        let len = encode(&self.state, self.seq + 1, &mut record);
        let len = len.div_ceil(F::WRITE_SIZE) * F::WRITE_SIZE;
        if self.next == self.slots() {
            let (full, fresh) = (self.active, 1 - self.active);
            if !self.is_erased(fresh)? {
                self.erase(fresh)?;
            }
            // The fresh half is used from here on, even if this write is torn.
            (self.active, self.next) = (fresh, 0);
            self.write(&record[..len])?;
            // The new record is safe: the full half may go. Should this
            // erase fail, the half is erased before its next use.
            self.erase(full)
        } else {
            self.write(&record[..len])
        }
    }

    /// Writes the next record to the next slot of the active half.
    fn write(&mut self, record: &[u8]) -> Result<(), StoreError> {
        let at = self.slot_at(self.active, self.next);
        // Past it whether or not the write completes: a torn slot is not
        // erased, so it cannot take another record.
        self.next += 1;
        self.flash.write(at, record).map_err(flash_error)?;
        self.seq += 1;
        Ok(())
    }

    fn is_erased(&mut self, half: u32) -> Result<bool, StoreError> {
        let mut buf = [0u8; SLOT];
        for i in 0..self.slots() {
            self.flash.read(self.slot_at(half, i), &mut buf).map_err(flash_error)?;
            if !is_erased(&buf) {
                return Ok(false);
            }
        }
        Ok(true)
    }

    fn erase(&mut self, half: u32) -> Result<(), StoreError> {
        let from = self.slot_at(half, 0);
        self.flash.erase(from, from + self.half_len).map_err(flash_error)
    }
}

fn flash_error<E: NorFlashError>(e: E) -> StoreError {
    StoreError::Flash(e.kind())
}

fn is_erased(slot: &[u8; SLOT]) -> bool {
    slot.iter().all(|b| *b == 0xFF)
}

/// Lays out the record of `state` with sequence number `seq` in `slot`:
/// length, sequence number, payload, CRC-32 of all three. Returns its length.
fn encode<T: Serialize>(state: &T, seq: u32, slot: &mut [u8; SLOT]) -> usize {
    // Cannot fail: the record's maximum size fits a slot (checked above).
    let n = postcard::to_slice(state, &mut slot[6..SLOT - 4]).map(|b| b.len()).unwrap_or(0);
    slot[..2].copy_from_slice(&(n as u16).to_le_bytes());
    slot[2..6].copy_from_slice(&seq.to_le_bytes());
    let crc = CRC.checksum(&slot[..6 + n]);
    slot[6 + n..10 + n].copy_from_slice(&crc.to_le_bytes());
    n + OVERHEAD
}

/// The sequence number and state of a slot, if its CRC and payload are valid.
fn decode<T: DeserializeOwned>(slot: &[u8; SLOT]) -> Option<(u32, T)> {
    let n = usize::from(u16::from_le_bytes([slot[0], slot[1]]));
    if n + OVERHEAD > SLOT {
        return None;
    }
    let crc = u32::from_le_bytes([slot[6 + n], slot[7 + n], slot[8 + n], slot[9 + n]]);
    if CRC.checksum(&slot[..6 + n]) != crc {
        return None;
    }
    let seq = u32::from_le_bytes([slot[2], slot[3], slot[4], slot[5]]);
    Some((seq, postcard::from_bytes(&slot[6..6 + n]).ok()?))
}

impl<F: NorFlash> Store<F> {
    /// Keeps the calibrated offsets.
    pub fn set_offsets(&mut self, offsets: [i32; 8]) -> Result<(), StoreError> {
        self.update(|p| p.offsets = Some(offsets))
    }

    /// Keeps an accepted setting, replacing the last one of its kind;
    /// commands are not kept.
    pub fn set_setting(&mut self, setting: Setting) -> Result<(), StoreError> {
        match setting.slot() {
            Some(slot) => self.update(|p| p.settings[slot] = Some(setting)),
            None => Ok(()),
        }
    }
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

/// The application's settings and offsets, in flash; a failed write leaves
/// the value in RAM (the application counts it).
impl<F: NorFlash> SettingsStore for Store<F> {
    fn settings(&self) -> impl Iterator<Item = Setting> + '_ {
        self.state.settings.iter().flatten().copied()
    }

    fn offsets(&self) -> Option<[i32; 8]> {
        self.state.offsets
    }

    fn keep_setting(&mut self, setting: Setting) -> Result<(), StoreFailed> {
        self.set_setting(setting).map_err(|_| StoreFailed)
    }

    fn keep_offsets(&mut self, offsets: [i32; 8]) -> Result<(), StoreFailed> {
        self.set_offsets(offsets).map_err(|_| StoreFailed)
    }
}

/// NOR flash in RAM, `SECTORS` erase sectors of `SECTOR` bytes: a write can
/// only clear bits, as on the real part. The store of a board without
/// flash, and of the tests, which can cut its power in the middle of any
/// write or erase.
///
/// It keeps the programmed bits (the complement of what reads back), so
/// erased flash is all zeros: a static of it sits in `.bss` and needs no
/// copy at start.
#[derive(Clone, Debug)]
pub struct RamFlash<const SECTOR: usize, const SECTORS: usize> {
    programmed: [[u8; SECTOR]; SECTORS],
    power: Power,
    steps: u32,
}

/// The power of a [`RamFlash`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Power {
    On,
    /// Cut in the middle of the step after `steps` more, tearing it as `tear` says.
    CutAfter {
        steps: u32,
        tear: u32,
    },
    Off,
}

impl<const SECTOR: usize, const SECTORS: usize> Default for RamFlash<SECTOR, SECTORS> {
    fn default() -> Self {
        RamFlash::new()
    }
}

impl<const SECTOR: usize, const SECTORS: usize> RamFlash<SECTOR, SECTORS> {
    /// Erased flash.
    pub const fn new() -> Self {
        RamFlash { programmed: [[0; SECTOR]; SECTORS], power: Power::On, steps: 0 }
    }

    /// Cuts the power in the middle of the step that follows `steps` more
    /// steps (a step programs one byte or erases one sector). The torn step
    /// leaves a byte with part of its bits programmed, or a sector with
    /// part of its bytes erased, as the bits of `tear` choose; then every
    /// write and erase fails until [`RamFlash::power_on`].
    pub fn cut_after(&mut self, steps: u32, tear: u32) {
        self.power = Power::CutAfter { steps, tear };
    }

    /// Power back (a reboot).
    pub fn power_on(&mut self) {
        self.power = Power::On;
    }

    /// True unless a cut happened.
    pub fn powered(&self) -> bool {
        self.power != Power::Off
    }

    /// Steps taken since creation.
    pub fn steps(&self) -> u32 {
        self.steps
    }

    /// Flips the bits `mask` of the byte at `offset`, as a fault would.
    pub fn flip(&mut self, offset: usize, mask: u8) {
        *self.byte(offset) ^= mask;
    }

    /// The programmed bits of the byte at `offset`.
    fn byte(&mut self, offset: usize) -> &mut u8 {
        &mut self.programmed[offset / SECTOR][offset % SECTOR]
    }

    /// Takes a step; `Some(tear)` when the power goes in its middle.
    fn step(&mut self) -> Result<Option<u32>, NorFlashErrorKind> {
        let torn = match &mut self.power {
            Power::On => None,
            Power::Off => return Err(NorFlashErrorKind::Other),
            Power::CutAfter { steps: 0, tear } => Some(*tear),
            Power::CutAfter { steps, .. } => {
                *steps -= 1;
                None
            }
        };
        self.steps += 1;
        if torn.is_some() {
            self.power = Power::Off;
        }
        Ok(torn)
    }

    fn range(offset: u32, len: usize) -> Result<core::ops::Range<usize>, NorFlashErrorKind> {
        let start = offset as usize;
        match start.checked_add(len) {
            Some(end) if end <= SECTOR * SECTORS => Ok(start..end),
            _ => Err(NorFlashErrorKind::OutOfBounds),
        }
    }
}

impl<const SECTOR: usize, const SECTORS: usize> ErrorType for RamFlash<SECTOR, SECTORS> {
    type Error = NorFlashErrorKind;
}

impl<const SECTOR: usize, const SECTORS: usize> ReadNorFlash for RamFlash<SECTOR, SECTORS> {
    const READ_SIZE: usize = 1;

    fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), Self::Error> {
        for (i, b) in Self::range(offset, bytes.len())?.zip(bytes) {
            *b = !*self.byte(i);
        }
        Ok(())
    }

    fn capacity(&self) -> usize {
        SECTOR * SECTORS
    }
}

impl<const SECTOR: usize, const SECTORS: usize> NorFlash for RamFlash<SECTOR, SECTORS> {
    const WRITE_SIZE: usize = 1;
    const ERASE_SIZE: usize = SECTOR;

    fn erase(&mut self, from: u32, to: u32) -> Result<(), Self::Error> {
        let (from, to) = (from as usize, to as usize);
        if from % SECTOR != 0 || to % SECTOR != 0 || from > to {
            return Err(NorFlashErrorKind::NotAligned);
        }
        if to > SECTOR * SECTORS {
            return Err(NorFlashErrorKind::OutOfBounds);
        }
        for sector in from / SECTOR..to / SECTOR {
            let torn = self.step()?;
            for (i, b) in self.programmed[sector].iter_mut().enumerate() {
                if torn.is_none_or(|tear| tear.rotate_left(i as u32) & 1 != 0) {
                    *b = 0;
                }
            }
            if torn.is_some() {
                return Err(NorFlashErrorKind::Other);
            }
        }
        Ok(())
    }

    fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), Self::Error> {
        for (i, value) in Self::range(offset, bytes.len())?.zip(bytes) {
            let torn = self.step()?;
            // The bits to clear, all of them or those the tear lets through.
            let clear = torn.map_or(!*value, |tear| !*value & !(tear as u8));
            *self.byte(i) |= clear;
            if torn.is_some() {
                return Err(NorFlashErrorKind::Other);
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;
    use skin_protocol::message::{AccelRange, TrafficMode};

    /// Two halves of one 1 KiB sector: four slots each.
    type Flash = RamFlash<1024, 2>;

    fn open(flash: Flash) -> Store<Flash> {
        Store::open(flash, 0, 2048).unwrap()
    }

    #[test]
    fn state_survives_reopening_and_alternates_halves() {
        let mut s = open(Flash::default());
        assert_eq!(s.state(), &Persistent::default());
        s.store(Address(42));
        s.set_offsets([1, 2, 3, 4, 0, 0, 0, 0]).unwrap();
        // 4 slots a half: these writes move to the other half three times.
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
            s.state().settings[Setting::ForceGain { cell: 1, gain: 0.0 }.slot().unwrap()],
            Some(Setting::ForceGain { cell: 1, gain: 9.0 })
        );
        // 13 records: 3 moves, the last one to half 1, with the older half erased.
        assert_eq!((s.active, s.next, s.seq), (1, 1, 13));
        let mut half = [0; 1024];
        s.release().read(0, &mut half).unwrap();
        assert!(half.iter().all(|b| *b == 0xFF));
    }

    #[test]
    fn unchanged_state_costs_no_write() {
        let mut s = open(Flash::default());
        s.store(Address(7));
        let steps = s.flash.steps();
        s.store(Address(7));
        s.set_setting(Setting::Calibrate).unwrap();
        assert_eq!(s.release().steps(), steps);
    }

    #[test]
    fn a_torn_record_leaves_the_previous_one() {
        let mut s = open(Flash::default());
        s.store(Address(5));
        s.set_offsets([9; 8]).unwrap();
        let mut flash = s.release();
        flash.flip(SLOT + 5, 0x10);
        let mut s = open(flash);
        assert_eq!(s.state().id, Some(Address(5)));
        assert_eq!(s.state().offsets, None);
        // The torn slot is not written again.
        s.set_offsets([3; 8]).unwrap();
        assert_eq!(s.next, 3);
        assert_eq!(open(s.release()).state().offsets, Some([3; 8]));
    }

    #[test]
    fn bad_layouts_are_refused() {
        assert_eq!(Store::<_>::open(Flash::default(), 0, 1024).unwrap_err(), StoreError::Layout);
        assert_eq!(Store::<_>::open(Flash::default(), 0, 4096).unwrap_err(), StoreError::Layout);
        assert_eq!(Store::<_>::open(RamFlash::<128, 2>::default(), 0, 256).unwrap_err(), StoreError::Layout);
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
        let mut slots: Vec<usize> = all.map(|s| s.slot().unwrap()).collect();
        slots.sort();
        assert_eq!(slots, (0..SETTING_SLOTS).collect::<Vec<_>>());
    }

    /// One change of the stored state.
    #[derive(Clone, Debug)]
    enum Change {
        Id(u16),
        Offsets(i32),
        Gain(f32),
        Rate(f32),
    }

    impl Change {
        fn apply(&self, s: &mut Store<Flash>) {
            // Errors show as the flash losing power; the store keeps the state in RAM.
            let _ = match *self {
                Change::Id(id) => {
                    s.store(Address(id));
                    Ok(())
                }
                Change::Offsets(o) => s.set_offsets([o; 8]),
                Change::Gain(gain) => s.set_setting(Setting::ForceGain { cell: 0, gain }),
                Change::Rate(hz) => s.set_setting(Setting::SampleRateHz(hz)),
            };
        }
    }

    /// Applies `changes` to an erased store whose power is cut as given;
    /// returns the states after each change (as the store holds them in
    /// RAM), the index of the change the cut interrupted, and the flash.
    fn run(changes: &[Change], cut: Option<(u32, u32)>) -> (Vec<Persistent>, Option<usize>, Flash) {
        let mut flash = Flash::default();
        if let Some((steps, tear)) = cut {
            flash.cut_after(steps, tear);
        }
        let mut s = open(flash);
        let mut states = Vec::new();
        for (i, change) in changes.iter().enumerate() {
            change.apply(&mut s);
            states.push(s.state().clone());
            if !s.flash.powered() {
                return (states, Some(i), s.release());
            }
        }
        (states, None, s.release())
    }

    /// Cuts the power at step `cut` of `changes`, tearing it with `tear`:
    /// after a reboot the store holds the state from before the interrupted
    /// change or the one it was writing, and goes on storing.
    fn check_cut(changes: &[Change], cut: u32, tear: u32) -> Result<(), String> {
        let (states, interrupted, mut flash) = run(changes, Some((cut, tear)));
        let k = interrupted.ok_or_else(|| format!("the cut at step {cut} came after the last change"))?;
        let before = if k == 0 { Persistent::default() } else { states[k - 1].clone() };
        let after = &states[k];
        flash.power_on();
        let mut s = Store::<_>::open(flash, 0, 2048).map_err(|e| format!("{e:?}"))?;
        if s.state() != &before && s.state() != after {
            return Err(format!("cut at step {cut} (change {k}, tear {tear:#x}): got {:?}", s.state()));
        }
        let mut expected = s.state().clone();
        for change in [Change::Rate(123.0), Change::Id(77), Change::Offsets(-5)] {
            change.apply(&mut s);
            expected = s.state().clone();
        }
        let s = open(s.release());
        (s.state() == &expected).then_some(()).ok_or_else(|| format!("cut at step {cut}: no longer stores"))
    }

    fn changes() -> Vec<Change> {
        let mut c = vec![Change::Id(42), Change::Offsets(1)];
        c.extend((1..12).map(|g| Change::Gain(g as f32)));
        c
    }

    #[test]
    fn a_power_cut_at_any_step_leaves_the_old_or_the_new_state() {
        let changes = changes();
        let (_, interrupted, flash) = run(&changes, None);
        assert_eq!(interrupted, None);
        // 13 records in halves of 4 slots: three moves, each with an erase.
        let steps = flash.steps();
        for tear in [0, u32::MAX, 0x0F0F_0F0F, 0x8000_0001] {
            for cut in 0..steps {
                check_cut(&changes, cut, tear).unwrap();
            }
        }
    }

    fn change() -> impl Strategy<Value = Change> {
        prop_oneof![
            (1u16..100).prop_map(Change::Id),
            any::<i32>().prop_map(Change::Offsets),
            (0.0f32..4.0).prop_map(Change::Gain),
            (1.0f32..1000.0).prop_map(Change::Rate),
        ]
    }

    proptest! {
        /// Any flash contents open as some state, and the store then works.
        #[test]
        fn any_flash_contents_open(bytes in proptest::collection::vec(any::<u8>(), 2048)) {
            let mut flash = Flash::default();
            for (i, b) in bytes.iter().enumerate() {
                flash.flip(i, *b);
            }
            let mut s = open(flash);
            s.store(Address(3));
            prop_assert_eq!(open(s.release()).load(), Some(Address(3)));
        }

        /// Random changes, a power cut at a random step with a random tear:
        /// the old or the new state, and a store that goes on working.
        #[test]
        fn a_random_power_cut_leaves_the_old_or_the_new_state(
            changes in proptest::collection::vec(change(), 1..30),
            cut in any::<proptest::sample::Index>(),
            tear in any::<u32>(),
        ) {
            let (_, _, flash) = run(&changes, None);
            if flash.steps() > 0 {
                let r = check_cut(&changes, cut.index(flash.steps() as usize) as u32, tear);
                prop_assert!(r.is_ok(), "{}", r.unwrap_err());
            }
        }
    }
}
