//! A message already in CDR, handed to a serde-based DDS writer as it is.
//!
//! RustDDS serializes a sample with serde into little-endian CDR after
//! its own `00 01 00 00` header. [`RawCdr`] serializes as a tuple of its
//! body's bytes (tuples carry no length in CDR, and a byte needs no
//! alignment), so the wire carries exactly the bytes [`crate::ros::cdr`]
//! wrote, aligned as they were: both count alignment from the end of the
//! same header.

use serde::ser::{Serialize, SerializeTuple, Serializer};

use crate::ros::cdr::ENCAPSULATION_LE;

/// The body of a little-endian CDR message (after the encapsulation header).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct RawCdr(Vec<u8>);

impl RawCdr {
    /// The body of `cdr` (a whole message, header first), or `None` when
    /// its header is not little-endian plain CDR, the only encoding the
    /// writer's header can announce.
    pub fn from_message(cdr: &[u8]) -> Option<RawCdr> {
        let (header, body) = cdr.split_at_checked(ENCAPSULATION_LE.len())?;
        (header[..2] == ENCAPSULATION_LE[..2]).then(|| RawCdr(body.to_vec()))
    }
}

impl Serialize for RawCdr {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        let mut tuple = serializer.serialize_tuple(self.0.len())?;
        for b in &self.0 {
            tuple.serialize_element(b)?;
        }
        tuple.end()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ros::cdr::Cdr;

    #[test]
    fn the_body_goes_out_byte_for_byte() {
        let mut cdr = Cdr::new();
        cdr.u8(7);
        cdr.f64(1.5);
        cdr.string("skin");
        let message = cdr.into_bytes();
        let raw = RawCdr::from_message(&message).unwrap();
        let mut out = Vec::new();
        rustdds::serialization::to_writer_with_rep_id(&mut out, &raw, rustdds::RepresentationIdentifier::CDR_LE)
            .unwrap();
        assert_eq!(out, message[4..]);
    }

    #[test]
    fn a_big_endian_or_short_message_is_refused() {
        assert_eq!(RawCdr::from_message(&[0, 0, 0, 0, 1]), None);
        assert_eq!(RawCdr::from_message(&[0, 1]), None);
        assert_eq!(RawCdr::from_message(&[0, 1, 0, 0]), Some(RawCdr(Vec::new())));
    }
}
