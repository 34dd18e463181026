//! The base's own motion, regressed out of a coupled DoF's repeated steps.
//!
//! A standing robot rocks on its feet or mount when a joint accelerates:
//! the reaction starts with the acceleration itself, so every cell shows a
//! lever that pooling never averages away (PR2's grippers: 0.8-1.3 mm on
//! cells the gripper does not move). During the step every link the DoF
//! does not move is held rigidly to the base, so all of those cells see
//! one rigid body's motion: the same waveforms, each cell in its own
//! proportion and frame. The cells already decided still are then a
//! reference accelerometer on the base. Summed over the repeats of the
//! step (each turned to the step's direction, so the DoF's own motion adds
//! up and the slow sway cancels), their traces give the rocking waveform;
//! a cell's summed trace regressed on the DoF's acceleration *and* that
//! waveform leaves the lever the DoF itself gives it.

use super::activity::unexplained;
use super::fit::LeastSquares;
use super::session::{Trace, Window};

/// The repeats of one DoF's step in the start posture, summed tick by tick.
pub(crate) struct Sums {
    cells: usize,
    /// Ticks per trace; repeats of another length start the sums again.
    len: usize,
    /// Sum of the DoF's acceleration, each repeat times its direction, rad/s^2.
    alpha: Vec<f64>,
    /// `accel[k * cells + u]`: the same sum of the acceleration gravity
    /// does not explain, m/s^2; NaN once a sample was missing.
    accel: Vec<[f64; 3]>,
    /// Per cell, the sum of the repeats' sample variances, (m/s^2)^2.
    var: Vec<f64>,
    /// Per cell: saturated in some repeat.
    saturated: Vec<bool>,
    /// Per cell, the lever last found by [`Sums::update`] and its standard
    /// deviation, m.
    levers: Vec<Option<(f64, f64)>>,
}

impl Sums {
    /// Empty sums for `cells` cells.
    pub fn new(cells: usize) -> Sums {
        Sums {
            cells,
            len: 0,
            alpha: Vec::new(),
            accel: Vec::new(),
            var: vec![0.0; cells],
            saturated: vec![false; cells],
            levers: vec![None; cells],
        }
    }

    /// The lever of cell `u` with the base's motion regressed out, and its
    /// standard deviation, m, as of the last [`Sums::update`].
    pub fn lever(&self, u: usize) -> Option<(f64, f64)> {
        self.levers[u]
    }

    /// Adds one repeat: its trace, the still windows around it and the
    /// DoF's acceleration per tick.
    pub fn add(&mut self, pre: &Window, post: &Window, trace: &Trace, alpha: &[f64], noise_var: &[f64]) {
        let moved = trace.q.last().map_or(0.0, |q| q - trace.q0);
        if moved == 0.0 || alpha.len() != trace.len() {
            return;
        }
        if trace.len() != self.len {
            *self = Sums::new(self.cells);
            self.len = trace.len();
            self.alpha = vec![0.0; self.len];
            self.accel = vec![[0.0; 3]; self.len * self.cells];
        }
        let sign = moved.signum();
        for (s, a) in self.alpha.iter_mut().zip(alpha) {
            *s += sign * a;
        }
        let rows = self.accel.chunks_mut(self.cells).zip(trace.accel.chunks(self.cells));
        for ((sums, samples), q) in rows.zip(&trace.q) {
            let turned = (q - trace.q0) / moved;
            for (u, (sum, sample)) in sums.iter_mut().zip(samples).enumerate() {
                let residual = unexplained(*sample, &pre.mean[u], &post.mean[u], turned);
                for (s, r) in sum.iter_mut().zip(residual) {
                    *s += sign * r;
                }
            }
        }
        for ((var, saturated), (noise, hit)) in
            self.var.iter_mut().zip(&mut self.saturated).zip(noise_var.iter().zip(&trace.saturated))
        {
            *var += noise;
            *saturated |= hit;
        }
    }

    /// Finds the lever of each cell in `of` with the base's motion, as the
    /// cells in `still` see it, regressed out. A cell whose samples were
    /// missing or saturated gets none, and so do all when fewer than
    /// `min_references` of the cells in `still` can be read or the rocking
    /// cannot be told from the DoF's own acceleration.
    pub fn update(&mut self, still: &[usize], of: &[usize], min_references: usize) {
        for &u in of {
            self.levers[u] = None;
        }
        let Some(plain) = LeastSquares::new(self.alpha.iter().map(|&a| [1.0, a]).collect()) else { return };
        // Each still cell's lever is its share of the rocking: weighting its
        // trace by it sums the waveform with the least noise.
        let mut waveform = vec![0.0; self.len];
        let mut weight = 0.0;
        let mut references = 0;
        for &u in still {
            let Some(fits) = self.fit(&plain, u) else { continue };
            references += 1;
            for (a, [offset, lever]) in fits.into_iter().enumerate() {
                for (k, w) in waveform.iter_mut().enumerate() {
                    *w += lever * (self.accel[k * self.cells + u][a] - offset);
                }
                weight += lever * lever;
            }
        }
        if references < min_references || weight <= 0.0 {
            return;
        }
        let rows = self.alpha.iter().zip(&waveform).map(|(&a, &w)| [1.0, a, w / weight]).collect();
        let Some(rocking) = LeastSquares::new(rows) else { return };
        let sigma = rocking.variance_factor(1).sqrt();
        for &u in of {
            self.levers[u] = self.fit(&rocking, u).map(|fits| {
                let [x, y, z] = fits.map(|c| c[1]);
                ((x * x + y * y + z * z).sqrt(), sigma * self.var[u].sqrt())
            });
        }
    }

    /// Cell `u`'s summed trace fitted per axis on `fit`'s regressors.
    fn fit<const N: usize>(&self, fit: &LeastSquares<N>, u: usize) -> Option<[[f64; N]; 3]> {
        if self.saturated[u] || self.len == 0 {
            return None;
        }
        let axis = |a: usize| fit.fit((0..self.len).map(|k| self.accel[k * self.cells + u][a]));
        Some([axis(0)?, axis(1)?, axis(2)?])
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;
    use rand_distr::{Distribution, Normal};

    const TICK_S: f64 = 0.004;
    const TICKS: usize = 100;
    /// Noise of one sample, m/s^2 (the BMA250's, roughly).
    const NOISE: f64 = 0.04;

    /// A raised-cosine step's acceleration over its first 0.2 s, rad/s^2,
    /// and the base's rocking acceleration it drives: a 4 Hz mode, damping
    /// 0.1, whose reaction starts with the joint's acceleration.
    fn step() -> (Vec<f64>, Vec<f64>) {
        let move_s = 0.2;
        let alpha: Vec<f64> = (0..TICKS)
            .map(|k| {
                let t = k as f64 * TICK_S;
                if t < move_s {
                    std::f64::consts::TAU * 0.2 / (move_s * move_s) * (std::f64::consts::TAU * t / move_s).sin()
                } else {
                    0.0
                }
            })
            .collect();
        let w = std::f64::consts::TAU * 4.0;
        let (mut r, mut rate) = (0.0, 0.0);
        let rocking = alpha
            .iter()
            .map(|a| {
                let accel = -a - 2.0 * 0.1 * w * rate - w * w * r;
                rate += accel * TICK_S;
                r += rate * TICK_S;
                accel
            })
            .collect();
        (alpha, rocking)
    }

    /// Cells whose traces are `lever * alpha + share * rocking` per axis, m,
    /// summed over `repeats` alternating steps with the BMA250's noise.
    fn summed(cells: &[([f64; 3], [f64; 3])], repeats: usize, seed: u64) -> Sums {
        let (alpha, rocking) = step();
        let g = [0.0, 0.0, 9.81];
        let window = Window {
            mean: vec![g; cells.len()],
            var: vec![[NOISE * NOISE; 3]; cells.len()],
            n: vec![25; cells.len()],
            saturated: vec![false; cells.len()],
        };
        let noise = Normal::new(0.0, NOISE).unwrap();
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut sums = Sums::new(cells.len());
        for n in 0..repeats {
            let sign = if n % 2 == 0 { 1.0 } else { -1.0 };
            let mut accel = Vec::with_capacity(TICKS * cells.len());
            for (a, r) in alpha.iter().zip(&rocking) {
                for (lever, share) in cells {
                    accel.push(std::array::from_fn(|x| {
                        (g[x] + sign * (lever[x] * a + share[x] * r) + noise.sample(&mut rng)) as f32
                    }));
                }
            }
            let q = (0..TICKS).map(|k| sign * 0.2 * (k + 1) as f64 / TICKS as f64).collect();
            let trace = Trace {
                accel,
                q0: 0.0,
                q,
                start: Vec::new(),
                positions: Vec::new(),
                saturated: vec![false; cells.len()],
            };
            let signed: Vec<f64> = alpha.iter().map(|a| sign * a).collect();
            sums.add(&window, &window, &trace, &signed, &vec![NOISE * NOISE; cells.len()]);
        }
        sums
    }

    #[test]
    fn the_base_rocking_is_regressed_out_and_a_real_lever_kept() {
        // Twelve still cells, each rocking in its own proportion and frame
        // (1-3 mm of fake lever per unit joint acceleration), a still cell
        // rocking the most, and a cell that moves 1 mm per rad/s^2 and rocks.
        let mut cells: Vec<([f64; 3], [f64; 3])> = (0..12)
            .map(|i| {
                let f = 1e-3 * (1.0 + i as f64 / 6.0);
                ([0.0; 3], [f * (i as f64).cos(), f * (i as f64).sin(), 0.3 * f])
            })
            .collect();
        cells.push(([0.0; 3], [0.0, 3e-3, 1e-3]));
        cells.push(([1e-3, 0.0, 0.0], [2e-3, 0.0, 0.0]));
        let mut sums = summed(&cells, 400, 7);
        sums.update(&(0..12).collect::<Vec<_>>(), &[12, 13], 8);
        let k = 6.0;
        let (still, sigma) = sums.lever(12).unwrap();
        assert!(sigma < 1e-4, "sigma {sigma}");
        assert!(still < k * sigma, "a still cell keeps {still} m of lever (sigma {sigma})");
        let (moved, sigma) = sums.lever(13).unwrap();
        assert!((moved - 1e-3).abs() < k * sigma, "the moving cell's lever is {moved} m, not 1 mm (sigma {sigma})");
        // Without the reference the rocking shows as a lever of millimetres.
        let plain = LeastSquares::new(step().0.iter().map(|&a| [1.0, a]).collect()).unwrap();
        let [x, y, z] = sums.fit(&plain, 12).unwrap().map(|c| c[1] / 400.0);
        assert!(
            (x * x + y * y + z * z).sqrt() > 1e-3,
            "the rocking fakes a lever of {} m",
            (x * x + y * y + z * z).sqrt()
        );
    }

    #[test]
    fn too_few_references_give_no_lever() {
        let cells = vec![([0.0; 3], [1e-3, 0.0, 0.0]); 5];
        let mut sums = summed(&cells, 20, 1);
        sums.update(&[0, 1, 2, 3], &[4], 8);
        assert_eq!(sums.lever(4), None);
        sums.update(&[0, 1, 2, 3], &[4], 4);
        assert!(sums.lever(4).is_some());
    }
}
