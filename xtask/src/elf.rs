//! Flash and RAM use of a 32-bit little-endian ELF file, from its section
//! headers (what `size` reports), and its flash contents as one flat binary
//! (what `objcopy -O binary` writes), without needing binutils.

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

const PT_LOAD: u32 = 1;

/// The bytes loaded into flash, from the lowest load address to the end of
/// the highest, gaps zero-filled: the program a bootloader copies or starts.
/// Returns the load address and the bytes.
pub fn flat_binary(b: &[u8]) -> Result<(u32, Vec<u8>), String> {
    size(b)?;
    let phoff = u32_at(b, 0x1C)? as usize;
    let phentsize = usize::from(u16_at(b, 0x2A)?);
    let phnum = usize::from(u16_at(b, 0x2C)?);
    if phnum > 0 && phentsize < 32 {
        return Err(format!("program header entries of {phentsize} bytes"));
    }
    let mut loads = Vec::new();
    for i in 0..phnum {
        let h = phoff + i * phentsize;
        let (kind, offset, paddr, filesz) = (u32_at(b, h)?, u32_at(b, h + 4)?, u32_at(b, h + 12)?, u32_at(b, h + 16)?);
        if kind == PT_LOAD && filesz > 0 {
            let bytes = b.get(offset as usize..offset as usize + filesz as usize).ok_or("truncated ELF segment")?;
            loads.push((paddr, bytes));
        }
    }
    let start = loads.iter().map(|(at, _)| *at).min().ok_or("no loadable segment")?;
    let end = loads.iter().map(|(at, bytes)| u64::from(*at) + bytes.len() as u64).max().unwrap_or(0);
    let mut flat = vec![0u8; usize::try_from(end - u64::from(start)).map_err(|_| "segments too far apart")?];
    for (at, bytes) in loads {
        let from = (at - start) as usize;
        flat[from..from + bytes.len()].copy_from_slice(bytes);
    }
    Ok((start, flat))
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

    /// `image()` with two loadable segments: 4 bytes at 0x100 and 2 at
    /// 0x108 (a gap of 4), and one empty (bss-like) segment.
    fn loadable() -> Vec<u8> {
        let mut b = image();
        let phoff = b.len() as u32;
        b[0x1C..0x20].copy_from_slice(&phoff.to_le_bytes());
        b[0x2A..0x2C].copy_from_slice(&32u16.to_le_bytes());
        b[0x2C..0x2E].copy_from_slice(&3u16.to_le_bytes());
        let data = phoff + 3 * 32;
        for (offset, paddr, filesz) in [(data, 0x100u32, 4u32), (data + 4, 0x108, 2), (0, 0x2000_0000, 0)] {
            let mut h = [0u8; 32];
            h[..4].copy_from_slice(&PT_LOAD.to_le_bytes());
            h[4..8].copy_from_slice(&offset.to_le_bytes());
            h[12..16].copy_from_slice(&paddr.to_le_bytes());
            h[16..20].copy_from_slice(&filesz.to_le_bytes());
            b.extend_from_slice(&h);
        }
        b.extend_from_slice(&[1, 2, 3, 4, 5, 6]);
        b
    }

    #[test]
    fn the_flat_binary_places_segments_at_their_load_addresses() {
        assert_eq!(flat_binary(&loadable()), Ok((0x100, vec![1, 2, 3, 4, 0, 0, 0, 0, 5, 6])));
        assert_eq!(flat_binary(&image()), Err("no loadable segment".to_string()));
        let mut cut = loadable();
        cut.truncate(cut.len() - 1);
        assert_eq!(flat_binary(&cut), Err("truncated ELF segment".to_string()));
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
