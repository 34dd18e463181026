//! The attachment rmw_zenoh puts on every message (`attachment_helpers.cpp`):
//! the publisher's sequence number, the source timestamp and the
//! publisher's GID, in zenoh-ext's serialization (two little-endian
//! `i64`, then the 16 GID bytes behind their length as a LEB128 varint).

/// Bytes of one attachment.
pub const LEN: usize = 8 + 8 + 1 + 16;

/// The attachment of message `sequence` (from 1) sent at `timestamp_ns`
/// (since the Unix epoch) by the publisher `gid`.
pub fn encode(sequence: i64, timestamp_ns: i64, gid: [u8; 16]) -> [u8; LEN] {
    let mut out = [0; LEN];
    out[..8].copy_from_slice(&sequence.to_le_bytes());
    out[8..16].copy_from_slice(&timestamp_ns.to_le_bytes());
    out[16] = 16;
    out[17..].copy_from_slice(&gid);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn zenoh_ext_reads_what_we_write() {
        let gid: [u8; 16] = std::array::from_fn(|i| i as u8 * 17);
        let bytes = encode(42, -3, gid);
        let payload = zenoh::bytes::ZBytes::from(bytes.to_vec());
        let mut reader = zenoh_ext::ZDeserializer::new(&payload);
        assert_eq!(reader.deserialize::<i64>().unwrap(), 42);
        assert_eq!(reader.deserialize::<i64>().unwrap(), -3);
        assert_eq!(reader.deserialize::<[u8; 16]>().unwrap(), gid);
        assert!(reader.done());
    }
}
