//! Flash and RAM use of a 32-bit little-endian ELF file, from its section
//! headers: what `size` reports, without needing binutils on the machine.

/// Bytes an image takes.
#[derive(Debug, PartialEq, Eq)]
pub struct Size {
    /// Loaded sections with contents: code, read-only data, vectors, and the
    /// initial values of `.data`, which are copied from flash at boot.
    pub flash: u64,
    /// Writable loaded sections: `.data`, `.bss`, `.uninit`.
    pub ram: u64,
}

const SHF_WRITE: u32 = 0x1;
const SHF_ALLOC: u32 = 0x2;
const SHT_NOBITS: u32 = 8;

fn u16_at(b: &[u8], at: usize) -> Result<u16, String> {
    b.get(at..at + 2).map(|s| u16::from_le_bytes([s[0], s[1]])).ok_or_else(|| "truncated ELF".to_string())
}

fn u32_at(b: &[u8], at: usize) -> Result<u32, String> {
    b.get(at..at + 4).map(|s| u32::from_le_bytes([s[0], s[1], s[2], s[3]])).ok_or_else(|| "truncated ELF".to_string())
}

/// Sums the allocated sections of an ELF32 little-endian image.
pub fn size(b: &[u8]) -> Result<Size, String> {
    if b.get(..6) != Some(&[0x7F, b'E', b'L', b'F', 1, 1]) {
        return Err("not a 32-bit little-endian ELF file".into());
    }
    let shoff = u32_at(b, 0x20)? as usize;
    let shentsize = usize::from(u16_at(b, 0x2E)?);
    let shnum = usize::from(u16_at(b, 0x30)?);
    if shentsize < 40 {
        return Err(format!("section header entries of {shentsize} bytes"));
    }
    let mut size = Size { flash: 0, ram: 0 };
    for i in 0..shnum {
        let h = shoff + i * shentsize;
        let (kind, flags, bytes) = (u32_at(b, h + 4)?, u32_at(b, h + 8)?, u64::from(u32_at(b, h + 20)?));
        if flags & SHF_ALLOC == 0 {
            continue;
        }
        if kind != SHT_NOBITS {
            size.flash += bytes;
        }
        if flags & SHF_WRITE != 0 {
            size.ram += bytes;
        }
    }
    Ok(size)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A minimal ELF with three sections: text (alloc), data (alloc+write),
    /// bss (alloc+write, nobits), and one non-allocated section.
    fn image() -> Vec<u8> {
        let mut b = vec![0u8; 0x34];
        b[..6].copy_from_slice(&[0x7F, b'E', b'L', b'F', 1, 1]);
        b[0x20..0x24].copy_from_slice(&0x34u32.to_le_bytes());
        b[0x2E..0x30].copy_from_slice(&40u16.to_le_bytes());
        b[0x30..0x32].copy_from_slice(&4u16.to_le_bytes());
        for (kind, flags, bytes) in [(1u32, 0x6u32, 1000u32), (1, 0x3, 20), (8, 0x3, 300), (1, 0, 5000)] {
            let mut h = [0u8; 40];
            h[4..8].copy_from_slice(&kind.to_le_bytes());
            h[8..12].copy_from_slice(&flags.to_le_bytes());
            h[20..24].copy_from_slice(&bytes.to_le_bytes());
            b.extend_from_slice(&h);
        }
        b
    }

    #[test]
    fn sums_flash_and_ram_like_size_does() {
        assert_eq!(size(&image()), Ok(Size { flash: 1020, ram: 320 }));
    }

    #[test]
    fn rejects_what_is_not_an_elf32() {
        assert!(size(b"hello").is_err());
        let mut cut = image();
        cut.truncate(100);
        assert!(size(&cut).is_err());
    }
}
