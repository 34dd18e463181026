//! Reading a whole file under a cap (std only).
//!
//! Every file the programs read whole (configurations, parameters, skin and
//! topology files, robot descriptions, firmware images, recordings) goes
//! through here, so a wrong path such as `/dev/zero` or a file grown past
//! any use is refused naming the cap instead of filling memory. The read is
//! bounded by `take`, not by the file's reported size: a device or a pipe
//! says 0 and then never ends.

use std::io::{Error, ErrorKind, Read};
use std::path::Path;

/// One mebibyte, the unit caps are written in.
pub const MIB: usize = 1 << 20;

/// The bytes of the file at `path`; an [`ErrorKind::FileTooLarge`] error
/// naming the cap when it holds more than `max_bytes`.
pub fn read_capped(path: &Path, max_bytes: usize) -> Result<Vec<u8>, Error> {
    let mut bytes = Vec::new();
    std::fs::File::open(path)?.take(max_bytes as u64 + 1).read_to_end(&mut bytes)?;
    if bytes.len() > max_bytes {
        return Err(Error::new(
            ErrorKind::FileTooLarge,
            format!("larger than {}, the most read here", size(max_bytes)),
        ));
    }
    Ok(bytes)
}

/// The text of the file at `path`, as [`read_capped`]; an
/// [`ErrorKind::InvalidData`] error when it is not UTF-8.
pub fn read_text_capped(path: &Path, max_bytes: usize) -> Result<String, Error> {
    String::from_utf8(read_capped(path, max_bytes)?)
        .map_err(|e| Error::new(ErrorKind::InvalidData, format!("not UTF-8 text: {}", e.utf8_error())))
}

/// `bytes` for people: whole MiB where it is, bytes otherwise.
fn size(bytes: usize) -> String {
    if bytes >= MIB && bytes.is_multiple_of(MIB) {
        format!("{} MiB", bytes / MIB)
    } else {
        format!("{bytes} bytes")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_endless_device_is_refused_naming_the_cap() {
        let e = read_capped(Path::new("/dev/zero"), MIB).unwrap_err();
        assert_eq!(e.kind(), ErrorKind::FileTooLarge);
        assert_eq!(e.to_string(), "larger than 1 MiB, the most read here");
    }

    #[test]
    fn a_file_at_the_cap_is_read_and_one_byte_more_is_not() {
        let path = std::env::temp_dir().join(format!("skin-protocol-file-{}", std::process::id()));
        std::fs::write(&path, [b'a'; 10]).unwrap();
        assert_eq!(read_text_capped(&path, 10).unwrap(), "aaaaaaaaaa");
        let e = read_text_capped(&path, 9).unwrap_err();
        assert_eq!(e.to_string(), "larger than 9 bytes, the most read here");
        std::fs::write(&path, [0xff, 0xfe]).unwrap();
        assert_eq!(read_text_capped(&path, 10).unwrap_err().kind(), ErrorKind::InvalidData);
        std::fs::remove_file(&path).unwrap();
    }
}
