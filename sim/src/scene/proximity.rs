//! The VCNL4010 proximity sensor: reflected infrared intensity against
//! distance.
//!
//! The intensity falls with the square of the distance far away and
//! saturates at contact: `I(d) = r / (r + (d / d0)^2)` with `r = R cos^2(a)`
//! for a target of reflectance `R` (1 for skin) seen at angle `a` off the
//! sensor axis. So a dark target reads less from afar but any target
//! saturates the sensor when it touches the window. `d0` is set so that the
//! Table 3/4 threshold of 0.01 is crossed 5 cm from a hand, where the
//! paper's proximity guidance starts to react; for skin close contact
//! (0.80) is then 2.5 mm, low proximity (0.10) 15 mm. The range is 1-200 mm
//! (16 bit); at 200 mm a hand reads about 40 counts, well above the noise.

use rand::Rng;
use rand_distr::{Distribution, Normal};
use skin_protocol::sample::PROXIMITY_MAX;

/// A VCNL4010 model.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Vcnl4010 {
    /// Distance at which a skin-like target reads half scale, m.
    pub half_distance_m: f64,
    /// Largest distance the sensor sees anything at, m.
    pub range_m: f64,
    /// Standard deviation of the reading noise, counts.
    pub noise_counts: f64,
}

impl Default for Vcnl4010 {
    fn default() -> Vcnl4010 {
        Vcnl4010 { half_distance_m: 0.05 / 99f64.sqrt(), range_m: 0.2, noise_counts: 3.0 }
    }
}

impl Vcnl4010 {
    /// Normalized intensity of a target at `distance_m` along a direction
    /// with cosine `cos_axis` to the sensor axis.
    pub fn intensity(&self, distance_m: f64, cos_axis: f64, reflectance: f64) -> f64 {
        if distance_m > self.range_m || cos_axis <= 0.0 {
            return 0.0;
        }
        let x = distance_m.max(0.0) / self.half_distance_m;
        let r = (reflectance * cos_axis * cos_axis).max(0.0);
        if r == 0.0 {
            return 0.0;
        }
        (r / (r + x * x)).clamp(0.0, 1.0)
    }

    /// Distance at which a skin-like target straight ahead reads
    /// `intensity`, m.
    pub fn distance_for(&self, intensity: f64) -> f64 {
        self.half_distance_m * (1.0 / intensity - 1.0).max(0.0).sqrt()
    }

    /// 16-bit counts of an intensity, with noise.
    pub fn counts(&self, intensity: f64, rng: &mut impl Rng) -> u16 {
        let noise = Normal::new(0.0, self.noise_counts.max(0.0)).map_or(0.0, |n| n.sample(rng));
        (intensity * f64::from(PROXIMITY_MAX) + noise).round().clamp(0.0, f64::from(PROXIMITY_MAX)) as u16
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn table_levels_fall_at_plausible_distances() {
        let s = Vcnl4010::default();
        assert!((s.intensity(0.05, 1.0, 1.0) - 0.01).abs() < 1e-12, "threshold 0.01 at 5 cm");
        for (level, mm) in [(0.80, 2.5), (0.10, 15.1), (0.02, 35.2), (0.01, 50.0)] {
            assert!((s.distance_for(level) * 1e3 - mm).abs() < 0.1, "{level} at {} mm", s.distance_for(level) * 1e3);
        }
        assert!(s.intensity(0.001, 1.0, 1.0) > 0.95);
        assert_eq!(s.intensity(0.25, 1.0, 1.0), 0.0, "out of range");
        assert_eq!(s.intensity(0.01, -0.2, 1.0), 0.0, "behind the sensor");
        // From afar, a target 60 degrees off the axis reads a quarter, a
        // target of half the reflectance half; at contact both saturate.
        let far = s.intensity(0.1, 1.0, 1.0);
        assert!((s.intensity(0.1, 0.5, 1.0) / far - 0.25).abs() < 0.01);
        assert!((s.intensity(0.1, 1.0, 0.5) / far - 0.5).abs() < 0.01);
        assert!(s.intensity(0.0, 1.0, 0.3) > 0.99 && s.intensity(0.001, 1.0, 0.5) > 0.9);
        let counts_at_200mm = s.intensity(0.2, 1.0, 1.0) * 65535.0;
        assert!(counts_at_200mm > 30.0 && counts_at_200mm < 60.0, "{counts_at_200mm}");
    }
}
