//! One flash seen by several owners: the settings store, the boot record
//! and the image slots are regions of the same chip (or QEMU file), and
//! each takes a [`SharedFlash`] handle to it. The cell is single-threaded,
//! so a handle borrows the flash for one operation at a time.

use core::cell::RefCell;

use embedded_storage::nor_flash::{ErrorType, NorFlash, NorFlashError, NorFlashErrorKind, ReadNorFlash};

/// A handle to a flash that others hold handles to.
#[derive(Debug)]
pub struct SharedFlash<'a, F>(&'a RefCell<F>);

impl<F> Clone for SharedFlash<'_, F> {
    fn clone(&self) -> Self {
        SharedFlash(self.0)
    }
}

impl<'a, F> SharedFlash<'a, F> {
    /// A handle to `flash`.
    pub fn new(flash: &'a RefCell<F>) -> Self {
        SharedFlash(flash)
    }

    fn with<T>(&self, op: impl FnOnce(&mut F) -> Result<T, NorFlashErrorKind>) -> Result<T, NorFlashErrorKind> {
        // Busy only if an operation ran inside another: a bug, reported as a flash error.
        let mut flash = self.0.try_borrow_mut().map_err(|_| NorFlashErrorKind::Other)?;
        op(&mut flash)
    }
}

impl<F: ErrorType> ErrorType for SharedFlash<'_, F> {
    type Error = NorFlashErrorKind;
}

impl<F: ReadNorFlash> ReadNorFlash for SharedFlash<'_, F> {
    const READ_SIZE: usize = F::READ_SIZE;

    fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), Self::Error> {
        self.with(|f| f.read(offset, bytes).map_err(|e| e.kind()))
    }

    fn capacity(&self) -> usize {
        self.0.try_borrow().map(|f| f.capacity()).unwrap_or(0)
    }
}

impl<F: NorFlash> NorFlash for SharedFlash<'_, F> {
    const WRITE_SIZE: usize = F::WRITE_SIZE;
    const ERASE_SIZE: usize = F::ERASE_SIZE;

    fn erase(&mut self, from: u32, to: u32) -> Result<(), Self::Error> {
        self.with(|f| f.erase(from, to).map_err(|e| e.kind()))
    }

    fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), Self::Error> {
        self.with(|f| f.write(offset, bytes).map_err(|e| e.kind()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::store::RamFlash;

    #[test]
    fn every_handle_sees_the_others_writes() {
        let flash = RefCell::new(RamFlash::<256, 2>::default());
        let (mut a, mut b) = (SharedFlash::new(&flash), SharedFlash::new(&flash));
        a.write(10, &[1, 2]).unwrap();
        let mut buf = [0; 2];
        b.read(10, &mut buf).unwrap();
        assert_eq!(buf, [1, 2]);
        b.erase(0, 256).unwrap();
        a.read(10, &mut buf).unwrap();
        assert_eq!(buf, [0xFF; 2]);
        assert_eq!(a.capacity(), 512);
        let _held = flash.borrow_mut();
        assert_eq!(a.read(0, &mut buf), Err(NorFlashErrorKind::Other), "a busy flash is an error, not a panic");
    }
}
