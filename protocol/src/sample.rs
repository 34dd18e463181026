//! One multi-modal sensor sample of a cell, bit-packed to fit in one frame.
//!
//! The widths are the sensors' own (Table 1): proximity 16 bit (VCNL4010),
//! three normal forces 12 bit, acceleration 3 x 10 bit signed (BMA250),
//! temperature 14 bit signed (LM71). Together 96 bits, so a sample is 12
//! packed bytes plus a sequence number: 13 bytes, the whole frame payload.

use postcard::experimental::max_size::MaxSize;
use serde::{Deserialize, Serialize};

/// Largest proximity reading.
pub const PROXIMITY_MAX: u16 = u16::MAX;
/// Largest force reading (12 bit).
pub const FORCE_MAX: u16 = (1 << 12) - 1;
/// Acceleration range (10 bit two's complement).
pub const ACCEL_MIN: i16 = -(1 << 9);
/// Acceleration range (10 bit two's complement).
pub const ACCEL_MAX: i16 = (1 << 9) - 1;
/// Temperature range (14 bit two's complement, LM71: 0.03125 degC per count).
pub const TEMPERATURE_MIN: i16 = -(1 << 13);
/// Temperature range (14 bit two's complement).
pub const TEMPERATURE_MAX: i16 = (1 << 13) - 1;

/// Bit widths of the packed fields, in packing order.
const WIDTHS: [u32; 8] = [16, 12, 12, 12, 10, 10, 10, 14];

/// A sensor sample in raw sensor counts; every field within its sensor's width.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[serde(into = "Packed", try_from = "Packed")]
pub struct Sample {
    proximity: u16,
    force: [u16; 3],
    accel: [i16; 3],
    temperature: i16,
    seq: u8,
}

/// A field of a [`Sample`] outside the width of its sensor.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct OutOfRange;

impl core::fmt::Display for OutOfRange {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str("sensor value outside its sensor's bit width")
    }
}

impl Sample {
    /// A sample from raw counts, if every value fits its sensor's width.
    pub fn new(
        proximity: u16,
        force: [u16; 3],
        accel: [i16; 3],
        temperature: i16,
        seq: u8,
    ) -> Result<Sample, OutOfRange> {
        let ok = force.iter().all(|f| *f <= FORCE_MAX)
            && accel.iter().all(|a| (ACCEL_MIN..=ACCEL_MAX).contains(a))
            && (TEMPERATURE_MIN..=TEMPERATURE_MAX).contains(&temperature);
        ok.then_some(Sample { proximity, force, accel, temperature, seq }).ok_or(OutOfRange)
    }

    /// A sample from raw counts, each clamped into its sensor's range, as an
    /// ADC saturates.
    pub fn saturating(proximity: u16, force: [u16; 3], accel: [i16; 3], temperature: i16, seq: u8) -> Sample {
        Sample {
            proximity,
            force: force.map(|f| f.min(FORCE_MAX)),
            accel: accel.map(|a| a.clamp(ACCEL_MIN, ACCEL_MAX)),
            temperature: temperature.clamp(TEMPERATURE_MIN, TEMPERATURE_MAX),
            seq,
        }
    }

    /// Proximity intensity in counts (larger is closer).
    pub fn proximity(&self) -> u16 {
        self.proximity
    }
    /// The three normal-force readings in counts.
    pub fn force(&self) -> [u16; 3] {
        self.force
    }
    /// Acceleration x, y, z in counts of the configured range.
    pub fn accel(&self) -> [i16; 3] {
        self.accel
    }
    /// Temperature in LM71 counts.
    pub fn temperature(&self) -> i16 {
        self.temperature
    }
    /// Wrapping sample counter of the cell, to see losses and reordering.
    pub fn seq(&self) -> u8 {
        self.seq
    }

    /// Proximity normalized to `[0, 1]`, the unit of Table 3.
    pub fn proximity_norm(&self) -> f32 {
        f32::from(self.proximity) / f32::from(PROXIMITY_MAX)
    }
    /// Forces normalized to `[0, 1]`, the unit of Table 3.
    pub fn force_norm(&self) -> [f32; 3] {
        self.force.map(|f| f32::from(f) / f32::from(FORCE_MAX))
    }
    /// Temperature in degrees Celsius.
    pub fn temperature_c(&self) -> f32 {
        f32::from(self.temperature) * 0.031_25
    }

    /// The eight channels in packing order (proximity, 3 forces, 3 axes,
    /// temperature) as signed values, for filters that treat them alike.
    pub fn channels(&self) -> [i32; 8] {
        [
            i32::from(self.proximity),
            i32::from(self.force[0]),
            i32::from(self.force[1]),
            i32::from(self.force[2]),
            i32::from(self.accel[0]),
            i32::from(self.accel[1]),
            i32::from(self.accel[2]),
            i32::from(self.temperature),
        ]
    }

    fn pack(&self) -> [u8; 12] {
        let mut bits: u128 = 0;
        let mut at = 0;
        for (value, width) in self.channels().into_iter().zip(WIDTHS) {
            let mask = (1u128 << width) - 1;
            bits |= (value as u128 & mask) << at;
            at += width;
        }
        let mut out = [0; 12];
        out.copy_from_slice(&bits.to_le_bytes()[..12]);
        out
    }

    fn unpack(bytes: [u8; 12], seq: u8) -> Sample {
        let mut wide = [0u8; 16];
        wide[..12].copy_from_slice(&bytes);
        let bits = u128::from_le_bytes(wide);
        let mut v = [0i32; 8];
        let mut at = 0;
        for (i, (slot, width)) in v.iter_mut().zip(WIDTHS).enumerate() {
            let raw = ((bits >> at) & ((1u128 << width) - 1)) as u32;
            at += width;
            // Fields 4.. (acceleration, temperature) are signed: sign-extend.
            let shift = 32 - width;
            *slot = if i >= 4 { ((raw << shift) as i32) >> shift } else { raw as i32 };
        }
        // Every value was cut to its width above, so the casts are lossless.
        Sample {
            proximity: v[0] as u16,
            force: [v[1] as u16, v[2] as u16, v[3] as u16],
            accel: [v[4] as i16, v[5] as i16, v[6] as i16],
            temperature: v[7] as i16,
            seq,
        }
    }
}

/// The wire form of a sample: 96 packed bits and the sequence number.
#[derive(Clone, Copy, Serialize, Deserialize, MaxSize)]
struct Packed {
    bits: [u8; 12],
    seq: u8,
}

impl From<Sample> for Packed {
    fn from(s: Sample) -> Packed {
        Packed { bits: s.pack(), seq: s.seq }
    }
}

// Every 96-bit pattern is a valid sample; `TryFrom` keeps serde's
// `try_from` door open for checks that a later version may add.
impl TryFrom<Packed> for Sample {
    type Error = OutOfRange;
    fn try_from(p: Packed) -> Result<Sample, OutOfRange> {
        Ok(Sample::unpack(p.bits, p.seq))
    }
}

impl MaxSize for Sample {
    const POSTCARD_MAX_SIZE: usize = Packed::POSTCARD_MAX_SIZE;
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn any_sample() -> impl Strategy<Value = Sample> {
        (
            any::<u16>(),
            [0..=FORCE_MAX, 0..=FORCE_MAX, 0..=FORCE_MAX],
            [ACCEL_MIN..=ACCEL_MAX, ACCEL_MIN..=ACCEL_MAX, ACCEL_MIN..=ACCEL_MAX],
            TEMPERATURE_MIN..=TEMPERATURE_MAX,
            any::<u8>(),
        )
            .prop_map(|(p, f, a, t, s)| Sample::new(p, f, a, t, s).unwrap())
    }

    proptest! {
        #[test]
        fn packing_round_trips(s in any_sample()) {
            prop_assert_eq!(Sample::unpack(s.pack(), s.seq()), s);
        }

        #[test]
        fn any_bits_unpack_and_repack_identically(bits in any::<[u8; 12]>(), seq in any::<u8>()) {
            let s = Sample::unpack(bits, seq);
            prop_assert_eq!(s.pack(), bits);
        }
    }

    #[test]
    fn out_of_range_values_are_refused_or_clamped() {
        assert_eq!(Sample::new(0, [4096, 0, 0], [0; 3], 0, 0), Err(OutOfRange));
        assert_eq!(Sample::new(0, [0; 3], [512, 0, 0], 0, 0), Err(OutOfRange));
        assert_eq!(Sample::new(0, [0; 3], [0; 3], -8193, 0), Err(OutOfRange));
        let s = Sample::saturating(9, [5000, 1, 2], [-600, 600, 3], 9000, 7);
        assert_eq!(s.force(), [FORCE_MAX, 1, 2]);
        assert_eq!(s.accel(), [ACCEL_MIN, ACCEL_MAX, 3]);
        assert_eq!(s.temperature(), TEMPERATURE_MAX);
    }

    #[test]
    fn extremes_survive_packing() {
        let lo = Sample::new(0, [0; 3], [ACCEL_MIN; 3], TEMPERATURE_MIN, 0).unwrap();
        let hi = Sample::new(u16::MAX, [FORCE_MAX; 3], [ACCEL_MAX; 3], TEMPERATURE_MAX, 255).unwrap();
        for s in [lo, hi] {
            assert_eq!(Sample::unpack(s.pack(), s.seq()), s);
        }
        assert_eq!(Sample::POSTCARD_MAX_SIZE, 13);
    }
}
