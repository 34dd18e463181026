//! CDR, the serialization of ROS 2 messages on every RMW and in MCAP
//! files: plain XCDR1, little endian, after a 4-byte encapsulation header
//! (`00 01 00 00`). Every primitive is aligned to its size counted from the
//! end of that header; strings are a `u32` length with the NUL, the bytes
//! and the NUL; sequences a `u32` count and the elements.

/// The encapsulation header of little-endian plain CDR.
pub const ENCAPSULATION_LE: [u8; 4] = [0x00, 0x01, 0x00, 0x00];

/// A CDR message being written.
#[derive(Debug)]
pub struct Cdr {
    buf: Vec<u8>,
}

impl Default for Cdr {
    fn default() -> Self {
        Cdr::new()
    }
}

impl Cdr {
    /// An empty message: the encapsulation header only.
    pub fn new() -> Cdr {
        Cdr { buf: ENCAPSULATION_LE.to_vec() }
    }

    /// An empty message in `buf`'s allocation.
    pub fn reusing(mut buf: Vec<u8>) -> Cdr {
        buf.clear();
        buf.extend_from_slice(&ENCAPSULATION_LE);
        Cdr { buf }
    }

    /// The message bytes, header included.
    pub fn into_bytes(self) -> Vec<u8> {
        self.buf
    }

    /// Pads to a multiple of `n` bytes after the encapsulation header.
    fn align(&mut self, n: usize) {
        let body = self.buf.len() - ENCAPSULATION_LE.len();
        self.buf.resize(self.buf.len() + (n - body % n) % n, 0);
    }

    /// A primitive of `N` bytes, aligned to `N`.
    fn put<const N: usize>(&mut self, bytes: [u8; N]) {
        self.align(N);
        self.buf.extend_from_slice(&bytes);
    }

    /// A `bool`.
    pub fn bool(&mut self, v: bool) {
        self.buf.push(u8::from(v));
    }

    /// A `uint8` (also `byte` and `char`).
    pub fn u8(&mut self, v: u8) {
        self.buf.push(v);
    }

    /// A `uint32`.
    pub fn u32(&mut self, v: u32) {
        self.put(v.to_le_bytes());
    }

    /// An `int32`.
    pub fn i32(&mut self, v: i32) {
        self.put(v.to_le_bytes());
    }

    /// A `float32`.
    pub fn f32(&mut self, v: f32) {
        self.put(v.to_le_bytes());
    }

    /// A `float64`.
    pub fn f64(&mut self, v: f64) {
        self.put(v.to_le_bytes());
    }

    /// A `string`: its length counts the terminating NUL.
    pub fn string(&mut self, s: &str) {
        self.len(s.len() + 1);
        self.buf.extend_from_slice(s.as_bytes());
        self.buf.push(0);
    }

    /// The count that starts a sequence.
    pub fn len(&mut self, n: usize) {
        // A message holding more than 4 G elements cannot exist: the
        // count saturates rather than wraps, and a reader rejects it.
        self.u32(u32::try_from(n).unwrap_or(u32::MAX));
    }

    /// A `uint8[]`.
    pub fn bytes(&mut self, v: &[u8]) {
        self.len(v.len());
        self.buf.extend_from_slice(v);
    }

    /// A `float64[]`.
    pub fn f64s(&mut self, v: &[f64]) {
        self.len(v.len());
        v.iter().for_each(|x| self.f64(*x));
    }

    /// A `string[]`.
    pub fn strings<S: AsRef<str>>(&mut self, v: &[S]) {
        self.len(v.len());
        v.iter().for_each(|s| self.string(s.as_ref()));
    }
}

/// Why CDR bytes could not be read.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum CdrError {
    /// Not little-endian plain CDR (or shorter than its header).
    #[error("not little-endian CDR: encapsulation header missing or of another kind")]
    Encapsulation,
    /// The message ends before a field does.
    #[error("the message ends inside a field at byte {0}")]
    Truncated(usize),
    /// A string without its NUL or not UTF-8.
    #[error("a string at byte {0} is not NUL-terminated UTF-8")]
    BadString(usize),
}

/// A CDR message being read; every read checks the bounds.
#[derive(Debug)]
pub struct CdrReader<'a> {
    buf: &'a [u8],
    at: usize,
}

impl<'a> CdrReader<'a> {
    /// Checks the encapsulation header.
    pub fn new(buf: &'a [u8]) -> Result<CdrReader<'a>, CdrError> {
        // The options bytes (2..4) carry padding counts some writers set.
        if buf.len() < 4 || buf[..2] != ENCAPSULATION_LE[..2] {
            return Err(CdrError::Encapsulation);
        }
        Ok(CdrReader { buf, at: 4 })
    }

    fn take(&mut self, n: usize, align: usize) -> Result<&'a [u8], CdrError> {
        let body = self.at - ENCAPSULATION_LE.len();
        let start = self.at + (align - body % align) % align;
        let end = start.checked_add(n).filter(|&e| e <= self.buf.len()).ok_or(CdrError::Truncated(self.at))?;
        self.at = end;
        Ok(&self.buf[start..end])
    }

    /// A `uint32`.
    pub fn u32(&mut self) -> Result<u32, CdrError> {
        let b = self.take(4, 4)?;
        Ok(u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
    }

    /// An `int32`.
    pub fn i32(&mut self) -> Result<i32, CdrError> {
        self.u32().map(|v| v as i32)
    }

    /// A `uint8[]`.
    pub fn bytes(&mut self) -> Result<&'a [u8], CdrError> {
        let n = self.u32()? as usize;
        self.take(n, 1)
    }

    /// A `string`.
    pub fn string(&mut self) -> Result<&'a str, CdrError> {
        let at = self.at;
        match self.bytes()? {
            [text @ .., 0] => std::str::from_utf8(text).map_err(|_| CdrError::BadString(at)),
            _ => Err(CdrError::BadString(at)),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn alignment_counts_from_the_end_of_the_header() {
        let mut c = Cdr::new();
        c.u8(7);
        c.f64(1.0);
        c.string("ab");
        c.bool(true);
        c.u32(5);
        let b = c.into_bytes();
        assert_eq!(&b[..4], &ENCAPSULATION_LE);
        assert_eq!(b[4], 7);
        assert_eq!(&b[5..12], &[0; 7], "a float64 is aligned to 8 within the body");
        assert_eq!(&b[12..20], &1.0f64.to_le_bytes());
        assert_eq!(&b[20..27], &[3, 0, 0, 0, b'a', b'b', 0]);
        assert_eq!(b[27], 1);
        assert_eq!(&b[28..32], &5u32.to_le_bytes(), "already aligned: no padding");
        assert_eq!(b.len(), 32);
    }

    proptest::proptest! {
        #[test]
        fn any_bytes_read_or_fail_typed(bytes in proptest::collection::vec(proptest::prelude::any::<u8>(), 0..64)) {
            if let Ok(mut r) = CdrReader::new(&bytes) {
                let _ = r.i32().and_then(|_| r.string()).and_then(|_| r.bytes());
            }
        }

        #[test]
        fn what_is_written_reads_back(n in proptest::prelude::any::<i32>(), s in "[a-z]{0,20}", b in proptest::collection::vec(proptest::prelude::any::<u8>(), 0..40)) {
            let mut c = Cdr::new();
            c.u8(1);
            c.i32(n);
            c.string(&s);
            c.bytes(&b);
            let bytes = c.into_bytes();
            let mut r = CdrReader::new(&bytes).unwrap();
            r.take(1, 1).unwrap();
            proptest::prop_assert_eq!((r.i32().unwrap(), r.string().unwrap(), r.bytes().unwrap()), (n, s.as_str(), b.as_slice()));
            proptest::prop_assert_eq!(r.i32(), Err(CdrError::Truncated(bytes.len())));
        }
    }
}
