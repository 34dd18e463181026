//! A cell's position on its link from the accelerations of joint motion.
//!
//! A point `p` of a link (link frame) whose origin accelerates by `a_o`
//! while the link turns at `omega` and `alpha` feels, in the world frame,
//! `a_o + (alpha× + omega×omega×) R p + g_up` (equations (1)-(3) for any
//! motion). With the cell's frame, gain and offset known from gravity, its
//! reading gives that specific force, and every tick is three equations
//! linear in `p`. Each excitation gets its own constant bias, which soaks
//! up what the still fit left (a fraction of a degree of tilt, a residual
//! offset) so only the motion decides. The normal equations are summed as
//! the ticks come and never stored: memory does not grow with the record.
//!
//! Motion about one axis says nothing about where along that axis the cell
//! sits. Such directions are found from the information matrix and left
//! out: the position there is reported unobservable, not invented.

use nalgebra::{Matrix3, Vector3};

/// The running sums of one cell's equations.
#[derive(Clone, Debug, Default)]
pub struct Lever {
    /// Over finished excitations, each centred on its own mean.
    info: Matrix3<f64>,
    rhs: Vector3<f64>,
    yy: f64,
    equations: usize,
    biases: usize,
    /// The excitation being summed.
    open: Sums,
}

#[derive(Clone, Debug, Default)]
struct Sums {
    n: usize,
    a: Matrix3<f64>,
    y: Vector3<f64>,
    ata: Matrix3<f64>,
    aty: Vector3<f64>,
    yy: f64,
}

/// Where a cell sits, as far as the motion showed.
#[derive(Clone, Debug, PartialEq)]
pub struct LeverFit {
    /// Position in the link frame, m; zero along unobservable directions.
    pub position: Vector3<f64>,
    /// Standard deviation along each observable direction's coordinate
    /// share, m (link axes; `inf` for an axis the motion never showed).
    pub sigma_m: Vector3<f64>,
    /// Unit directions (link frame) along which the motion showed nothing.
    pub unobservable: Vec<Vector3<f64>>,
    /// Root mean square residual of the equations, m/s^2.
    pub rms_mps2: f64,
}

impl Lever {
    /// Adds one tick: the link turning at `omega` with `alpha`, its frame
    /// turned by `rotation` and its origin accelerating by `origin_accel`
    /// (all world frame), and the cell's specific force `force` (world frame).
    pub fn add(
        &mut self,
        rotation: &Matrix3<f64>,
        omega: &Vector3<f64>,
        alpha: &Vector3<f64>,
        origin_accel: &Vector3<f64>,
        force: &Vector3<f64>,
        up: &Vector3<f64>,
    ) {
        let a = (alpha.cross_matrix() + omega.cross_matrix() * omega.cross_matrix()) * rotation;
        let y = force - origin_accel - up;
        if !(a.iter().all(|x| x.is_finite()) && y.iter().all(|x| x.is_finite())) {
            return;
        }
        let s = &mut self.open;
        s.n += 1;
        s.a += a;
        s.y += y;
        s.ata += a.transpose() * a;
        s.aty += a.transpose() * y;
        s.yy += y.norm_squared();
    }

    /// Closes the current excitation: its bias is fitted out.
    pub fn finish_excitation(&mut self) {
        let s = std::mem::take(&mut self.open);
        if s.n < 2 {
            return;
        }
        let n = s.n as f64;
        self.info += s.ata - s.a.transpose() * s.a / n;
        self.rhs += s.aty - s.a.transpose() * s.y / n;
        self.yy += s.yy - s.y.norm_squared() / n;
        self.equations += 3 * s.n;
        self.biases += 3;
    }

    /// The least-squares position along every direction the motion showed
    /// at all, and its sum of squared residuals.
    fn least_squares(&self) -> (Vector3<f64>, f64, nalgebra::SymmetricEigen<f64, nalgebra::U3>) {
        let eig = self.info.symmetric_eigen();
        let scale = eig.eigenvalues.amax();
        let mut p = Vector3::zeros();
        for (i, &lambda) in eig.eigenvalues.iter().enumerate() {
            if scale.is_finite() && lambda > 1e-9 * scale {
                let v = eig.eigenvectors.column(i);
                p += v * (v.dot(&self.rhs) / lambda);
            }
        }
        let ss = (self.yy - 2.0 * p.dot(&self.rhs) + (p.transpose() * self.info * p)[0]).max(0.0);
        (p, ss, eig)
    }

    /// Root mean square residual of the equations, m/s^2, whether or not
    /// the link moved: motion the link's own cannot explain shows here.
    pub fn residual_rms(&self) -> Option<f64> {
        let free = self.equations.checked_sub(self.biases).filter(|&d| d > 0)?;
        let (_, ss, _) = self.least_squares();
        Some((ss / free as f64).sqrt())
    }

    /// The position, with directions whose standard deviation would exceed
    /// `observable_sigma_m` left out. `None` before enough equations.
    pub fn solve(&self, observable_sigma_m: f64) -> Option<LeverFit> {
        let dof = self.equations.checked_sub(self.biases + 3).filter(|&d| d > 0)?;
        let (_, ss, eig) = self.least_squares();
        let scale = eig.eigenvalues.amax();
        if !(scale.is_finite() && scale > 0.0) {
            return None;
        }
        let var = ss / dof as f64;
        let observable = |lambda: f64| lambda > 1e-9 * scale && (var / lambda).sqrt() <= observable_sigma_m;
        let mut position = Vector3::zeros();
        let mut unobservable = Vec::new();
        let mut variance = Vector3::zeros();
        for (i, &lambda) in eig.eigenvalues.iter().enumerate() {
            let v: Vector3<f64> = eig.eigenvectors.column(i).into_owned();
            if observable(lambda) {
                position += v * (v.dot(&self.rhs) / lambda);
                variance += v.component_mul(&v) * (var / lambda);
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
                variance[k].sqrt()
            }
        });
        let rms_mps2 = (ss / (self.equations - self.biases) as f64).sqrt();
        Some(LeverFit { position, sigma_m, unobservable, rms_mps2 })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;
    use rand_distr::StandardNormal;

    const UP: Vector3<f64> = Vector3::new(0.0, 0.0, 9.81);

    /// A link turning about `axis` through the origin, `phi = A (1 - cos wt) / 2`.
    fn excite(
        lever: &mut Lever,
        axis: Vector3<f64>,
        p: Vector3<f64>,
        noise: f64,
        bias: Vector3<f64>,
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
            let f = alpha.cross(&r)
                + omega.cross(&omega.cross(&r))
                + UP
                + bias
                + Vector3::from_fn(|_, _| noise * rng.sample::<f64, _>(StandardNormal));
            lever.add(rot.matrix(), &omega, &alpha, &Vector3::zeros(), &f, &UP);
        }
        lever.finish_excitation();
    }

    #[test]
    fn two_axes_give_the_whole_position() {
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        let p = Vector3::new(0.05, -0.12, 0.2);
        let mut l = Lever::default();
        excite(&mut l, Vector3::y(), p, 0.07, Vector3::new(0.1, 0.0, -0.05), &mut rng);
        excite(&mut l, Vector3::x(), p, 0.07, Vector3::new(0.0, 0.2, 0.0), &mut rng);
        let f = l.solve(0.003).unwrap();
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
        let f = l.solve(0.003).unwrap();
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
            let f = l.solve(0.003).unwrap();
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
        let (q, l) = (quiet.solve(0.003).unwrap(), loud.solve(0.003).unwrap());
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
            l.add(&Matrix3::identity(), &Vector3::zeros(), &Vector3::zeros(), &Vector3::zeros(), &UP, &UP);
        }
        l.finish_excitation();
        assert!(l.solve(0.003).is_none());
        assert!(Lever::default().solve(0.003).is_none());
    }

    #[test]
    fn non_finite_ticks_are_skipped() {
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let p = Vector3::new(0.05, -0.12, 0.2);
        let mut l = Lever::default();
        l.add(&Matrix3::identity(), &Vector3::x(), &Vector3::y(), &Vector3::zeros(), &Vector3::repeat(f64::NAN), &UP);
        excite(&mut l, Vector3::y(), p, 0.07, Vector3::zeros(), &mut rng);
        excite(&mut l, Vector3::x(), p, 0.07, Vector3::zeros(), &mut rng);
        assert!((l.solve(0.003).unwrap().position - p).norm() < 0.002);
    }
}
