//! The BMA250 accelerometer of a cell: equation (3) as a real sensor reports it.
//!
//! The specific force at the cell (gravity, tangential and centripetal
//! terms together, in the cell frame) goes through the chip's mounting
//! misalignment, per-axis sensitivity error and zero-g offset, its
//! first-order low-pass at the configured bandwidth, white noise, and 10-bit
//! quantization with saturation at the range. Each cell draws its own
//! offset, sensitivity and misalignment once, from the world's seed.

use nalgebra::{Rotation3, Vector3};
use rand::Rng;
use rand_distr::{Distribution, StandardNormal};
use skin_protocol::message::AccelRange;
use skin_protocol::sample::{ACCEL_MAX, ACCEL_MIN};

/// Standard gravity, m/s^2 (the protocol's).
pub use skin_protocol::message::G0;

/// Sensor parameters; the defaults are typical BMA250 datasheet values.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bma250Config {
    /// Measurement range.
    pub range: AccelRange,
    /// Output noise density, g per sqrt(Hz).
    pub noise_density_g_per_sqrt_hz: f64,
    /// Bandwidth of the on-chip low-pass, Hz (125 Hz gives a new value every 4 ms).
    pub bandwidth_hz: f64,
    /// Zero-g offset, uniform in +- this per axis, m/s^2 (+-60 mg).
    pub offset_max_mps2: f64,
    /// Sensitivity error, uniform in +- this fraction per axis.
    pub sensitivity_tolerance: f64,
    /// Mounting misalignment of the chip on the cell, up to this angle, rad.
    pub misalignment_max_rad: f64,
}

impl Default for Bma250Config {
    fn default() -> Self {
        Bma250Config {
            range: AccelRange::G2,
            noise_density_g_per_sqrt_hz: 0.5e-3,
            bandwidth_hz: 125.0,
            offset_max_mps2: 0.060 * G0,
            sensitivity_tolerance: 0.02,
            misalignment_max_rad: 1f64.to_radians(),
        }
    }
}

impl Bma250Config {
    /// A sensor without offset, sensitivity or alignment errors, and without noise.
    pub fn ideal() -> Self {
        Bma250Config {
            offset_max_mps2: 0.0,
            sensitivity_tolerance: 0.0,
            misalignment_max_rad: 0.0,
            ..Bma250Config::default().with_noise_scale(0.0)
        }
    }

    /// The same sensor with `scale` times the noise (0 for a noise-free one).
    pub fn with_noise_scale(self, scale: f64) -> Self {
        Bma250Config { noise_density_g_per_sqrt_hz: self.noise_density_g_per_sqrt_hz * scale, ..self }
    }

    /// RMS noise of one reading, m/s^2: the density over the equivalent noise
    /// bandwidth of a first-order low-pass, pi/2 times its cut-off.
    pub fn noise_rms_mps2(&self) -> f64 {
        self.noise_density_g_per_sqrt_hz * G0 * (std::f64::consts::FRAC_PI_2 * self.bandwidth_hz).sqrt()
    }
}

/// One cell's accelerometer.
#[derive(Clone, Debug)]
pub struct Bma250 {
    offset: Vector3<f64>,
    gain: Vector3<f64>,
    mount: Rotation3<f64>,
    filtered: Option<Vector3<f64>>,
    smoothing: f64,
    noise_rms: f64,
    counts_per_mps2: f64,
}

impl Bma250 {
    /// A sensor read every `period_s`, with its own errors drawn from `rng`.
    pub fn new(cfg: &Bma250Config, period_s: f64, rng: &mut impl Rng) -> Bma250 {
        let mut uniform = |max: f64| if max > 0.0 { rng.random_range(-max..=max) } else { 0.0 };
        let offset = Vector3::from_fn(|_, _| uniform(cfg.offset_max_mps2));
        let gain = Vector3::from_fn(|_, _| 1.0 + uniform(cfg.sensitivity_tolerance));
        let angle = uniform(cfg.misalignment_max_rad);
        let axis = Vector3::from_fn(|_, _| uniform(1.0));
        let mount = Rotation3::from_scaled_axis(axis.try_normalize(1e-9).unwrap_or_else(Vector3::x) * angle);
        Bma250 {
            offset,
            gain,
            mount,
            filtered: None,
            smoothing: 1.0 - (-std::f64::consts::TAU * cfg.bandwidth_hz * period_s).exp(),
            noise_rms: cfg.noise_rms_mps2(),
            counts_per_mps2: cfg.range.counts_per_g() / G0,
        }
    }

    /// Ground truth: the zero-g offset (m/s^2), per-axis gain and mounting
    /// rotation, `reading = gain * (mount * f) + offset` before filtering,
    /// noise and quantization.
    pub fn errors(&self) -> (Vector3<f64>, Vector3<f64>, Rotation3<f64>) {
        (self.offset, self.gain, self.mount)
    }

    /// The next reading, in counts, for the specific force `f` (m/s^2,
    /// cell frame: at rest it is minus gravity, +9.81 upward).
    pub fn sample(&mut self, f: &Vector3<f64>, rng: &mut impl Rng) -> [i16; 3] {
        let sensed = (self.mount * f).component_mul(&self.gain) + self.offset;
        let y = match self.filtered {
            Some(y) => y + (sensed - y) * self.smoothing,
            None => sensed,
        };
        self.filtered = Some(y);
        let mut out = [0; 3];
        for (o, v) in out.iter_mut().zip(y.iter()) {
            let n: f64 = StandardNormal.sample(rng);
            let noisy = v + self.noise_rms * n;
            *o = (noisy * self.counts_per_mps2).round().clamp(f64::from(ACCEL_MIN), f64::from(ACCEL_MAX)) as i16;
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;

    #[test]
    fn one_g_is_256_counts_at_2g() {
        assert_eq!(AccelRange::G2.counts_per_g(), 256.0);
        assert_eq!(AccelRange::G16.counts_per_g(), 32.0);
        let mut rng = ChaCha8Rng::seed_from_u64(0);
        let mut s = Bma250::new(&Bma250Config::ideal(), 0.004, &mut rng);
        assert_eq!(s.sample(&Vector3::new(0.0, -G0, G0), &mut rng), [0, -256, 256]);
    }

    #[test]
    fn noise_has_the_configured_rms() {
        let cfg = Bma250Config { range: AccelRange::G16, ..Bma250Config::ideal() };
        let cfg = Bma250Config { noise_density_g_per_sqrt_hz: 0.02, ..cfg };
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        let mut s = Bma250::new(&cfg, 0.004, &mut rng);
        let n = 20_000;
        let lsb = G0 / cfg.range.counts_per_g();
        let var: f64 = (0..n).map(|_| (f64::from(s.sample(&Vector3::zeros(), &mut rng)[0]) * lsb).powi(2)).sum::<f64>()
            / f64::from(n);
        let rms = cfg.noise_rms_mps2();
        assert!((var.sqrt() / rms - 1.0).abs() < 0.05, "{} vs {rms}", var.sqrt());
    }

    proptest! {
        #[test]
        fn readings_saturate_at_the_range_and_never_wrap(
            f in prop::array::uniform3(-1e6f64..1e6), seed in any::<u64>(),
        ) {
            let mut rng = ChaCha8Rng::seed_from_u64(seed);
            // Without misalignment, which would leak a huge axis into the others.
            let cfg = Bma250Config { misalignment_max_rad: 0.0, ..Bma250Config::default() };
            let mut s = Bma250::new(&cfg, 0.004, &mut rng);
            let out = s.sample(&Vector3::from(f), &mut rng);
            for (o, v) in out.iter().zip(f) {
                prop_assert!((ACCEL_MIN..=ACCEL_MAX).contains(o));
                // Far beyond the range, the reading is pinned to the rail of the right sign.
                if v.abs() > 3.0 * G0 {
                    prop_assert_eq!(*o, if v > 0.0 { ACCEL_MAX } else { ACCEL_MIN });
                }
            }
        }
    }
}
