//! A QEMU cell's flash file as the factory leaves it: erased, with a
//! signed image of the `cell-qemu` program in slot A; and that program's
//! images, signed with the development key the firmware trusts by default
//! (RFC 8032's TEST 1 key: its secret is published, so only tests use it).

use std::fs::OpenOptions;
use std::io::{Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

use skin_firmware::flash_map::{QEMU, QEMU_FILE_LEN};
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

/// Writes a factory-fresh flash file at `path`: erased, `image` in slot A.
pub fn provision(path: &Path, image: &[u8]) -> Result<(), QemuError> {
    let what = || format!("writing the flash file {}", path.display());
    let mut file = OpenOptions::new().create(true).write(true).truncate(true).open(path).context(what)?;
    file.write_all(&vec![0xFF; QEMU_FILE_LEN as usize]).context(what)?;
    file.seek(SeekFrom::Start(u64::from(QEMU.slots[0].base))).context(what)?;
    file.write_all(image).context(what)
}

/// The bytes of a slot of the flash file at `path`.
pub fn slot(path: &Path, index: usize) -> Result<Vec<u8>, QemuError> {
    let bytes = std::fs::read(path).context(|| format!("reading the flash file {}", path.display()))?;
    let r = QEMU.slots[index];
    Ok(bytes.get(r.base as usize..r.end() as usize).unwrap_or_default().to_vec())
}
