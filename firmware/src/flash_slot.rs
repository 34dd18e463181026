//! An image slot ([`Slot`]) on a region of NOR flash: where the updater
//! writes an incoming image and the bootloader reads it back.

use core::cell::RefCell;

use embedded_storage::nor_flash::NorFlash;
use skin_protocol::app::StoreFailed;
use skin_protocol::message::CHUNK_LEN;
use skin_protocol::update::Slot;

/// Why a slot region does not fit its flash.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SlotLayoutError;

/// `len` bytes of `flash` at `base`, whole erase sectors.
#[derive(Debug)]
pub struct FlashSlot<F> {
    // Reading NOR flash takes `&mut`; the slot is read through `&self`.
    flash: RefCell<F>,
    base: u32,
    len: u32,
}

impl<F: NorFlash> FlashSlot<F> {
    /// The slot of `len` bytes at `base`: whole erase sectors within the
    /// flash, written a chunk at a time.
    pub fn new(flash: F, base: u32, len: u32) -> Result<FlashSlot<F>, SlotLayoutError> {
        let aligned = |v: u32| (v as usize).is_multiple_of(F::ERASE_SIZE);
        let fits = (base as usize).checked_add(len as usize).is_some_and(|end| end <= flash.capacity());
        let ok = aligned(base)
            && aligned(len)
            && len > 0
            && fits
            && CHUNK_LEN.is_multiple_of(F::WRITE_SIZE)
            && F::READ_SIZE == 1;
        if ok {
            Ok(FlashSlot { flash: RefCell::new(flash), base, len })
        } else {
            Err(SlotLayoutError)
        }
    }

    /// Gives the flash back.
    pub fn release(self) -> F {
        self.flash.into_inner()
    }

    /// The flash address of `len` bytes at `offset`, if inside the slot.
    fn at(&self, offset: u32, len: usize) -> Result<u32, StoreFailed> {
        let len = u32::try_from(len).map_err(|_| StoreFailed)?;
        match offset.checked_add(len) {
            Some(end) if end <= self.len => Ok(self.base + offset),
            _ => Err(StoreFailed),
        }
    }
}

impl<F: NorFlash> Slot for FlashSlot<F> {
    fn capacity(&self) -> u32 {
        self.len
    }

    fn erase(&mut self) -> Result<(), StoreFailed> {
        self.flash.get_mut().erase(self.base, self.base + self.len).map_err(|_| StoreFailed)
    }

    fn write(&mut self, offset: u32, data: &[u8]) -> Result<(), StoreFailed> {
        let at = self.at(offset, data.len())?;
        self.flash.get_mut().write(at, data).map_err(|_| StoreFailed)
    }

    fn read(&self, offset: u32, buf: &mut [u8]) -> Result<(), StoreFailed> {
        let at = self.at(offset, buf.len())?;
        let mut flash = self.flash.try_borrow_mut().map_err(|_| StoreFailed)?;
        flash.read(at, buf).map_err(|_| StoreFailed)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::store::RamFlash;
    use embedded_storage::nor_flash::ReadNorFlash;

    type Flash = RamFlash<256, 4>;

    #[test]
    fn writes_read_back_inside_the_slot_only() {
        let mut slot = FlashSlot::new(Flash::default(), 256, 512).unwrap();
        slot.erase().unwrap();
        slot.write(10, &[1, 2, 3]).unwrap();
        let mut buf = [0; 4];
        slot.read(9, &mut buf).unwrap();
        assert_eq!(buf, [0xFF, 1, 2, 3]);
        assert_eq!(slot.write(510, &[0; 3]), Err(StoreFailed));
        assert_eq!(slot.read(u32::MAX, &mut buf), Err(StoreFailed));
        let mut flash = slot.release();
        let mut raw = [0; 3];
        flash.read(266, &mut raw).unwrap();
        assert_eq!(raw, [1, 2, 3]);
        flash.read(0, &mut raw).unwrap();
        assert_eq!(raw, [0xFF; 3], "the sector before the slot is untouched");
    }

    #[test]
    fn erase_blanks_the_slot_and_nothing_else() {
        let mut flash = Flash::default();
        flash.write(0, &[7]).unwrap();
        flash.write(768, &[7]).unwrap();
        let mut slot = FlashSlot::new(flash, 256, 512).unwrap();
        slot.write(0, &[0; 10]).unwrap();
        slot.erase().unwrap();
        let mut buf = [0; 10];
        slot.read(0, &mut buf).unwrap();
        assert_eq!(buf, [0xFF; 10]);
        let mut flash = slot.release();
        let (mut a, mut b) = ([0], [0]);
        flash.read(0, &mut a).unwrap();
        flash.read(768, &mut b).unwrap();
        assert_eq!((a, b), ([7], [7]));
    }

    #[test]
    fn layouts_off_the_sectors_or_the_flash_are_refused() {
        assert!(FlashSlot::new(Flash::default(), 100, 256).is_err());
        assert!(FlashSlot::new(Flash::default(), 0, 300).is_err());
        assert!(FlashSlot::new(Flash::default(), 768, 512).is_err());
        assert!(FlashSlot::new(Flash::default(), 0, 0).is_err());
        assert!(FlashSlot::new(Flash::default(), 0, 1024).is_ok());
    }
}
