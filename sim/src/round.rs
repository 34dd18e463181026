//! Rounding and truncation to integers as `f64::round` and `f64::trunc`
//! do, bit for bit, but without the call into libm that x86-64's baseline
//! instruction set makes of them, and without a branch on the fraction
//! (sensor noise makes it a coin toss): readings, datagram times and the
//! stimulus's phase are rounded on every event of the network simulator
//! (3% of a clock-driven HRP-2 run).

/// Below this magnitude an `f64` may have a fraction, and fits an `i64`.
const FRACTIONAL_BELOW: f64 = 4_503_599_627_370_496.0; // 2^52

/// `v.trunc()`, bit for bit: through `i64` below 2^52, where that is exact;
/// beyond, `v` is already an integer (or infinite, or NaN).
pub fn trunc(v: f64) -> f64 {
    if v.abs() < FRACTIONAL_BELOW {
        (v as i64 as f64).copysign(v)
    } else {
        v.trunc()
    }
}

/// `v.round()`, bit for bit: adding just under a half, away from zero,
/// and truncating is exact (beyond 2^52 the sum is `v` itself).
pub fn round(v: f64) -> f64 {
    trunc(v + 0.499_999_999_999_999_94_f64.copysign(v))
}

#[cfg(test)]
mod tests {
    use super::*;

    proptest::proptest! {
        /// `round` is `f64::round`, bit for bit.
        #[test]
        fn round_is_f64_round(v: f64, w in -1e6f64..1e6, k in -1_000_000i64..1_000_000) {
            let half = k as f64 + 0.5;
            for x in [v, w, half, -half, k as f64, f64::from_bits(half.to_bits() + 1), f64::from_bits(half.to_bits() - 1)] {
                let (a, b) = (round(x), x.round());
                proptest::prop_assert!(a.to_bits() == b.to_bits() || a.is_nan() && b.is_nan(), "{x}: {a} != {b}");
            }
        }
    }

    proptest::proptest! {
        /// `trunc` is `f64::trunc`, bit for bit.
        #[test]
        fn trunc_is_f64_trunc(v: f64, w in -1e6f64..1e6) {
            for x in [v, w, -w, w.trunc()] {
                let (a, b) = (trunc(x), x.trunc());
                proptest::prop_assert!(a.to_bits() == b.to_bits() || a.is_nan() && b.is_nan(), "{x}: {a} != {b}");
            }
        }
    }

    #[test]
    fn round_agrees_at_the_edges() {
        let two52 = 4_503_599_627_370_496.0;
        for x in
            [0.0, -0.0, 0.5, -0.5, 0.499_999_999_999_999_94, -0.3, 2.5, -2.5, two52 - 0.5, two52, -two52 - 1.0, 1e-300]
        {
            assert_eq!(round(x).to_bits(), x.round().to_bits(), "{x}");
        }
        assert!(round(f64::NAN).is_nan() && round(f64::INFINITY) == f64::INFINITY);
    }
}
