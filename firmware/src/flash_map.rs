//! Where each board keeps its bootloader, its running program, its two
//! image slots, its boot record and its settings store.
//!
//! The slots hold signed images (header and body, as they arrived); the
//! program runs from an execution region the bootloader fills with the
//! body of the slot it chose. So one image runs from either slot (no
//! position-independent code, no per-slot link), and the slots are never
//! written at boot: a power cut while the region is filled leaves both
//! slots as they were, and the next boot fills it again.
//!
//! The memory layouts the programs are linked with (`memory/*.x`) say the
//! same addresses; a test checks they agree.

/// A run of bytes of a flash: `len` bytes from `base`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Region {
    /// The first byte, as the board's flash driver numbers them.
    pub base: u32,
    /// Bytes.
    pub len: u32,
}

impl Region {
    /// The byte after the region.
    pub const fn end(&self) -> u32 {
        self.base + self.len
    }
}

/// A board's layout.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FlashMap {
    /// The cell's ID, offsets and settings (`store::Store`).
    pub store: Region,
    /// The bootloader's record (`boot::BootRecord` in a `store::Store`).
    pub records: Region,
    /// Image slots A and B.
    pub slots: [Region; 2],
    /// Where the running program's body is, as a CPU address: the program
    /// is linked there, and a body longer than it is never booted.
    pub exec: Region,
}

/// QEMU's mps2-an386: the store, the record and the slots are in one
/// semihosting file on the host (`flash=PATH`), so a killed QEMU is a
/// power cut; the bootloader (32 KiB at 0x0) and the execution region
/// (64 KiB at 0x0001_0000) are in the board's code SRAM, filled again at
/// every reset. Erase sectors of the file are 1 KiB.
pub const QEMU: FlashMap = FlashMap {
    store: Region { base: 0x0000, len: 0x0800 },
    records: Region { base: 0x0800, len: 0x0800 },
    slots: [Region { base: 0x1000, len: QEMU_SLOT }, Region { base: 0x1000 + QEMU_SLOT, len: QEMU_SLOT }],
    exec: Region { base: 0x0001_0000, len: 0x1_0000 },
};

/// A QEMU slot: a 64 KiB body and its 128-byte header, in 1 KiB sectors.
const QEMU_SLOT: u32 = 0x1_0400;

/// Bytes of QEMU's flash file.
pub const QEMU_FILE_LEN: u32 = QEMU.slots[1].end();

/// Bytes of an erase sector of QEMU's flash file.
pub const QEMU_SECTOR: u32 = 1024;

/// The STM32F405's 1 MiB of flash (offsets from 0x0800_0000; sectors 0-3
/// are 16 KiB, 4 is 64 KiB, 5-11 are 128 KiB):
///
/// | sectors | offset | what |
/// |---|---|---|
/// | 0-1 | 0x00000 | bootloader, 32 KiB |
/// | 2-3 | 0x08000 | free |
/// | 4 | 0x10000 | execution region, 64 KiB |
/// | 5-6 | 0x20000 | settings store |
/// | 7 | 0x60000 | slot A |
/// | 8 | 0x80000 | slot B |
/// | 9-10 | 0xA0000 | boot record |
/// | 11 | 0xE0000 | free |
pub const STM32F4: FlashMap = FlashMap {
    store: Region { base: 0x2_0000, len: 0x4_0000 },
    records: Region { base: 0xA_0000, len: 0x4_0000 },
    slots: [Region { base: 0x6_0000, len: 0x2_0000 }, Region { base: 0x8_0000, len: 0x2_0000 }],
    exec: Region { base: STM32F4_FLASH + 0x1_0000, len: 0x1_0000 },
};

/// The STM32F405's flash as a CPU address.
pub const STM32F4_FLASH: u32 = 0x0800_0000;

/// Where the bootloaders are, as CPU addresses.
pub const BOOTLOADER: [(&str, Region); 2] =
    [("qemu", Region { base: 0, len: 0x8000 }), ("stm32f4", Region { base: STM32F4_FLASH, len: 0x8000 })];

#[cfg(test)]
mod tests {
    use super::*;

    /// The `FLASH` origin and length a memory layout file gives.
    fn flash_of(layout: &str) -> Region {
        let line = layout.lines().find(|l| l.trim_start().starts_with("FLASH")).unwrap();
        let field = |name: &str| line.split(name).nth(1).unwrap().split([',', ' ']).find(|s| !s.is_empty()).unwrap();
        let base = u32::from_str_radix(field("ORIGIN = ").trim_start_matches("0x"), 16).unwrap();
        let len = field("LENGTH = ").trim_end_matches('K').parse::<u32>().unwrap() * 1024;
        Region { base, len }
    }

    #[test]
    fn the_linked_layouts_match_the_map() {
        assert_eq!(flash_of(include_str!("../memory/qemu.x")), QEMU.exec);
        assert_eq!(flash_of(include_str!("../memory/stm32f4.x")), STM32F4.exec);
        assert_eq!(flash_of(include_str!("../memory/qemu-boot.x")), BOOTLOADER[0].1);
        assert_eq!(flash_of(include_str!("../memory/stm32f4-boot.x")), BOOTLOADER[1].1);
    }

    #[test]
    fn regions_do_not_overlap_and_fit_their_flash() {
        let exec = |m: &FlashMap, flash: u32| Region { base: m.exec.base - flash, len: m.exec.len };
        for (map, flash, capacity, boot) in [
            (QEMU, None, QEMU_FILE_LEN, None),
            (STM32F4, Some(STM32F4_FLASH), 1024 * 1024, Some(Region { base: 0, len: BOOTLOADER[1].1.len })),
        ] {
            let mut regions = vec![map.store, map.records, map.slots[0], map.slots[1]];
            regions.extend(flash.map(|f| exec(&map, f)));
            regions.extend(boot);
            regions.sort_by_key(|r| r.base);
            assert!(regions.windows(2).all(|w| w[0].end() <= w[1].base), "{regions:?}");
            assert!(regions.iter().all(|r| r.end() <= capacity));
            // A slot holds the longest body the execution region runs, and its header.
            let header = skin_protocol::image::HEADER_LEN as u32;
            assert!(map.slots.iter().all(|s| s.len >= map.exec.len + header));
        }
        assert!(BOOTLOADER[0].1.end() <= QEMU.exec.base);
    }
}
