//! Intel HEX, the format `probe-rs download --binary-format hex` takes:
//! several pieces of flash at their addresses in one file, with nothing
//! in between (a flat binary from the bootloader to slot A would be
//! 384 KiB of padding that the probe would program).

/// Data bytes per record.
const LINE: usize = 16;

fn record(kind: u8, offset: u16, data: &[u8]) -> String {
    let mut bytes = vec![data.len() as u8, (offset >> 8) as u8, offset as u8, kind];
    bytes.extend_from_slice(data);
    let sum = bytes.iter().fold(0u8, |s, b| s.wrapping_add(*b));
    bytes.push(sum.wrapping_neg());
    let hex: String = bytes.iter().map(|b| format!("{b:02X}")).collect();
    format!(":{hex}\n")
}

/// `pieces` (address, bytes) as Intel HEX, with 32-bit addresses
/// (extended linear address records); a piece must not cross 4 GiB.
pub fn encode(pieces: &[(u32, &[u8])]) -> String {
    let mut out = String::new();
    let mut upper = None;
    for (base, bytes) in pieces {
        for (i, line) in bytes.chunks(LINE).enumerate() {
            let at = base + (i * LINE) as u32;
            // A line never crosses a 64 KiB boundary: split it there.
            let split = (0x1_0000 - (at & 0xFFFF) as usize).min(line.len());
            for (at, part) in [(at, &line[..split]), (at + split as u32, &line[split..])] {
                if part.is_empty() {
                    continue;
                }
                if upper != Some(at >> 16) {
                    upper = Some(at >> 16);
                    out += &record(4, 0, &((at >> 16) as u16).to_be_bytes());
                }
                out += &record(0, at as u16, part);
            }
        }
    }
    out + &record(1, 0, &[])
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The bytes at each address a HEX file gives, checking every record's checksum.
    fn decode(text: &str) -> Vec<(u32, u8)> {
        let mut upper = 0u32;
        let mut bytes = Vec::new();
        for line in text.lines() {
            let raw: Vec<u8> =
                (1..line.len()).step_by(2).map(|i| u8::from_str_radix(&line[i..i + 2], 16).unwrap()).collect();
            assert_eq!(raw.iter().fold(0u8, |s, b| s.wrapping_add(*b)), 0, "checksum of {line}");
            let (len, offset, kind) = (usize::from(raw[0]), u32::from(raw[1]) << 8 | u32::from(raw[2]), raw[3]);
            let data = &raw[4..4 + len];
            match kind {
                0 => bytes.extend(data.iter().enumerate().map(|(i, b)| (upper + offset + i as u32, *b))),
                4 => upper = (u32::from(data[0]) << 8 | u32::from(data[1])) << 16,
                1 => break,
                other => panic!("record type {other}"),
            }
        }
        bytes
    }

    #[test]
    fn records_match_the_specification_examples() {
        // Intel's specification: an extended linear address record and the end of file.
        assert_eq!(record(4, 0, &[0x08, 0x00]), ":020000040800F2\n");
        assert_eq!(record(1, 0, &[]), ":00000001FF\n");
    }

    #[test]
    fn pieces_come_back_at_their_addresses() {
        let boot: Vec<u8> = (0..40u8).collect();
        let slot = [0xAB; 3];
        let text = encode(&[(0x0800_0000, &boot), (0x0806_0000, &slot), (0x080B_FFF8, &[7; 12])]);
        let mut want: Vec<(u32, u8)> = boot.iter().enumerate().map(|(i, b)| (0x0800_0000 + i as u32, *b)).collect();
        want.extend((0..3).map(|i| (0x0806_0000 + i, 0xAB)));
        want.extend((0..12).map(|i| (0x080B_FFF8 + i, 7)));
        assert_eq!(decode(&text), want);
        assert!(text.lines().all(|l| l.len() <= 1 + 2 * (5 + LINE)));
        assert!(text.ends_with(":00000001FF\n"));
    }
}
