//! The normal-force cells and the foam under the skin.
//!
//! Each skin cell has three force cells (Table 1: 0-10 N, 12 bit) under a
//! micro-structured cover, and the skin lies on a foam layer (section 6.4,
//! point ii): contact is a series of springs, foam and object, so forces
//! build up over millimetres, not micrometres, and the robot has time to
//! react. The foam bottoms out near full compression.
//!
//! Calibration: the paper gives two points of its force cells, 0.05 of full
//! scale at about 0.6 N and 0.14 at about 1.0 N, and the range 0-10 N. A
//! straight line through the two points crosses zero at 0.38 N, which we
//! read as the preload of the cover (light touches do not reach the
//! springs); above 1.0 N the curve runs straight to full scale at 10 N. So
//! the Table 3 levels are: low 0.04 = 0.56 N, medium 0.10 = 0.82 N, high
//! 0.30 = 2.67 N, pain 0.45 = 4.24 N.

use rand::Rng;
use rand_distr::{Distribution, Normal};
use skin_protocol::sample::FORCE_MAX;

/// The foam between robot and skin, per force cell.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Foam {
    /// Thickness, m.
    pub thickness_m: f64,
    /// Stiffness under one force cell, N/m.
    pub stiffness_n_per_m: f64,
    /// Compression (fraction of the thickness) where it bottoms out.
    pub bottom_fraction: f64,
    /// Stiffness once bottomed out, N/m.
    pub bottom_stiffness_n_per_m: f64,
}

impl Default for Foam {
    /// 5 mm of soft polyurethane foam: about 50 kPa over 1.5 cm^2.
    fn default() -> Foam {
        Foam { thickness_m: 0.005, stiffness_n_per_m: 1500.0, bottom_fraction: 0.8, bottom_stiffness_n_per_m: 30_000.0 }
    }
}

impl Foam {
    /// Force of a contact pressed `depth_m` into foam and an object of
    /// stiffness `object_n_per_m` in series, N.
    pub fn contact_force(&self, depth_m: f64, object_n_per_m: f64) -> f64 {
        if depth_m <= 0.0 {
            return 0.0;
        }
        let soft = 1.0 / self.stiffness_n_per_m + 1.0 / object_n_per_m;
        let knee_n = self.stiffness_n_per_m * self.thickness_m * self.bottom_fraction;
        let knee_depth = knee_n * soft;
        if depth_m <= knee_depth {
            depth_m / soft
        } else {
            knee_n + (depth_m - knee_depth) / (1.0 / self.bottom_stiffness_n_per_m + 1.0 / object_n_per_m)
        }
    }
}

/// Force to normalized reading: a piecewise-linear curve through knots.
#[derive(Clone, Debug, PartialEq)]
pub struct Calibration {
    knots: Vec<(f64, f64)>,
}

impl Default for Calibration {
    /// The paper's points: see the module documentation.
    fn default() -> Calibration {
        Calibration { knots: vec![(0.0, 0.0), (0.378, 0.0), (1.0, 0.14), (10.0, 1.0)] }
    }
}

impl Calibration {
    /// A curve through `(force_n, reading)` knots, both ascending (readings
    /// non-decreasing), readings within `[0, 1]`; `None` otherwise.
    pub fn new(knots: Vec<(f64, f64)>) -> Option<Calibration> {
        let ok = knots.len() >= 2
            && knots.iter().all(|(f, r)| f.is_finite() && (0.0..=1.0).contains(r))
            && knots.windows(2).all(|w| w[1].0 > w[0].0 && w[1].1 >= w[0].1);
        ok.then_some(Calibration { knots })
    }

    /// Normalized reading for a force, clamped to the curve's ends.
    pub fn reading(&self, force_n: f64) -> f64 {
        let k = &self.knots;
        if force_n <= k[0].0 {
            return k[0].1;
        }
        for w in k.windows(2) {
            let ((f0, r0), (f1, r1)) = (w[0], w[1]);
            if force_n <= f1 {
                return r0 + (r1 - r0) * (force_n - f0) / (f1 - f0);
            }
        }
        k[k.len() - 1].1
    }

    /// The smallest force giving `reading`, N (the inverse where it exists).
    pub fn force(&self, reading: f64) -> f64 {
        let k = &self.knots;
        for w in k.windows(2) {
            let ((f0, r0), (f1, r1)) = (w[0], w[1]);
            if reading <= r1 && r1 > r0 {
                return f0 + (f1 - f0) * ((reading - r0) / (r1 - r0)).max(0.0);
            }
        }
        k[k.len() - 1].0
    }
}

/// The three force cells of a skin cell.
#[derive(Clone, Debug, PartialEq)]
pub struct ForceCells {
    /// Distance of each force cell from the cell centre, m (120 degrees apart).
    pub radius_m: f64,
    /// Force to reading.
    pub calibration: Calibration,
    /// Standard deviation of the reading noise, counts.
    pub noise_counts: f64,
}

impl Default for ForceCells {
    fn default() -> ForceCells {
        ForceCells { radius_m: 0.007, calibration: Calibration::default(), noise_counts: 1.0 }
    }
}

impl ForceCells {
    /// Positions of the three force cells in the cell plane, m.
    pub fn positions(&self) -> [[f64; 2]; 3] {
        [0.0f64, 120.0, 240.0].map(|deg| {
            let a = deg.to_radians();
            [self.radius_m * a.cos(), self.radius_m * a.sin()]
        })
    }

    /// 12-bit counts of a force, with noise.
    pub fn counts(&self, force_n: f64, rng: &mut impl Rng) -> u16 {
        let noise = Normal::new(0.0, self.noise_counts.max(0.0)).map_or(0.0, |n| n.sample(rng));
        let c = self.calibration.reading(force_n) * f64::from(FORCE_MAX) + noise;
        c.round().clamp(0.0, f64::from(FORCE_MAX)) as u16
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    #[test]
    fn the_papers_calibration_points() {
        let c = Calibration::default();
        assert!((c.reading(1.0) - 0.14).abs() < 1e-12);
        assert!((c.reading(0.6) - 0.05).abs() < 1e-3);
        assert!((c.reading(10.0) - 1.0).abs() < 1e-12);
        assert_eq!(c.reading(0.2), 0.0);
        assert!((c.force(0.45) - 4.244).abs() < 1e-3, "pain at {} N", c.force(0.45));
        for r in [0.01, 0.05, 0.14, 0.3, 0.9] {
            assert!((c.reading(c.force(r)) - r).abs() < 1e-12);
        }
        assert!(Calibration::new(vec![(0.0, 0.0), (1.0, 1.2)]).is_none());
        assert!(Calibration::new(vec![(1.0, 0.0), (0.5, 0.1)]).is_none());
    }

    #[test]
    fn foam_and_object_are_springs_in_series() {
        let foam = Foam::default();
        // 1 mm into foam on a rigid object: 1.5 N; on an equally soft object: half.
        assert!((foam.contact_force(0.001, 1e12) - 1.5).abs() < 1e-6);
        assert!((foam.contact_force(0.001, 1500.0) - 0.75).abs() < 1e-9);
        assert_eq!(foam.contact_force(-0.001, 1500.0), 0.0);
        // Bottomed out, the force climbs steeply.
        let knee = foam.contact_force(0.004, 1e12);
        assert!(foam.contact_force(0.005, 1e12) - knee > 20.0);
    }

    #[test]
    fn counts_are_12_bit_with_noise() {
        let cells = ForceCells::default();
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1);
        let c: Vec<u16> = (0..100).map(|_| cells.counts(1.0, &mut rng)).collect();
        let mean = c.iter().map(|c| f64::from(*c)).sum::<f64>() / 100.0;
        assert!((mean - 0.14 * 4095.0).abs() < 1.0, "{mean}");
        assert!(c.iter().any(|x| *x != c[0]), "noisy");
        assert_eq!(cells.counts(50.0, &mut rng), FORCE_MAX);
    }
}
