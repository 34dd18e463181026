//! The activity matrix (section 4.2.1): which DoF moves which cell.
//!
//! Each DoF is stepped by a small angle, one after the other, with the
//! robot still before and after. Two independent pieces of evidence say
//! whether a cell moved:
//!
//! - *static* (equation 4): the normalized gravity vector measured before
//!   and after the step. Every cell the DoF moves turns by the same rotation,
//!   so all of them see the same change `g |step| sin(beta)`, `beta` the angle
//!   between the axis and gravity; cells it does not move see none. The
//!   threshold is half that common change (at least the paper's 10 % of
//!   `g |step|`), estimated from the cells that clearly changed.
//! - *dynamic* (equations 1-2, past the paper): during the step, the
//!   acceleration not explained by the slowly turning gravity is regressed
//!   on the DoF's angular acceleration. The coefficient is the cell's lever
//!   arm `axis x r` in its own frame (metres), non-zero for every moved cell
//!   off the axis, even when the axis is vertical and the static test is
//!   blind (UR5's and Panda's first joint).
//!
//! Both tests are decided with a margin of `confidence_sigmas` standard
//! deviations of their own noise; what neither can decide stays
//! [`Activity::Unknown`] and is measured again, never guessed.

use super::session::{Trace, Window};
use super::StructureConfig;
use skin_sim::accel::G0;

/// One entry of the activity matrix.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Activity {
    /// The DoF moves the cell.
    Moved,
    /// The DoF does not move the cell.
    Still,
    /// Not decided (yet): the evidence is within the noise of a threshold.
    Unknown,
}

impl Activity {
    /// The element-wise "or" of two postural runs or repeated measurements:
    /// one sure movement is enough, and a sure "still" beats no decision.
    pub fn or(self, other: Activity) -> Activity {
        use Activity::*;
        match (self, other) {
            (Moved, _) | (_, Moved) => Moved,
            (Still, _) | (_, Still) => Still,
            (Unknown, Unknown) => Unknown,
        }
    }
}

/// Cells x DoFs of [`Activity`] entries.
#[derive(Clone, Debug, PartialEq)]
pub struct ActivityMatrix {
    cells: usize,
    dofs: usize,
    entries: Vec<Activity>,
}

impl ActivityMatrix {
    /// All entries [`Activity::Unknown`].
    pub fn unknown(cells: usize, dofs: usize) -> ActivityMatrix {
        ActivityMatrix { cells, dofs, entries: vec![Activity::Unknown; cells * dofs] }
    }

    /// A decided matrix from rows of booleans (one row per cell).
    pub fn from_rows(rows: &[Vec<bool>]) -> ActivityMatrix {
        let dofs = rows.first().map_or(0, Vec::len);
        let entries =
            rows.iter().flat_map(|r| r.iter().map(|&m| if m { Activity::Moved } else { Activity::Still })).collect();
        ActivityMatrix { cells: rows.len(), dofs, entries }
    }

    /// Number of cells (rows).
    pub fn cells(&self) -> usize {
        self.cells
    }

    /// Number of DoFs (columns).
    pub fn dofs(&self) -> usize {
        self.dofs
    }

    /// The entry of cell `u` and DoF `d`.
    pub fn get(&self, u: usize, d: usize) -> Activity {
        self.entries[u * self.dofs + d]
    }

    /// Ors `a` into the entry of cell `u` and DoF `d`.
    pub fn or(&mut self, u: usize, d: usize, a: Activity) {
        let e = &mut self.entries[u * self.dofs + d];
        *e = e.or(a);
    }

    /// True where the DoF moves the cell (the binary matrix `AM`).
    pub fn is_moved(&self, u: usize, d: usize) -> bool {
        self.get(u, d) == Activity::Moved
    }

    /// The binary rows, `Unknown` read as not moved.
    pub fn rows(&self) -> Vec<Vec<bool>> {
        (0..self.cells).map(|u| (0..self.dofs).map(|d| self.is_moved(u, d)).collect()).collect()
    }

    /// `(cell, dof)` of every undecided entry.
    pub fn undecided(&self) -> Vec<(usize, usize)> {
        (0..self.cells)
            .flat_map(|u| (0..self.dofs).map(move |d| (u, d)))
            .filter(|&(u, d)| self.get(u, d) == Activity::Unknown)
            .collect()
    }
}

/// The evidence one step gives about one cell.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Evidence {
    /// Equation (4) scaled to m/s^2: `g |g_pre/|g_pre| - g_post/|g_post||`.
    pub static_mps2: f64,
    /// Standard deviation of one axis of that difference, m/s^2.
    pub static_sigma: f64,
    /// Lever arm `|axis x r|` seen through the tangential acceleration, m.
    pub lever_m: f64,
    /// Standard deviation of one axis of the lever estimate, m.
    pub lever_sigma: f64,
    /// The still windows saturated: no static evidence.
    pub static_saturated: bool,
    /// The motion saturated: the lever is underestimated, never "still".
    pub trace_saturated: bool,
}

/// What one step of one DoF says about every cell.
pub(crate) struct Step {
    /// Evidence per cell.
    pub evidence: Vec<Evidence>,
    /// The step the DoF really made (position feedback), rad.
    pub moved_rad: f64,
}

impl Step {
    /// Gathers the evidence of a step from the still windows before and
    /// after it and the trace recorded while it moved and settled.
    pub fn measure(pre: &Window, post: &Window, trace: &Trace, tick_s: f64, lsb_mps2: f64) -> Step {
        let moved_rad = trace.q.last().map_or(0.0, |q| q - trace.q0);
        let regressors = Regressors::new(trace, tick_s);
        let cells = pre.mean.len();
        let evidence = (0..cells)
            .map(|u| {
                // Sample noise per axis, floored at the quantization noise.
                let noise_var: [f64; 3] = std::array::from_fn(|a| {
                    let pooled = (pre.var[u][a] * f64::from(pre.n[u] - 1) + post.var[u][a] * f64::from(post.n[u] - 1))
                        / f64::from(pre.n[u] + post.n[u] - 2);
                    pooled.max(lsb_mps2 * lsb_mps2 / 12.0)
                });
                let worst_var = noise_var.iter().copied().fold(0.0, f64::max);
                let (g0, g1) = (pre.mean[u], post.mean[u]);
                let (n0, n1) = (norm(&g0), norm(&g1));
                let diff: [f64; 3] = std::array::from_fn(|a| G0 * (g0[a] / n0 - g1[a] / n1));
                let static_sigma = (worst_var / f64::from(pre.n[u]) + worst_var / f64::from(post.n[u])).sqrt() * G0
                    / n0.min(n1).max(1e-9);
                let lever = regressors.lever(trace, u, cells, &g0, &g1, moved_rad);
                Evidence {
                    static_mps2: norm(&diff),
                    static_sigma,
                    lever_m: lever.map_or(0.0, |l| norm(&l)),
                    lever_sigma: (worst_var * regressors.alpha_variance).sqrt(),
                    static_saturated: pre.saturated[u] || post.saturated[u],
                    trace_saturated: trace.saturated[u] || lever.is_none(),
                }
            })
            .collect();
        Step { evidence, moved_rad }
    }

    /// Decides every cell, and tells whether the DoF was static-blind
    /// (no cell showed a gravity change above the paper's threshold: its
    /// axis is within about 6 degrees of vertical in this posture).
    pub fn decide(&self, cfg: &StructureConfig) -> (Vec<Activity>, bool) {
        let k = cfg.confidence_sigmas;
        let floor = cfg.static_fraction * G0 * self.moved_rad.abs();
        let mut changed: Vec<f64> = self
            .evidence
            .iter()
            .filter(|e| !e.static_saturated && e.static_mps2 - k * e.static_sigma > floor)
            .map(|e| e.static_mps2)
            .collect();
        let blind = changed.is_empty();
        let threshold = if blind {
            floor
        } else {
            changed.sort_by(f64::total_cmp);
            (changed[changed.len() / 2] / 2.0).max(floor)
        };
        let decisions = self
            .evidence
            .iter()
            .map(|e| {
                let static_known = !e.static_saturated && !blind;
                let static_hi = static_known && e.static_mps2 - k * e.static_sigma > threshold;
                let static_lo = static_known && e.static_mps2 + k * e.static_sigma < threshold;
                let lever_hi = e.lever_m - k * e.lever_sigma > cfg.lever_threshold_m;
                let lever_lo = !e.trace_saturated && e.lever_m + k * e.lever_sigma < cfg.lever_threshold_m;
                if static_hi || lever_hi {
                    Activity::Moved
                } else if static_lo || (blind && lever_lo) {
                    Activity::Still
                } else {
                    Activity::Unknown
                }
            })
            .collect();
        (decisions, blind)
    }
}

/// The DoF's angular acceleration and squared velocity during a trace,
/// from position feedback, and the variance factor of the acceleration
/// coefficient in a least-squares fit on `[1, alpha, omega^2]`.
struct Regressors {
    alpha: Vec<f64>,
    omega_sq: Vec<f64>,
    /// Rows of the inverse normal matrix.
    inverse: [[f64; 3]; 3],
    alpha_variance: f64,
    /// Position relative to the start, rad.
    phi: Vec<f64>,
}

impl Regressors {
    fn new(trace: &Trace, tick_s: f64) -> Regressors {
        let (phi, omega, alpha) = trace.motion(tick_s);
        let omega_sq: Vec<f64> = omega.iter().map(|w| w * w).collect();
        let mut normal = [[0.0; 3]; 3];
        for (a, w2) in alpha.iter().zip(&omega_sq) {
            let x = [1.0, *a, *w2];
            for i in 0..3 {
                for j in 0..3 {
                    normal[i][j] += x[i] * x[j];
                }
            }
        }
        let inverse = invert3(&normal).unwrap_or([[0.0; 3]; 3]);
        let alpha_variance = if inverse[1][1] > 0.0 { inverse[1][1] } else { f64::INFINITY };
        Regressors { alpha, omega_sq, inverse, alpha_variance, phi }
    }

    /// The acceleration coefficient per axis of cell `u`, m, after removing
    /// gravity turning from `g0` to `g1` along with the DoF; `None` if the
    /// trace has gaps or the motion carries no acceleration to regress on.
    fn lever(
        &self,
        trace: &Trace,
        u: usize,
        cells: usize,
        g0: &[f64; 3],
        g1: &[f64; 3],
        moved: f64,
    ) -> Option<[f64; 3]> {
        if !self.alpha_variance.is_finite() {
            return None;
        }
        let mut lever = [0.0; 3];
        for (a, l) in lever.iter_mut().enumerate() {
            let mut xz = [0.0; 3];
            for k in 0..trace.len() {
                let y = f64::from(trace.accel[k * cells + u][a]);
                if !y.is_finite() {
                    return None;
                }
                let turned = if moved.abs() > 0.0 { (g1[a] - g0[a]) * self.phi[k] / moved } else { 0.0 };
                let z = y - g0[a] - turned;
                xz[0] += z;
                xz[1] += self.alpha[k] * z;
                xz[2] += self.omega_sq[k] * z;
            }
            *l = (0..3).map(|j| self.inverse[1][j] * xz[j]).sum();
        }
        Some(lever)
    }
}

fn norm(v: &[f64; 3]) -> f64 {
    (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()
}

/// Inverse of a symmetric 3x3 matrix, if it is not singular.
fn invert3(m: &[[f64; 3]; 3]) -> Option<[[f64; 3]; 3]> {
    let c = |i: usize, j: usize| {
        let (r0, r1) = ((i + 1) % 3, (i + 2) % 3);
        let (c0, c1) = ((j + 1) % 3, (j + 2) % 3);
        m[r0][c0] * m[r1][c1] - m[r0][c1] * m[r1][c0]
    };
    let det: f64 = (0..3).map(|j| m[0][j] * c(0, j)).sum();
    let scale = m.iter().flatten().map(|x| x.abs()).fold(0.0, f64::max).powi(3);
    if det.is_nan() || det.abs() <= 1e-12 * scale {
        return None;
    }
    // The cofactor matrix transposed, over the determinant.
    Some(std::array::from_fn(|i| std::array::from_fn(|j| c(j, i) / det)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn or_prefers_a_sure_movement_then_a_sure_stillness() {
        use Activity::*;
        assert_eq!(Unknown.or(Moved), Moved);
        assert_eq!(Still.or(Moved), Moved);
        assert_eq!(Unknown.or(Still), Still);
        assert_eq!(Unknown.or(Unknown), Unknown);
    }

    #[test]
    fn inverse_of_a_symmetric_matrix() {
        let m = [[4.0, 1.0, 2.0], [1.0, 3.0, 0.5], [2.0, 0.5, 5.0]];
        let inv = invert3(&m).unwrap();
        let product = |i: usize, j: usize| (0..3).map(|k| m[i][k] * inv[k][j]).sum::<f64>();
        for (i, j) in (0..3).flat_map(|i| (0..3).map(move |j| (i, j))) {
            assert!((product(i, j) - if i == j { 1.0 } else { 0.0 }).abs() < 1e-12);
        }
        assert_eq!(invert3(&[[1.0, 2.0, 3.0], [2.0, 4.0, 6.0], [0.0, 0.0, 1.0]]), None);
    }
}
