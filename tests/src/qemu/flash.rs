//! A QEMU cell's flash file as the factory leaves it: erased, with a
//! signed image of the `cell-qemu` program in slot A; and that program's
//! images, signed with the development key the firmware trusts by default
//! (RFC 8032's TEST 1 key: its secret is published, so only tests use it).
//! Also the boot record and slots read from or put into a flash file.

use std::fs::OpenOptions;
use std::io::{Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

use embedded_storage::nor_flash::{NorFlash, ReadNorFlash};
use skin_firmware::boot::BootRecord;
use skin_firmware::flash_map::{QEMU, QEMU_FILE_LEN, QEMU_SECTOR};
use skin_firmware::store::{RamFlash, Store};
use skin_protocol::image::{self, Board};

use super::{Context, QemuError};

/// xtask's flattening of an ELF file (one source for both).
#[path = "../../../xtask/src/elf.rs"]
#[allow(dead_code)]
mod elf;

/// The secret seed of RFC 8032 section 7.1, TEST 1: the development key.
pub const DEVELOPMENT_SEED: [u8; 32] = [
    0x9d, 0x61, 0xb1, 0x9d, 0xef, 0xfd, 0x5a, 0x60, 0xba, 0x84, 0x4a, 0xf4, 0x92, 0xec, 0x2c, 0xc4, 0x44, 0x49, 0xc5,
    0x69, 0x7b, 0x32, 0x69, 0x19, 0x70, 0x3b, 0xac, 0x03, 0x1c, 0xae, 0x7f, 0x60,
];

/// The QEMU cell's programs: the bootloader to start and the body of the
/// cell program its images carry.
#[derive(Clone, Debug)]
pub struct Programs {
    /// The `boot-qemu` ELF file, QEMU's `-kernel`.
    pub bootloader: PathBuf,
    /// The `cell-qemu` program, flat, as linked at its execution region.
    pub body: Vec<u8>,
}

impl Programs {
    /// The programs of the `cell-qemu` ELF file `cell` and the `boot-qemu` beside it.
    pub fn load(cell: &Path) -> Result<Programs, QemuError> {
        let bootloader = cell.with_file_name("boot-qemu");
        for elf in [cell, &bootloader] {
            if !elf.is_file() {
                return Err(QemuError::MissingElf(elf.to_owned()));
            }
        }
        let bytes = std::fs::read(cell).context(|| format!("reading {}", cell.display()))?;
        let bad = |why: String| QemuError::Io {
            context: format!("flattening {}", cell.display()),
            source: std::io::Error::new(std::io::ErrorKind::InvalidData, why),
        };
        let (at, body) = elf::flat_binary(&bytes).map_err(bad)?;
        if at != QEMU.exec.base {
            return Err(bad(format!("linked at {at:#x}, not at the execution region {:#x}", QEMU.exec.base)));
        }
        Ok(Programs { bootloader, body })
    }

    /// The cell program signed as `version` for `board` with `seed`.
    pub fn image(&self, version: u32, board: Board, seed: &[u8; 32]) -> Vec<u8> {
        image::sign(&self.body, board, version, seed).unwrap_or_default()
    }

    /// The cell program signed as `version` with the development key.
    pub fn genuine(&self, version: u32) -> Vec<u8> {
        self.image(version, Board::Mps2An386, &DEVELOPMENT_SEED)
    }
}

/// The body of a program that hangs at once, linked at the execution
/// region: a vector table whose every vector (reset, NMI, faults) is one
/// `b .` instruction, so it never feeds the watchdog and nothing it does
/// ends QEMU. What a trial image that hangs looks like to the bootloader.
pub fn hanging_body() -> Vec<u8> {
    const VECTORS: u32 = 16;
    let spin = QEMU.exec.base + 4 * VECTORS;
    let mut body: Vec<u8> = 0x2000_4000u32.to_le_bytes().to_vec(); // initial stack pointer
    for _ in 1..VECTORS {
        body.extend((spin | 1).to_le_bytes()); // Thumb
    }
    body.extend(0xE7FEu16.to_le_bytes()); // b .
    body.extend([0, 0]);
    body
}

/// Writes a factory-fresh flash file at `path`: erased, `image` in slot A.
pub fn provision(path: &Path, image: &[u8]) -> Result<(), QemuError> {
    let what = || format!("writing the flash file {}", path.display());
    let mut file = OpenOptions::new().create(true).write(true).truncate(true).open(path).context(what)?;
    file.write_all(&vec![0xFF; QEMU_FILE_LEN as usize]).context(what)?;
    file.seek(SeekFrom::Start(u64::from(QEMU.slots[0].base))).context(what)?;
    file.write_all(image).context(what)
}

/// Writes `image` into slot `index` of the flash file at `path`.
pub fn write_slot(path: &Path, index: usize, image: &[u8]) -> Result<(), QemuError> {
    let what = || format!("writing slot {index} of {}", path.display());
    let mut file = OpenOptions::new().write(true).open(path).context(what)?;
    file.seek(SeekFrom::Start(u64::from(QEMU.slots[index].base))).context(what)?;
    file.write_all(image).context(what)
}

/// The flash file's boot record region as a RAM flash.
type Records = RamFlash<{ QEMU_SECTOR as usize }, { (QEMU.records.len / QEMU_SECTOR) as usize }>;

fn unreadable(path: &Path, what: &str) -> QemuError {
    QemuError::Io {
        context: format!("the boot record of {}", path.display()),
        source: std::io::Error::new(std::io::ErrorKind::InvalidData, what.to_owned()),
    }
}

/// The boot record kept in the flash file at `path`.
pub fn record(path: &Path) -> Result<BootRecord, QemuError> {
    let bytes = std::fs::read(path).context(|| format!("reading {}", path.display()))?;
    let region = bytes.get(QEMU.records.base as usize..QEMU.records.end() as usize).unwrap_or_default();
    let mut ram = Records::new();
    ram.write(0, region).map_err(|_| unreadable(path, "short file"))?;
    let store = Store::<_, BootRecord>::open(ram, 0, QEMU.records.len).map_err(|_| unreadable(path, "unreadable"))?;
    Ok(*store.state())
}

/// Keeps `record` in the flash file at `path`, as a cell would.
pub fn write_record(path: &Path, record: BootRecord) -> Result<(), QemuError> {
    let mut ram = Records::new();
    Store::<_, BootRecord>::open(&mut ram, 0, QEMU.records.len)
        .map_err(|_| unreadable(path, "no store"))?
        .set(record)
        .map_err(|_| unreadable(path, "not kept"))?;
    let mut region = vec![0; QEMU.records.len as usize];
    ram.read(0, &mut region).map_err(|_| unreadable(path, "not read back"))?;
    let what = || format!("writing the boot record of {}", path.display());
    let mut file = OpenOptions::new().write(true).open(path).context(what)?;
    file.seek(SeekFrom::Start(u64::from(QEMU.records.base))).context(what)?;
    file.write_all(&region).context(what)
}

/// The bytes of a slot of the flash file at `path`.
pub fn slot(path: &Path, index: usize) -> Result<Vec<u8>, QemuError> {
    let bytes = std::fs::read(path).context(|| format!("reading the flash file {}", path.display()))?;
    let r = QEMU.slots[index];
    Ok(bytes.get(r.base as usize..r.end() as usize).unwrap_or_default().to_vec())
}
