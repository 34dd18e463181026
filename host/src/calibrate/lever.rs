//! A cell's position on its link from the accelerations of joint motion.
//!
//! A point `p` of a link (link frame) whose origin accelerates by `a_o`
//! while the link turns at `omega` and `alpha` feels, in the world frame,
//! `a_o + (alpha× + omega×omega×) R p + g_up` (equations (1)-(3) for any
//! motion). With the cell's frame, gain and offset from gravity its reading
//! gives that specific force, and every tick is three equations linear in
//! `p`. Each excitation gets its own constant bias, so only the motion
//! decides. The normal equations are summed as the ticks come and never
//! stored: memory does not grow with the record.
//!
//! What the still postures left loose must not pose as known: a link that
//! gravity only meets in one plane leaves a gain 1-2 % off, and a 2 g
//! swing read through it puts the cell a centimetre off. So the frame's
//! turn, the gains and the offsets are unknowns here too, held by the
//! still fit's information; the motion sharpens them, and what it cannot
//! sharpen widens the position's uncertainty. Their columns depend on the
//! position (the force the cell feels), so the sums keep one block per
//! position coordinate and the fit linearizes at its own estimate. The
//! columns come from the kinematics, never from the noisy reading, so
//! noise cannot pose as information.
//!
//! Motion about one axis says nothing about where along that axis the cell
//! sits. Such directions are found from the information matrix and left
//! out: the position there is reported unobservable, not invented.

use nalgebra::{Matrix3, SMatrix, SVector, Vector3};

use super::gravity::{GravityFit, Mat9};

/// Columns summed per tick: the position's (3); then the turn's and the
/// gains' for the force's constant part and per position coordinate
/// (4 x 3 each); then the offsets' (3).
const COLUMNS: usize = 30;
type Big = SMatrix<f64, COLUMNS, COLUMNS>;
type BigVec = SVector<f64, COLUMNS>;
type Rows = SMatrix<f64, 3, COLUMNS>;
/// Position, turn (link axes), gain, offset.
type Mat12 = SMatrix<f64, 12, 12>;
type Vec12 = SVector<f64, 12>;
const TURN: usize = 3;
const GAIN: usize = 15;
const OFFSET: usize = 27;

/// Residuals below this, m/s^2, are taken as this (noise-free data).
const NOISE_FLOOR_MPS2: f64 = 1e-6;
/// A cell is within this of its link's origin, m: a prior too weak to
/// place anything, only there to tell a free position from a fixed one.
const POSITION_PRIOR_M: f64 = 1.0;
/// Refits at the new position (the sensor columns depend on it).
const ITERATIONS: usize = 3;

/// How a link moves at one tick, world frame.
pub struct LinkMotion {
    /// The link frame's orientation.
    pub rotation: Matrix3<f64>,
    /// Angular velocity, rad/s.
    pub omega: Vector3<f64>,
    /// Angular acceleration, rad/s^2.
    pub alpha: Vector3<f64>,
    /// The link origin's acceleration plus gravity's upward reaction.
    pub origin_force: Vector3<f64>,
}

/// The running sums of one cell's equations.
#[derive(Clone, Debug, Default)]
pub struct Lever {
    /// Sums the position's columns only: enough for the residual, at a
    /// tenth of the work (the skin's delay is searched this way).
    position_only: bool,
    /// Over finished excitations, each centred on its own mean (the upper
    /// triangle while open, then whole).
    info: Big,
    rhs: BigVec,
    yy: f64,
    equations: usize,
    biases: usize,
    /// The excitation being summed.
    open: Sums,
}

#[derive(Clone, Debug, Default)]
struct Sums {
    n: usize,
    a: Rows,
    y: Vector3<f64>,
    ata: Big,
    aty: BigVec,
    yy: f64,
}

/// Where a cell sits, and its sensor as the motion corrected it.
#[derive(Clone, Debug, PartialEq)]
pub struct LeverFit {
    /// Position in the link frame, m; zero along unobservable directions.
    pub position: Vector3<f64>,
    /// Standard deviation along each observable direction's coordinate
    /// share, m (link axes; `inf` for an axis the motion never showed).
    pub sigma_m: Vector3<f64>,
    /// Covariance of the position along the observable directions, m^2.
    pub covariance_m2: Matrix3<f64>,
    /// Unit directions (link frame) along which the motion showed nothing.
    pub unobservable: Vec<Vector3<f64>>,
    /// Root mean square residual of the equations, m/s^2.
    pub rms_mps2: f64,
    /// The turn that corrects the still fit's frame (link axes, rad):
    /// the frame is `exp(turn) * frame`.
    pub turn: Vector3<f64>,
    /// Standard deviation of the corrected frame's worst-known turn, rad.
    pub turn_sigma_rad: f64,
    /// Correction to the still fit's gains.
    pub gain: Vector3<f64>,
    /// Correction to the still fit's offsets, m/s^2.
    pub offset: Vector3<f64>,
}

impl Lever {
    /// Sums for [`Lever::residual_rms`] alone.
    pub fn position_only() -> Self {
        Lever { position_only: true, ..Lever::default() }
    }

    /// Adds one tick: the link's motion, the still fit of the cell, and
    /// the cell's specific force read through that fit (world frame).
    pub fn add(&mut self, link: &LinkMotion, still: &GravityFit, force: &Vector3<f64>) {
        let r = &link.rotation;
        let m = (link.alpha.cross_matrix() + link.omega.cross_matrix() * link.omega.cross_matrix()) * r;
        // Read through the still fit, the true force u = f0 + m p (world)
        // arrives turned by the frame's error d and scaled by the gains' and
        // shifted by the offsets' errors:
        //   y = m p + [u]x R d + R F diag(F^T R^T u / g) dg + R F diag(1 / g) do.
        let mut a = Rows::zeros();
        a.fixed_view_mut::<3, 3>(0, 0).copy_from(&m);
        let columns = if self.position_only {
            3
        } else {
            let rf = r * still.frame.matrix();
            let per_gain = rf * Matrix3::from_diagonal(&still.gain.map(f64::recip));
            let parts =
                [link.origin_force, m.column(0).into_owned(), m.column(1).into_owned(), m.column(2).into_owned()];
            for (j, u) in parts.iter().enumerate() {
                a.fixed_view_mut::<3, 3>(0, TURN + 3 * j).copy_from(&(u.cross_matrix() * r));
                let sensed = rf.transpose() * u;
                a.fixed_view_mut::<3, 3>(0, GAIN + 3 * j).copy_from(&(per_gain * Matrix3::from_diagonal(&sensed)));
            }
            a.fixed_view_mut::<3, 3>(0, OFFSET).copy_from(&per_gain);
            COLUMNS
        };
        let y = force - link.origin_force;
        if !(a.iter().all(|x| x.is_finite()) && y.iter().all(|x| x.is_finite())) {
            return;
        }
        let s = &mut self.open;
        s.n += 1;
        s.a += a;
        s.y += y;
        for j in 0..columns {
            let aj = a.column(j);
            for i in 0..=j {
                s.ata[(i, j)] += aj.dot(&a.column(i));
            }
            s.aty[j] += aj.dot(&y);
        }
        s.yy += y.norm_squared();
    }

    /// Closes the current excitation: its bias is fitted out.
    pub fn finish_excitation(&mut self) {
        let s = std::mem::take(&mut self.open);
        if s.n < 2 {
            return;
        }
        let n = s.n as f64;
        let ata = Big::from_fn(|i, j| s.ata[(i.min(j), i.max(j))]);
        self.info += ata - s.a.transpose() * s.a / n;
        self.rhs += s.aty - s.a.transpose() * s.y / n;
        self.yy += s.yy - s.y.norm_squared() / n;
        self.equations += 3 * s.n;
        self.biases += 3;
    }

    /// The least-squares position with the still fit taken as exact, along
    /// every direction the motion showed at all, and its sum of squared
    /// residuals.
    fn least_squares(&self) -> (Vector3<f64>, f64, nalgebra::SymmetricEigen<f64, nalgebra::U3>) {
        let info = self.info.fixed_view::<3, 3>(0, 0).into_owned();
        let rhs = self.rhs.fixed_rows::<3>(0).into_owned();
        let eig = info.symmetric_eigen();
        let scale = eig.eigenvalues.amax();
        let mut p = Vector3::zeros();
        for (i, &lambda) in eig.eigenvalues.iter().enumerate() {
            if scale.is_finite() && lambda > 1e-9 * scale {
                let v = eig.eigenvectors.column(i);
                p += v * (v.dot(&rhs) / lambda);
            }
        }
        let ss = (self.yy - 2.0 * p.dot(&rhs) + (p.transpose() * info * p)[0]).max(0.0);
        (p, ss, eig)
    }

    /// Root mean square residual of the equations with the still fit taken
    /// as exact, m/s^2, whether or not the link moved: motion the link's
    /// own cannot explain shows here.
    pub fn residual_rms(&self) -> Option<f64> {
        let free = self.equations.checked_sub(self.biases).filter(|&d| d > 0)?;
        let (_, ss, _) = self.least_squares();
        Some((ss / free as f64).sqrt())
    }

    /// The position and the sensor's corrections, the sensor held to the
    /// still fit by its information `still` (link-axes turn, gain,
    /// offset). Position directions known worse than `observable_sigma_m`
    /// are left out. `None` before enough equations.
    pub fn solve(&self, observable_sigma_m: f64, still: &Mat9) -> Option<LeverFit> {
        let dof = self.equations.checked_sub(self.biases + 3).filter(|&d| d > 0)?;
        let (mut position, ss, eig) = self.least_squares();
        let scale = eig.eigenvalues.amax();
        if !(scale.is_finite() && scale > 0.0) {
            return None;
        }
        let mut var = ss / dof as f64;
        let mut fit = None;
        for _ in 0..ITERATIONS {
            let (info, rhs) = self.joint(&position);
            let f = joint_fit(&info, &rhs, var.max(NOISE_FLOOR_MPS2 * NOISE_FLOOR_MPS2), still, observable_sigma_m)?;
            let x = Vec12::from_iterator(
                f.position.iter().chain(f.turn.iter()).chain(f.gain.iter()).chain(f.offset.iter()).copied(),
            );
            var = (self.yy - 2.0 * x.dot(&rhs) + (x.transpose() * info * x)[0]).max(0.0) / dof as f64;
            position = f.position;
            fit = Some(f);
        }
        let mut fit = fit?;
        fit.rms_mps2 = (var * dof as f64 / (self.equations - self.biases) as f64).sqrt();
        Some(fit)
    }

    /// The normal equations in position, turn, gain and offset, the sensor
    /// columns built at `position`.
    fn joint(&self, position: &Vector3<f64>) -> (Mat12, Vec12) {
        let mut w = SMatrix::<f64, COLUMNS, 12>::zeros();
        w.fixed_view_mut::<3, 3>(0, 0).fill_with_identity();
        for (j, weight) in [1.0, position.x, position.y, position.z].into_iter().enumerate() {
            let block = Matrix3::identity() * weight;
            w.fixed_view_mut::<3, 3>(TURN + 3 * j, 3).copy_from(&block);
            w.fixed_view_mut::<3, 3>(GAIN + 3 * j, 6).copy_from(&block);
        }
        w.fixed_view_mut::<3, 3>(OFFSET, 9).fill_with_identity();
        (w.transpose() * self.info * w, w.transpose() * self.rhs)
    }
}

/// Position and sensor corrections from their normal equations (`var` the
/// noise variance, m^2/s^4), the sensor held by `still`; position
/// directions known worse than `observable_sigma_m` are left out.
fn joint_fit(info: &Mat12, rhs: &Vec12, var: f64, still: &Mat9, observable_sigma_m: f64) -> Option<LeverFit> {
    let hpp = info.fixed_view::<3, 3>(0, 0) / var;
    let hps = info.fixed_view::<3, 9>(0, 3) / var;
    let hss = info.fixed_view::<9, 9>(3, 3) / var + still;
    let (bp, bs) = (rhs.fixed_rows::<3>(0) / var, rhs.fixed_rows::<9>(3) / var);
    let chol = hss.cholesky()?;
    // The sensor eliminated: what the position alone is told.
    let k = chol.solve(&hps.transpose());
    let reduced = hpp - hps * k;
    let reduced_rhs = bp - hps * chol.solve(&bs);
    let eig = reduced.symmetric_eigen();
    let scale = eig.eigenvalues.amax();
    if !(scale.is_finite() && scale > 0.0) {
        return None;
    }
    let observable = |lambda: f64| lambda > 1e-9 * scale && lambda.recip().sqrt() <= observable_sigma_m;
    let mut position = Vector3::zeros();
    let mut covariance = Matrix3::zeros();
    let mut unobservable = Vec::new();
    for (i, &lambda) in eig.eigenvalues.iter().enumerate() {
        let v: Vector3<f64> = eig.eigenvectors.column(i).into_owned();
        if observable(lambda) {
            position += v * (v.dot(&reduced_rhs) / lambda);
            covariance += v * v.transpose() / lambda;
        } else {
            unobservable.push(v);
        }
    }
    // An axis is unknown where an unobservable direction leans on it.
    let sigma_m = Vector3::from_fn(|k, _| {
        let lean: f64 = unobservable.iter().map(|v| v[k] * v[k]).sum();
        if lean > 0.04 {
            f64::INFINITY
        } else {
            covariance[(k, k)].sqrt()
        }
    });
    let sensor = chol.solve(&bs) - k * position;
    // The sensor's spread with the position free, also along directions
    // the motion did not show: where a turn of the frame and a shift of the
    // cell read alike (a link turning about a vertical axis), neither is known.
    let loose = hpp + Matrix3::identity() / (POSITION_PRIOR_M * POSITION_PRIOR_M);
    let sensor_info = hss - hps.transpose() * loose.cholesky()?.solve(&hps);
    let sensor_covariance = sensor_info.cholesky()?.inverse();
    let turn_sigma_rad = sensor_covariance.fixed_view::<3, 3>(0, 0).symmetric_eigenvalues().max().max(0.0).sqrt();
    let ok = position.iter().chain(sensor.iter()).all(|x| x.is_finite()) && turn_sigma_rad.is_finite();
    ok.then(|| LeverFit {
        position,
        sigma_m,
        covariance_m2: covariance,
        unobservable,
        rms_mps2: 0.0,
        turn: sensor.fixed_rows::<3>(0).into_owned(),
        turn_sigma_rad,
        gain: sensor.fixed_rows::<3>(3).into_owned(),
        offset: sensor.fixed_rows::<3>(6).into_owned(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;
    use rand_distr::StandardNormal;

    const UP: Vector3<f64> = Vector3::new(0.0, 0.0, 9.81);

    /// The information of a still fit that fixed the frame to `turn_rad`,
    /// the gains to `gain` and the offsets to 0.005 m/s^2.
    fn still_info(turn_rad: f64, gain: [f64; 3]) -> Mat9 {
        let [gx, gy, gz] = gain;
        let spread = [turn_rad, turn_rad, turn_rad, gx, gy, gz, 0.005, 0.005, 0.005];
        Mat9::from_diagonal(&SVector::from(spread.map(|s: f64| s.powi(-2))))
    }

    /// A still fit that found the frame 0.05 degrees and the gains 0.1 % sure.
    fn known() -> Mat9 {
        still_info(0.05f64.to_radians(), [0.001; 3])
    }

    /// The still fit the readings are read through: sensor axes = link axes.
    fn identity_fit() -> GravityFit {
        GravityFit {
            frame: nalgebra::Rotation3::identity(),
            gain: Vector3::repeat(1.0),
            offset: Vector3::zeros(),
            orientation_sigma_rad: 0.0,
            information: known(),
            rms_residual: 1.0,
        }
    }

    fn excite(
        lever: &mut Lever,
        axis: Vector3<f64>,
        p: Vector3<f64>,
        noise: f64,
        bias: Vector3<f64>,
        rng: &mut ChaCha8Rng,
    ) {
        excite_gain(lever, axis, p, noise, bias, Vector3::zeros(), rng);
    }

    /// A link turning about `axis` through the origin, `phi = A (1 - cos wt) / 2`,
    /// its cell's gains `gain_error` off what the still fit said.
    fn excite_gain(
        lever: &mut Lever,
        axis: Vector3<f64>,
        p: Vector3<f64>,
        noise: f64,
        bias: Vector3<f64>,
        gain_error: Vector3<f64>,
        rng: &mut ChaCha8Rng,
    ) {
        let axis = axis.normalize();
        let (amp, w, dt) = (0.6, std::f64::consts::TAU, 0.004);
        for k in 0..750 {
            let t = k as f64 * dt;
            let phi = amp * (1.0 - (w * t).cos()) / 2.0;
            let omega = axis * (amp * w * (w * t).sin() / 2.0);
            let alpha = axis * (amp * w * w * (w * t).cos() / 2.0);
            let rot = nalgebra::Rotation3::from_axis_angle(&nalgebra::Unit::new_normalize(axis), phi);
            let r = rot * p;
            let f = alpha.cross(&r) + omega.cross(&omega.cross(&r)) + UP;
            let read = (rot.inverse() * f).component_mul(&(Vector3::repeat(1.0) + gain_error));
            let f = rot * read + bias + Vector3::from_fn(|_, _| noise * rng.sample::<f64, _>(StandardNormal));
            let link = LinkMotion { rotation: *rot.matrix(), omega, alpha, origin_force: UP };
            lever.add(&link, &identity_fit(), &f);
        }
        lever.finish_excitation();
    }

    #[test]
    fn a_gain_the_still_fit_left_loose_is_found_and_does_not_move_the_cell() {
        // Gravity met the link in the y-z plane only: the x gain is known to
        // its datasheet spread (2 %), and it is 1.5 % off.
        let mut rng = ChaCha8Rng::seed_from_u64(6);
        let p = Vector3::new(0.25, -0.12, 0.3);
        let gain_error = Vector3::new(0.015, 0.0, 0.0);
        let mut l = Lever::default();
        for axis in [Vector3::y(), Vector3::x(), Vector3::new(1.0, 1.0, 0.0)] {
            excite_gain(&mut l, axis, p, 0.07, Vector3::zeros(), gain_error, &mut rng);
        }
        let turn = 0.1f64.to_radians();
        let loose = l.solve(0.003, &still_info(turn, [0.02, 0.001, 0.001])).unwrap();
        assert!((loose.position - p).norm() < 0.0015, "{} vs {p}", loose.position);
        assert!((loose.gain - gain_error).amax() < 0.003, "{} vs {gain_error}", loose.gain);
        // Held to the wrong gain as if it were exact, the same data put the cell off.
        let wrong = l.solve(0.003, &still_info(turn, [1e-5; 3])).unwrap();
        assert!((wrong.position - p).norm() > 3.0 * (loose.position - p).norm(), "{}", wrong.position - p);
    }

    #[test]
    fn a_link_turning_about_a_vertical_axis_knows_neither_azimuth_nor_frame() {
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let p = Vector3::new(0.1, 0.05, 0.2);
        let mut l = Lever::default();
        excite(&mut l, Vector3::z(), p, 0.07, Vector3::zeros(), &mut rng);
        // Gravity alone never turned the frame about the vertical.
        let mut info = still_info(0.1f64.to_radians(), [0.001; 3]);
        info[(2, 2)] = 1.0;
        let f = l.solve(0.003, &info).unwrap();
        assert!(f.turn_sigma_rad > 10f64.to_radians(), "{}", f.turn_sigma_rad.to_degrees());
        // The azimuth's direction (tangent) and the axis are unobservable.
        let tangent = Vector3::z().cross(&p).normalize();
        assert!(f.unobservable.iter().any(|v| v.dot(&tangent).abs() > 0.99), "{:?}", f.unobservable);
    }

    #[test]
    fn two_axes_give_the_whole_position() {
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        let p = Vector3::new(0.05, -0.12, 0.2);
        let mut l = Lever::default();
        excite(&mut l, Vector3::y(), p, 0.07, Vector3::new(0.1, 0.0, -0.05), &mut rng);
        excite(&mut l, Vector3::x(), p, 0.07, Vector3::new(0.0, 0.2, 0.0), &mut rng);
        let f = l.solve(0.003, &known()).unwrap();
        assert!(f.unobservable.is_empty(), "{:?}", f.unobservable);
        assert!((f.position - p).norm() < 0.002, "{} vs {p}", f.position);
        assert!(f.sigma_m.max() < 0.001);
    }

    #[test]
    fn one_axis_leaves_the_position_along_it_unobservable() {
        let mut rng = ChaCha8Rng::seed_from_u64(2);
        let p = Vector3::new(0.05, -0.12, 0.2);
        let mut l = Lever::default();
        excite(&mut l, Vector3::y(), p, 0.07, Vector3::zeros(), &mut rng);
        let f = l.solve(0.003, &known()).unwrap();
        assert_eq!(f.unobservable.len(), 1);
        assert!(f.unobservable[0].y.abs() > 0.999);
        assert!(f.sigma_m.y.is_infinite() && f.sigma_m.x.is_finite() && f.sigma_m.z.is_finite());
        // Perpendicular to the axis the position is right.
        let e = f.position - p;
        assert!((e - Vector3::y() * e.y).norm() < 0.002, "{e}");
    }

    #[test]
    fn a_cell_on_the_axis_is_found_there_and_a_tiny_lever_is_not_invented() {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        for p in [Vector3::zeros(), Vector3::new(0.001, 0.0, 0.0)] {
            let mut l = Lever::default();
            excite(&mut l, Vector3::z(), p, 0.07, Vector3::zeros(), &mut rng);
            excite(&mut l, Vector3::x(), p, 0.07, Vector3::zeros(), &mut rng);
            let f = l.solve(0.003, &known()).unwrap();
            assert!((f.position - p).norm() < 0.002, "{} vs {p}", f.position);
        }
    }

    #[test]
    fn ten_times_the_noise_gives_wider_sigmas_or_unobservable_never_nan() {
        let mut rng = ChaCha8Rng::seed_from_u64(4);
        let p = Vector3::new(0.02, 0.03, 0.1);
        let mut quiet = Lever::default();
        let mut loud = Lever::default();
        for axis in [Vector3::x(), Vector3::y()] {
            excite(&mut quiet, axis, p, 0.07, Vector3::zeros(), &mut rng);
            excite(&mut loud, axis, p, 0.7, Vector3::zeros(), &mut rng);
        }
        let (q, l) = (quiet.solve(0.003, &known()).unwrap(), loud.solve(0.003, &known()).unwrap());
        assert!(l.position.iter().all(|x| x.is_finite()));
        for k in 0..3 {
            assert!(l.sigma_m[k] > 5.0 * q.sigma_m[k], "{} vs {}", l.sigma_m, q.sigma_m);
            if l.sigma_m[k].is_finite() {
                assert!((l.position[k] - p[k]).abs() < 4.0 * l.sigma_m[k] + 1e-3);
            }
        }
    }

    #[test]
    fn no_motion_is_no_answer() {
        let mut l = Lever::default();
        for _ in 0..100 {
            let still = LinkMotion {
                rotation: Matrix3::identity(),
                omega: Vector3::zeros(),
                alpha: Vector3::zeros(),
                origin_force: UP,
            };
            l.add(&still, &identity_fit(), &UP);
        }
        l.finish_excitation();
        assert!(l.solve(0.003, &known()).is_none());
        assert!(Lever::default().solve(0.003, &known()).is_none());
    }

    #[test]
    fn non_finite_ticks_are_skipped() {
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let p = Vector3::new(0.05, -0.12, 0.2);
        let mut l = Lever::default();
        let link =
            LinkMotion { rotation: Matrix3::identity(), omega: Vector3::x(), alpha: Vector3::y(), origin_force: UP };
        l.add(&link, &identity_fit(), &Vector3::repeat(f64::NAN));
        excite(&mut l, Vector3::y(), p, 0.07, Vector3::zeros(), &mut rng);
        excite(&mut l, Vector3::x(), p, 0.07, Vector3::zeros(), &mut rng);
        assert!((l.solve(0.003, &known()).unwrap().position - p).norm() < 0.002);
    }
}
