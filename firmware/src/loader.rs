//! The bootloader's work at reset, the same on every board: choose the
//! slot ([`crate::boot::boot`]: record, signature, trial), put its body in
//! the execution region the program is linked for, and say where the
//! program's vector table is. The jump itself is the board's
//! (`boards::jump`).
//!
//! The region is only rewritten when it differs from the body (flash
//! wears), and read back after: a power cut while it is written leaves the
//! slots as they were, and the next boot writes it again.

use embedded_storage::nor_flash::NorFlash;
use skin_protocol::image::{Board, ImageHeader, HEADER_LEN, PUBLIC_KEY_LEN};
use skin_protocol::update::Slot;

use crate::boot::{boot, BootError, BootRecord, SlotId};
use crate::store::Store;

/// Bytes moved at a time.
const PIECE: usize = 64;

/// Why nothing was started.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum LoadError {
    /// Neither slot holds a genuine image that fits the execution region.
    NoImage,
    /// The chosen slot could not be read.
    Slot,
    /// The execution region could not be written, or does not read back
    /// as the body.
    Exec,
}

impl From<BootError> for LoadError {
    fn from(e: BootError) -> LoadError {
        match e {
            BootError::NoImage => LoadError::NoImage,
        }
    }
}

/// The execution region: `len` bytes of `flash` from `base`.
#[derive(Debug)]
pub struct Exec<E> {
    /// Its flash (code SRAM on QEMU).
    pub flash: E,
    /// Where the region starts in it.
    pub base: u32,
    /// Its length: the longest body booted.
    pub len: u32,
}

/// Chooses the slot, installs its body, and returns the slot and the image.
pub fn load<F: NorFlash, S: Slot, E: NorFlash>(
    records: &mut Store<F, BootRecord>,
    slots: [&S; 2],
    exec: &mut Exec<E>,
    board: Board,
    key: &[u8; PUBLIC_KEY_LEN],
) -> Result<(SlotId, ImageHeader), LoadError> {
    let chosen = boot(records, slots, board, key, exec.len)?;
    let slot = slots[chosen as usize];
    let mut header = [0; HEADER_LEN];
    slot.read(0, &mut header).map_err(|_| LoadError::Slot)?;
    let header = ImageHeader::parse(&header).map_err(|_| LoadError::Slot)?;
    if !same(slot, header.body_len, exec)? {
        let len = header.body_len.next_multiple_of(E::ERASE_SIZE as u32).min(exec.len);
        exec.flash.erase(exec.base, exec.base + len).map_err(|_| LoadError::Exec)?;
        copy(slot, header.body_len, exec)?;
        if !same(slot, header.body_len, exec)? {
            return Err(LoadError::Exec);
        }
    }
    Ok((chosen, header))
}

/// True when the region holds the slot's body of `len` bytes.
fn same<S: Slot, E: NorFlash>(slot: &S, len: u32, exec: &mut Exec<E>) -> Result<bool, LoadError> {
    let (mut a, mut b) = ([0u8; PIECE], [0u8; PIECE]);
    let mut at = 0;
    while at < len {
        let n = (len - at).min(PIECE as u32) as usize;
        slot.read(HEADER_LEN as u32 + at, &mut a[..n]).map_err(|_| LoadError::Slot)?;
        exec.flash.read(exec.base + at, &mut b[..n]).map_err(|_| LoadError::Exec)?;
        if a[..n] != b[..n] {
            return Ok(false);
        }
        at += n as u32;
    }
    Ok(true)
}

fn copy<S: Slot, E: NorFlash>(slot: &S, len: u32, exec: &mut Exec<E>) -> Result<(), LoadError> {
    let mut piece = [0xFFu8; PIECE];
    let mut at = 0;
    while at < len {
        let n = (len - at).min(PIECE as u32) as usize;
        slot.read(HEADER_LEN as u32 + at, &mut piece[..n]).map_err(|_| LoadError::Slot)?;
        // Whole write units: the tail past the body stays erased.
        let unit = n.next_multiple_of(E::WRITE_SIZE).min(PIECE);
        piece[n..unit].fill(0xFF);
        exec.flash.write(exec.base + at, &piece[..unit]).map_err(|_| LoadError::Exec)?;
        at += n as u32;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::flash_slot::FlashSlot;
    use crate::store::RamFlash;

    /// Record in sectors 0-1, slots A and B in 2-3 and 4-5.
    type Flash = RamFlash<1024, 6>;
    type Code = RamFlash<256, 8>;
    const SEED: [u8; 32] = [2; 32];

    fn key() -> [u8; PUBLIC_KEY_LEN] {
        salty::Keypair::from(&SEED).public.to_bytes()
    }

    fn body(len: usize, v: u32) -> Vec<u8> {
        (0..len as u32).map(|i| (i * 11 + v) as u8).collect()
    }

    fn reset(f: &Flash, code: Code, exec_len: u32) -> (Result<(SlotId, ImageHeader), LoadError>, Code) {
        let slots = [FlashSlot::new(f.clone(), 2048, 2048).unwrap(), FlashSlot::new(f.clone(), 4096, 2048).unwrap()];
        let mut records = Store::<_, BootRecord>::open(f.clone(), 0, 2048).unwrap();
        let mut exec = Exec { flash: code, base: 256, len: exec_len };
        let got = load(&mut records, [&slots[0], &slots[1]], &mut exec, Board::Mps2An386, &key());
        (got, exec.flash)
    }

    fn region(code: &mut Code, len: usize) -> Vec<u8> {
        let mut buf = vec![0; len];
        embedded_storage::nor_flash::ReadNorFlash::read(code, 256, &mut buf).unwrap();
        buf
    }

    #[test]
    fn the_body_lands_in_the_region_and_is_not_rewritten_when_there() {
        let mut f = Flash::default();
        f.write(2048, &skin_protocol::image::sign(&body(901, 1), Board::Mps2An386, 1, &SEED).unwrap()).unwrap();
        let (got, mut code) = reset(&f, Code::default(), 1024);
        assert_eq!(got.map(|(s, h)| (s, h.version)), Ok((SlotId::A, 1)));
        assert_eq!(region(&mut code, 901), body(901, 1));
        let steps = code.steps();
        let (got, code) = reset(&f, code, 1024);
        assert!(got.is_ok());
        assert_eq!(code.steps(), steps, "an installed body is only read");
    }

    #[test]
    fn a_cut_while_the_region_is_written_is_repaired_at_the_next_boot() {
        let mut f = Flash::default();
        f.write(2048, &skin_protocol::image::sign(&body(900, 1), Board::Mps2An386, 1, &SEED).unwrap()).unwrap();
        for cut in (0..910).step_by(23) {
            let mut code = Code::default();
            code.cut_after(cut, 0x5555);
            let (got, mut code) = reset(&f, code, 1024);
            code.power_on();
            if got.is_ok() {
                assert_eq!(region(&mut code, 900), body(900, 1));
                continue;
            }
            assert_eq!(got.map(drop), Err(LoadError::Exec));
            let (got, mut code) = reset(&f, code, 1024);
            assert!(got.is_ok(), "cut after {cut} steps");
            assert_eq!(region(&mut code, 900), body(900, 1));
        }
    }

    #[test]
    fn a_body_longer_than_the_region_is_never_booted() {
        let mut f = Flash::default();
        f.write(2048, &skin_protocol::image::sign(&body(900, 1), Board::Mps2An386, 1, &SEED).unwrap()).unwrap();
        let (got, code) = reset(&f, Code::default(), 512);
        assert_eq!(got.map(drop), Err(LoadError::NoImage));
        assert_eq!(code.steps(), 0, "nothing written");
    }
}
