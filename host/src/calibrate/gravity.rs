//! A cell's accelerometer frame, gain and offset from gravity seen in many
//! still postures.
//!
//! At rest a cell reads `gain ⊙ (Rᵀ u g0) + offset`, where `u` is the upward
//! direction in its link frame (known from the URDF and the joint positions)
//! and `R` the accelerometer frame in that link frame. Offsets of up to
//! 60 mg and gains 2 % off are the largest errors of a BMA250, so both are
//! unknowns of the fit, held near their datasheet spread by priors: where
//! the postures turn the link through enough directions the data decide,
//! where they do not (a link that gravity always meets the same way) the
//! priors keep the answer defined and the covariance says how little is
//! known.

use nalgebra::{Matrix3, Rotation3, SMatrix, SVector, Vector3};
use skin_protocol::message::G0;

/// One still posture as one cell saw it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Still {
    /// Unit upward direction in the cell's link frame.
    pub up: Vector3<f64>,
    /// Mean reading, m/s^2, accelerometer axes.
    pub mean: Vector3<f64>,
    /// Standard error of that mean per axis, m/s^2.
    pub sigma: Vector3<f64>,
}

/// What the sensors are known to get wrong before calibration (one
/// standard deviation), the spread the fit starts from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SensorPrior {
    /// Zero-g offset per axis, m/s^2.
    pub offset_mps2: f64,
    /// Gain error per axis, fraction.
    pub gain: f64,
}

impl Default for SensorPrior {
    /// The BMA250 datasheet: offsets uniform in +-60 mg, gains in +-2 %.
    fn default() -> Self {
        let uniform = |half: f64| half / 3f64.sqrt();
        SensorPrior { offset_mps2: uniform(0.060 * G0), gain: uniform(0.02) }
    }
}

/// The fit of one cell.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GravityFit {
    /// Accelerometer frame in the link frame.
    pub frame: Rotation3<f64>,
    /// Gain per axis.
    pub gain: Vector3<f64>,
    /// Zero-g offset per axis, m/s^2.
    pub offset: Vector3<f64>,
    /// Standard deviation of the frame's worst-known turn, rad.
    pub orientation_sigma_rad: f64,
    /// How firmly the postures hold the frame's turn (link axes), the
    /// gains and the offsets: the fit's information matrix.
    pub information: Mat9,
    /// Root mean square of the normalized residuals (about 1 when the
    /// model and the noise estimate hold).
    pub rms_residual: f64,
}

/// A turn no posture constrains keeps this spread, rad: weak enough never
/// to pull on data, strong enough to keep the equations solvable.
const TURN_PRIOR_RAD: f64 = 1.0;
const ITERATIONS: usize = 30;

/// Frame turn, gain and offset, in that order.
pub type Mat9 = SMatrix<f64, 9, 9>;
type Vec9 = SVector<f64, 9>;

/// Fits frame, gain and offset to `stills`; `None` without at least one
/// posture or when the readings are not finite.
pub fn fit(stills: &[Still], prior: &SensorPrior) -> Option<GravityFit> {
    if stills.is_empty() || !stills.iter().all(|s| is_finite(s.up) && is_finite(s.mean) && is_finite(s.sigma)) {
        return None;
    }
    let mut frame = initial_frame(stills);
    let mut gain = Vector3::repeat(1.0);
    let mut offset = Vector3::zeros();
    let mut info = Mat9::zeros();
    for _ in 0..ITERATIONS {
        let (h, b) = normal_equations(stills, prior, &frame, &gain, &offset);
        info = h;
        let step = h.cholesky()?.solve(&b);
        frame *= Rotation3::from_scaled_axis(step.fixed_rows::<3>(0).into_owned());
        gain += step.fixed_rows::<3>(3);
        offset += step.fixed_rows::<3>(6);
        if step.norm() < 1e-12 {
            break;
        }
    }
    let cov = info.cholesky()?.inverse();
    let turn = cov.fixed_view::<3, 3>(0, 0).into_owned();
    let orientation_sigma_rad = turn.symmetric_eigenvalues().max().max(0.0).sqrt();
    // The fit turns the frame in its own axes; the link sees them turned by it.
    let mut to_link = Mat9::identity();
    to_link.fixed_view_mut::<3, 3>(0, 0).copy_from(frame.matrix());
    let information = to_link * info * to_link.transpose();
    let chi2: f64 = stills
        .iter()
        .map(|s| (s.mean - model(&frame, &gain, &offset, &s.up)).component_div(&s.sigma).norm_squared())
        .sum();
    let rms_residual = (chi2 / (3 * stills.len()) as f64).sqrt();
    let ok = orientation_sigma_rad.is_finite() && is_finite(gain) && is_finite(offset);
    ok.then_some(GravityFit { frame, gain, offset, orientation_sigma_rad, information, rms_residual })
}

/// The reading of a still cell whose link sees `up` as upward.
fn model(frame: &Rotation3<f64>, gain: &Vector3<f64>, offset: &Vector3<f64>, up: &Vector3<f64>) -> Vector3<f64> {
    gain.component_mul(&(frame.inverse() * up * G0)) + offset
}

/// Gauss-Newton normal equations in the increments (turn of the frame in
/// its own axes, gain, offset), priors included.
fn normal_equations(
    stills: &[Still],
    prior: &SensorPrior,
    frame: &Rotation3<f64>,
    gain: &Vector3<f64>,
    offset: &Vector3<f64>,
) -> (Mat9, Vec9) {
    let mut h = Mat9::zeros();
    let mut b = Vec9::zeros();
    for s in stills {
        let w = frame.inverse() * s.up;
        let r = s.mean - model(frame, gain, offset, &s.up);
        // d(model)/d(turn, gain, offset): the frame turned by exp([d]x) sees w + w x d.
        let mut j = SMatrix::<f64, 3, 9>::zeros();
        j.fixed_view_mut::<3, 3>(0, 0).copy_from(&(Matrix3::from_diagonal(gain) * w.cross_matrix() * G0));
        j.fixed_view_mut::<3, 3>(0, 3).copy_from(&Matrix3::from_diagonal(&(w * G0)));
        j.fixed_view_mut::<3, 3>(0, 6).copy_from(&Matrix3::identity());
        let weight = Matrix3::from_diagonal(&s.sigma.map(|x| 1.0 / (x * x)));
        h += j.transpose() * weight * j;
        b += j.transpose() * weight * r;
    }
    let (turn, g, o) = (TURN_PRIOR_RAD.powi(-2), prior.gain.powi(-2), prior.offset_mps2.powi(-2));
    for i in 0..3 {
        h[(i, i)] += turn;
        h[(3 + i, 3 + i)] += g;
        b[3 + i] -= g * (gain[i] - 1.0);
        h[(6 + i, 6 + i)] += o;
        b[6 + i] -= o * offset[i];
    }
    (h, b)
}

/// The rotation that best turns the upward directions into the readings'
/// directions (Kabsch): a start inside the fit's basin of attraction.
fn initial_frame(stills: &[Still]) -> Rotation3<f64> {
    let mut m = Matrix3::zeros();
    for s in stills {
        if let Some(reading) = s.mean.try_normalize(1e-9) {
            m += reading * s.up.transpose();
        }
    }
    let svd = m.svd(true, true);
    let (Some(u), Some(v_t)) = (svd.u, svd.v_t) else { return Rotation3::identity() };
    let d = (u * v_t).determinant().signum();
    let q = u * Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, d)) * v_t;
    // q maps link-frame directions into accelerometer axes: it is Rᵀ.
    Rotation3::from_matrix(&q.transpose())
}

fn is_finite(v: Vector3<f64>) -> bool {
    v.iter().all(|x| x.is_finite())
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;
    use rand_distr::StandardNormal;

    struct Truth {
        frame: Rotation3<f64>,
        gain: Vector3<f64>,
        offset: Vector3<f64>,
    }

    fn truth(rng: &mut ChaCha8Rng) -> Truth {
        let axis = Vector3::from_fn(|_, _| rng.random_range(-1.0..1.0));
        Truth {
            frame: Rotation3::from_scaled_axis(axis * 2.0),
            gain: Vector3::from_fn(|_, _| 1.0 + rng.random_range(-0.02..0.02)),
            offset: Vector3::from_fn(|_, _| rng.random_range(-0.6..0.6)),
        }
    }

    fn stills(t: &Truth, ups: &[Vector3<f64>], noise: f64, rng: &mut ChaCha8Rng) -> Vec<Still> {
        ups.iter()
            .map(|up| {
                let n = Vector3::from_fn(|_, _| noise * rng.sample::<f64, _>(StandardNormal));
                Still {
                    up: *up,
                    mean: model(&t.frame, &t.gain, &t.offset, up) + n,
                    sigma: Vector3::repeat(noise.max(1e-3)),
                }
            })
            .collect()
    }

    fn random_ups(n: usize, rng: &mut ChaCha8Rng) -> Vec<Vector3<f64>> {
        (0..n).map(|_| Vector3::from_fn(|_, _| rng.sample::<f64, _>(StandardNormal)).normalize()).collect()
    }

    fn angle(a: &Rotation3<f64>, b: &Rotation3<f64>) -> f64 {
        (a.inverse() * b).angle()
    }

    #[test]
    fn many_directions_give_frame_gain_and_offset() {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        for _ in 0..20 {
            let t = truth(&mut rng);
            let ups = random_ups(16, &mut rng);
            let f = fit(&stills(&t, &ups, 0.005, &mut rng), &SensorPrior::default()).unwrap();
            assert!(angle(&f.frame, &t.frame) < 0.2f64.to_radians(), "{}", angle(&f.frame, &t.frame));
            assert!((f.offset - t.offset).amax() < 0.02, "{} vs {}", f.offset, t.offset);
            assert!((f.gain - t.gain).amax() < 0.003);
            assert!(f.orientation_sigma_rad < 0.1f64.to_radians());
            assert!(f.rms_residual < 2.0);
        }
    }

    #[test]
    fn one_direction_leaves_the_turn_about_it_unknown_and_says_so() {
        // A link that never turns against gravity (the fixed base).
        let mut rng = ChaCha8Rng::seed_from_u64(4);
        let t = truth(&mut rng);
        let ups = vec![Vector3::z(); 6];
        let f = fit(&stills(&t, &ups, 0.005, &mut rng), &SensorPrior::default()).unwrap();
        assert!(f.orientation_sigma_rad > 0.5, "{}", f.orientation_sigma_rad);
        // Still, the reading's direction is honoured: the up axis is found within the offset's reach.
        let up_found = f.frame.inverse() * Vector3::z();
        let up_true = t.frame.inverse() * Vector3::z();
        assert!(up_found.angle(&up_true) < 0.1);
    }

    #[test]
    fn a_circle_of_directions_fixes_the_frame() {
        // One horizontal joint from the base: gravity turns in one plane of the link.
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let t = truth(&mut rng);
        let ups: Vec<_> = (0..12).map(|k| Vector3::new(0.0, (k as f64 * 0.3).cos(), (k as f64 * 0.3).sin())).collect();
        let f = fit(&stills(&t, &ups, 0.005, &mut rng), &SensorPrior::default()).unwrap();
        assert!(angle(&f.frame, &t.frame) < 1f64.to_radians(), "{}", angle(&f.frame, &t.frame).to_degrees());
        assert!(f.orientation_sigma_rad < 1f64.to_radians());
    }

    #[test]
    fn ten_times_the_noise_widens_the_uncertainty_and_stays_near() {
        let mut rng = ChaCha8Rng::seed_from_u64(6);
        let t = truth(&mut rng);
        let ups = random_ups(12, &mut rng);
        let quiet = fit(&stills(&t, &ups, 0.005, &mut rng), &SensorPrior::default()).unwrap();
        let loud = fit(&stills(&t, &ups, 0.05, &mut rng), &SensorPrior::default()).unwrap();
        assert!(loud.orientation_sigma_rad > 5.0 * quiet.orientation_sigma_rad);
        assert!(angle(&loud.frame, &t.frame) < 4.0 * loud.orientation_sigma_rad + 1e-3);
    }

    proptest! {
        #[test]
        fn any_finite_input_gives_a_finite_fit_or_none(
            data in prop::collection::vec((prop::array::uniform3(-1e3f64..1e3), prop::array::uniform3(-1e3f64..1e3), 1e-6f64..1e3), 0..8),
        ) {
            let stills: Vec<Still> = data
                .iter()
                .filter_map(|(u, m, s)| Some(Still { up: Vector3::from(*u).try_normalize(1e-9)?, mean: Vector3::from(*m), sigma: Vector3::repeat(*s) }))
                .collect();
            if let Some(f) = fit(&stills, &SensorPrior::default()) {
                prop_assert!(f.frame.matrix().iter().all(|x| x.is_finite()));
                prop_assert!(f.orientation_sigma_rad.is_finite() && f.rms_residual.is_finite());
            }
        }

        #[test]
        fn non_finite_readings_are_refused(k in 0usize..3) {
            let mut mean = Vector3::new(0.0, 0.0, G0);
            mean[k] = f64::NAN;
            let stills = [Still { up: Vector3::z(), mean, sigma: Vector3::repeat(0.01) }];
            prop_assert!(fit(&stills, &SensorPrior::default()).is_none());
        }
    }
}
