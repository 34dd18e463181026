//! Where an object is put down between the arms.
//!
//! The experiment's default spot is centred between the arms, the object's
//! back [`OBJECT_GAP_M`] in front of the chest's skin (the experiment's
//! `object_pose`); a placement moves it from there and
//! turns it about the vertical. Users never put things exactly in the
//! middle, so a seeded jitter draws placements within a stated envelope.

use nalgebra::Vector3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::object::Object;
use super::object_error::ObjectError;

/// Gap between the object and the chest's skin when it is put down at
/// the default spot, m.
pub const OBJECT_GAP_M: f64 = 0.02;

/// Largest offset along any axis an object file or flag may give, m: past
/// this the object is out of the arms' reach.
pub const MAX_OFFSET_M: f64 = 0.5;

/// The envelope of [`Placement::jitter`]: sideways offset, m, either way.
pub const JITTER_SIDEWAYS_M: f64 = 0.03;
/// The envelope of [`Placement::jitter`]: forward offset (away from the
/// chest), m, from 0 to this.
pub const JITTER_FORWARD_M: f64 = 0.02;
/// The envelope of [`Placement::jitter`]: yaw, rad, either way.
pub const JITTER_YAW_RAD: f64 = 0.3;

/// A move from the default spot.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Placement {
    /// Forward (away from the chest), left and up, m.
    pub offset_m: Vector3<f64>,
    /// Turn about the vertical, rad (positive: counter-clockwise seen from above).
    pub yaw_rad: f64,
}

impl Placement {
    /// A placement drawn uniformly within the jitter envelope.
    pub fn jitter(rng: &mut impl Rng) -> Placement {
        Placement {
            offset_m: Vector3::new(
                rng.random_range(0.0..=JITTER_FORWARD_M),
                rng.random_range(-JITTER_SIDEWAYS_M..=JITTER_SIDEWAYS_M),
                0.0,
            ),
            yaw_rad: rng.random_range(-JITTER_YAW_RAD..=JITTER_YAW_RAD),
        }
    }

    /// One jittered placement per object, the same for the same `seed`.
    pub fn jitters(seed: u64, count: usize) -> Vec<Placement> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        (0..count).map(|_| Placement::jitter(&mut rng)).collect()
    }

    /// Checks the placement can be carried out: finite, within reach, not
    /// into the chest, a yaw within half a turn either way.
    pub fn check(&self) -> Result<(), ObjectError> {
        for (axis, v) in ["offset_m[0]", "offset_m[1]", "offset_m[2]"].into_iter().zip(self.offset_m.iter()) {
            in_range(axis, *v, -MAX_OFFSET_M, MAX_OFFSET_M, "an offset in [-0.5, 0.5] m")?;
        }
        let back = -OBJECT_GAP_M;
        in_range(
            "offset_m[0]",
            self.offset_m.x,
            back,
            MAX_OFFSET_M,
            "at least -0.02 m (further back is inside the chest)",
        )?;
        let pi = std::f64::consts::PI;
        in_range("yaw_rad", self.yaw_rad, -pi, pi, "an angle in [-pi, pi] rad")
    }
}

/// An object and where it is put down.
#[derive(Clone, Debug, PartialEq)]
pub struct ObjectAt {
    /// The object.
    pub object: Object,
    /// Where, from the default spot.
    pub placement: Placement,
}

/// `Ok` when `lo <= v <= hi` (so never for NaN); else the key, value and range.
pub(super) fn in_range(key: &str, v: f64, lo: f64, hi: f64, expected: &'static str) -> Result<(), ObjectError> {
    if (lo..=hi).contains(&v) {
        Ok(())
    } else {
        Err(ObjectError::Range { key: key.to_owned(), value: v, expected })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn jitter_stays_in_its_envelope_and_repeats_with_its_seed() {
        let a = Placement::jitters(7, 200);
        assert_eq!(a, Placement::jitters(7, 200));
        assert_ne!(a, Placement::jitters(8, 200));
        for p in &a {
            p.check().unwrap();
            assert!((0.0..=JITTER_FORWARD_M).contains(&p.offset_m.x));
            assert!(p.offset_m.y.abs() <= JITTER_SIDEWAYS_M && p.offset_m.z == 0.0);
            assert!(p.yaw_rad.abs() <= JITTER_YAW_RAD);
        }
        // Both sides are drawn.
        assert!(a.iter().any(|p| p.offset_m.y < -0.02) && a.iter().any(|p| p.offset_m.y > 0.02));
    }

    #[test]
    fn impossible_placements_name_the_key() {
        let cases = [
            (Vector3::new(-0.05, 0.0, 0.0), 0.0, "offset_m[0]"),
            (Vector3::new(0.0, 0.7, 0.0), 0.0, "offset_m[1]"),
            (Vector3::new(0.0, 0.0, f64::NAN), 0.0, "offset_m[2]"),
            (Vector3::zeros(), 4.0, "yaw_rad"),
            (Vector3::zeros(), f64::INFINITY, "yaw_rad"),
        ];
        for (offset_m, yaw_rad, key) in cases {
            let e = Placement { offset_m, yaw_rad }.check().unwrap_err();
            assert!(e.to_string().contains(key), "{e}");
        }
    }
}
