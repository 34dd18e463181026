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
//!   `g |step|`), estimated from the cells that clearly changed. Because the
//!   change does not depend on where a cell sits, a cell clearly below the
//!   threshold is still wherever it is: the static test has the power to
//!   decide "still" for every cell, once one cell has shown the change.
//! - *dynamic* (equations 1-2, past the paper): during the step, the
//!   acceleration not explained by the slowly turning gravity is regressed
//!   on the DoF's angular acceleration. The coefficient is the cell's lever
//!   arm `axis x r` in its own frame (metres), non-zero for every moved cell
//!   off the axis, even when the axis is vertical and the static test is
//!   blind (UR5's and Panda's first joint). Its power depends on the place:
//!   a cell on the axis shows nothing whether it moved or not, so a small
//!   lever never decides "still" for a revolute DoF. For a prismatic DoF
//!   the coefficient is the axis itself, of length 1 wherever the cell is,
//!   so it decides both ways.
//!
//! Both tests are decided with a margin of `confidence_sigmas` standard
//! deviations of their own noise; what neither can decide stays
//! [`Activity::Unknown`] with the [`Doubt`] that kept it there, and is
//! measured again, never guessed.

use super::fit::LeastSquares;
use super::session::{Trace, Window};
use super::StructureConfig;
use crate::robot::DofKind;
use skin_protocol::message::G0;

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

/// What decided an entry.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Basis {
    /// The gravity vector turned with the DoF (or clearly did not) in the
    /// posture of that index (see [`Exploration::postures`](super::Exploration::postures)).
    Static {
        /// Index of the posture.
        posture: usize,
    },
    /// The tangential acceleration of a step in that posture.
    Dynamic {
        /// Index of the posture.
        posture: usize,
    },
    /// Implied by decided entries: in a kinematic tree, the cells two DoFs
    /// move are nested or disjoint.
    Tree,
    /// No lever to the DoF's untiltable, gravity-aligned axis (or from its
    /// coupled joints), and by the mounting clearance (declared, or the
    /// default) no cell sits that close to a moving axis.
    Clearance,
}

/// Why an entry is still undecided.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Doubt {
    /// The evidence is within the noise of a threshold: more averaging or a
    /// larger step decides it.
    Noise,
    /// The DoF's axis is aligned with gravity (the static test is blind)
    /// and the cell shows no lever to it: it is still, or on the axis.
    /// Only tilting the axis decides it.
    NearAxis,
    /// The accelerometer saturated during the measurement.
    Saturated,
    /// The DoF turns the cells it moves by different rotations (coupled
    /// joints, mimics), so a cell that shows no change may still move.
    Coupled,
}

/// Cells x DoFs of [`Activity`] entries, each with what decided it.
#[derive(Clone, Debug, PartialEq)]
pub struct ActivityMatrix {
    cells: usize,
    dofs: usize,
    entries: Vec<Activity>,
    basis: Vec<Option<Basis>>,
}

impl ActivityMatrix {
    /// All entries [`Activity::Unknown`].
    pub fn unknown(cells: usize, dofs: usize) -> ActivityMatrix {
        ActivityMatrix { cells, dofs, entries: vec![Activity::Unknown; cells * dofs], basis: vec![None; cells * dofs] }
    }

    /// A decided matrix from rows of booleans (one row per cell).
    pub fn from_rows(rows: &[Vec<bool>]) -> ActivityMatrix {
        let dofs = rows.first().map_or(0, Vec::len);
        let entries: Vec<Activity> =
            rows.iter().flat_map(|r| r.iter().map(|&m| if m { Activity::Moved } else { Activity::Still })).collect();
        ActivityMatrix { cells: rows.len(), dofs, basis: vec![None; entries.len()], entries }
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

    /// What decided the entry of cell `u` and DoF `d` (`None` while undecided).
    pub fn basis(&self, u: usize, d: usize) -> Option<Basis> {
        self.basis[u * self.dofs + d]
    }

    /// Ors `a` into the entry of cell `u` and DoF `d`, noting `basis` when
    /// it changes the entry; true if it did.
    pub fn or(&mut self, u: usize, d: usize, a: Activity, basis: Basis) -> bool {
        let i = u * self.dofs + d;
        let new = self.entries[i].or(a);
        if new == self.entries[i] {
            return false;
        }
        self.entries[i] = new;
        self.basis[i] = Some(basis);
        true
    }

    /// True where the DoF moves the cell (the binary matrix `AM`).
    pub fn is_moved(&self, u: usize, d: usize) -> bool {
        self.get(u, d) == Activity::Moved
    }

    /// True where the DoF surely does not move the cell.
    pub fn is_still(&self, u: usize, d: usize) -> bool {
        self.get(u, d) == Activity::Still
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

    /// DoF `d` has undecided entries.
    pub fn column_undecided(&self, d: usize) -> bool {
        (0..self.cells).any(|u| self.get(u, d) == Activity::Unknown)
    }
}

/// The evidence one step gives about one cell.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Evidence {
    /// Equation (4) scaled to m/s^2: `g |g_pre/|g_pre| - g_post/|g_post||`.
    pub static_mps2: f64,
    /// Standard deviation of one axis of that difference, m/s^2.
    pub static_sigma: f64,
    /// Lever arm `|axis x r|` seen through the tangential acceleration, m
    /// (for a prismatic DoF: the length of the axis in the cell frame, 1).
    pub lever_m: f64,
    /// The lever vector in the cell frame, m (zero without a fit).
    pub lever: [f64; 3],
    /// Standard deviation of one axis of the lever estimate, m.
    pub lever_sigma: f64,
    /// Variance of one sample on the noisiest axis, (m/s^2)^2.
    pub noise_var: f64,
    /// The still windows saturated: no static evidence.
    pub static_saturated: bool,
    /// The motion saturated: the lever is underestimated, never "still".
    pub trace_saturated: bool,
}

/// How far (as a fraction of the median change) a moved cell's gravity
/// change may differ from the others' before the DoF counts as coupled:
/// sensor gains and misalignment stay well within it.
const COUPLED_SPREAD: f64 = 0.25;

/// A lever this many times `lever_threshold_m` is a movement even where
/// the base rocks: three times the largest rocking seen.
pub(crate) const SURE_LEVER: f64 = 3.0;

/// What one step says about one cell.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Reading {
    /// Moved, by the static (`true`) or dynamic test.
    Moved { by_static: bool },
    /// Still, by the static (`true`) or dynamic test.
    Still { by_static: bool },
    /// Undecided, and why.
    Unknown(Doubt),
}

/// What one step says of its DoF as a whole (see [`Step::verdict`]).
struct Verdict {
    blind: bool,
    /// Half the median gravity change, at least `floor`, m/s^2.
    threshold: f64,
    /// The paper's static threshold, m/s^2.
    floor: f64,
    coupled: bool,
}

/// What one step of one DoF says about every cell.
pub(crate) struct Step {
    /// Evidence per cell.
    pub evidence: Vec<Evidence>,
    /// The step the DoF really made (position feedback), rad or m.
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
                    lever: lever.unwrap_or([0.0; 3]),
                    lever_sigma: (worst_var * regressors.alpha_variance()).sqrt(),
                    noise_var: worst_var,
                    static_saturated: pre.saturated[u] || post.saturated[u],
                    trace_saturated: trace.saturated[u] || lever.is_none(),
                }
            })
            .collect();
        Step { evidence, moved_rad }
    }

    /// The paper's static threshold for this step: a fraction of the
    /// largest change, `g |step|`.
    fn floor(&self, cfg: &StructureConfig) -> f64 {
        cfg.static_fraction * G0 * self.moved_rad.abs()
    }

    /// True when no cell's gravity change could pass the static floor
    /// however long the averaging: the axis is within about 6 degrees of
    /// gravity in this posture, and only another posture helps.
    pub fn surely_blind(&self, cfg: &StructureConfig) -> bool {
        let floor = self.floor(cfg);
        self.evidence
            .iter()
            .all(|e| e.static_saturated || e.static_mps2 + cfg.confidence_sigmas * e.static_sigma < floor)
    }

    /// What the step says of the DoF as a whole: whether the static test
    /// was blind (no cell showed a gravity change above the paper's
    /// threshold: a revolute axis within about 6 degrees of vertical in
    /// this posture, or a prismatic DoF, which turns nothing), the static
    /// threshold, and whether the DoF is coupled.
    fn verdict(&self, cfg: &StructureConfig, kind: DofKind) -> Verdict {
        let k = cfg.confidence_sigmas;
        let floor = self.floor(cfg);
        let mut changed: Vec<f64> = if kind == DofKind::Prismatic {
            Vec::new()
        } else {
            self.evidence
                .iter()
                .filter(|e| !e.static_saturated && e.static_mps2 - k * e.static_sigma > floor)
                .map(|e| e.static_mps2)
                .collect()
        };
        let blind = changed.is_empty();
        let threshold = if blind {
            floor
        } else {
            changed.sort_by(f64::total_cmp);
            (changed[changed.len() / 2] / 2.0).max(floor)
        };
        // One joint turns every cell it moves by the same rotation. Changes
        // that differ more than that (mimic joints with other ratios or
        // axes) mean a moved cell may show none: no "still" from gravity.
        let median = changed.get(changed.len() / 2).copied().unwrap_or(0.0);
        // So does a cell that clearly moved without turning (a parallel
        // gripper's fingertip, its mimics' turns cancelling).
        let coupled = self.evidence.iter().any(|e| {
            let unequal = !e.static_saturated && e.static_mps2 - k * e.static_sigma > floor && {
                let spread = (e.static_mps2 - median).abs() - k * e.static_sigma;
                spread > COUPLED_SPREAD * median
            };
            let unturned = !blind && e.static_mps2 + k * e.static_sigma < threshold;
            unequal || (unturned && e.lever_m - k * e.lever_sigma > SURE_LEVER * cfg.lever_threshold_m)
        });
        Verdict { blind, threshold, floor, coupled }
    }

    /// Per cell, the smallest lever to the DoF this one step would have
    /// decided as a movement, m: 0 where the static test had power (every
    /// cell a revolute DoF moves turns with it, on its axis too) or the DoF
    /// is prismatic (a moved cell shows the whole axis wherever it sits);
    /// else the lever threshold of [`Step::decide`] plus the margin of the
    /// lever's noise (infinite where the motion saturated).
    pub fn seen(&self, cfg: &StructureConfig, kind: DofKind) -> Vec<f64> {
        let v = self.verdict(cfg, kind);
        let k = cfg.confidence_sigmas;
        self.evidence
            .iter()
            .map(|e| {
                if kind == DofKind::Prismatic || (!v.blind && !v.coupled && !e.static_saturated) {
                    0.0
                } else if e.trace_saturated || !e.lever_sigma.is_finite() {
                    f64::INFINITY
                } else {
                    let moved = if v.coupled { SURE_LEVER } else { 1.0 } * cfg.lever_threshold_m;
                    moved + k * e.lever_sigma
                }
            })
            .collect()
    }

    /// Reads every cell, and tells whether the DoF was static-blind (see
    /// [`Step::verdict`]).
    pub fn decide(&self, cfg: &StructureConfig, kind: DofKind) -> (Vec<Reading>, bool) {
        let k = cfg.confidence_sigmas;
        let Verdict { blind, threshold, floor, coupled } = self.verdict(cfg, kind);
        // A lever below this can be the base rocking, not a movement: a
        // standing robot still rings from the step before. Repeats of a
        // blind step, pooled once the ringing is gone, go down to
        // `axis_lever_m` (see `structure`).
        let lever_moved = match kind {
            DofKind::Prismatic => 0.5,
            DofKind::Revolute => cfg.lever_threshold_m,
        };
        // Where the static test has power it decides alone: a standing
        // robot rocks with every horizontal joint acceleration, near its
        // resonance enough to fake a lever of a centimetre.
        // A coupled DoF turns its cells by one, two or more rotations (a
        // finger's phalanges), so half the median change can exceed a
        // single one: there any change above the paper's floor is a turn.
        let moved_above = if coupled { floor } else { threshold };
        let readings = self
            .evidence
            .iter()
            .map(|e| {
                let static_known = !e.static_saturated && !blind;
                let static_hi = static_known && e.static_mps2 - k * e.static_sigma > moved_above;
                let static_lo = static_known && !coupled && e.static_mps2 + k * e.static_sigma < threshold;
                let lever = e.lever_m - k * e.lever_sigma;
                let lever_hi = (lever > lever_moved && (blind || e.static_saturated))
                    || (coupled && lever > SURE_LEVER * cfg.lever_threshold_m);
                let lever_lo = !e.trace_saturated && e.lever_m + k * e.lever_sigma < lever_moved;
                if static_hi || lever_hi {
                    Reading::Moved { by_static: static_hi }
                } else if static_lo {
                    Reading::Still { by_static: true }
                } else if kind == DofKind::Prismatic && lever_lo {
                    // A moved cell shows the whole axis wherever it sits.
                    Reading::Still { by_static: false }
                } else if e.static_saturated || e.trace_saturated {
                    Reading::Unknown(Doubt::Saturated)
                } else if coupled {
                    Reading::Unknown(Doubt::Coupled)
                } else if blind && !e.trace_saturated && e.lever_m + k * e.lever_sigma < cfg.axis_lever_m {
                    Reading::Unknown(Doubt::NearAxis)
                } else {
                    Reading::Unknown(Doubt::Noise)
                }
            })
            .collect();
        (readings, blind)
    }
}

/// The DoF's motion during a trace as regressors of the lever test: a
/// constant, the angular acceleration (the lever) and the squared velocity.
struct Regressors {
    fit: Option<LeastSquares<3>>,
    /// Position relative to the start, rad.
    phi: Vec<f64>,
}

impl Regressors {
    fn new(trace: &Trace, tick_s: f64) -> Regressors {
        let (phi, omega, alpha) = trace.motion(tick_s);
        let rows = alpha.iter().zip(&omega).map(|(a, w)| [1.0, *a, w * w]).collect();
        Regressors { fit: LeastSquares::new(rows), phi }
    }

    /// Variance of the lever per unit sample variance (infinite without a fit).
    fn alpha_variance(&self) -> f64 {
        match &self.fit {
            Some(f) if f.variance_factor(1) > 0.0 => f.variance_factor(1),
            _ => f64::INFINITY,
        }
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
        let fit = self.fit.as_ref()?;
        let mut lever = [0.0; 3];
        for (a, l) in lever.iter_mut().enumerate() {
            let residual = (0..trace.len()).map(|k| {
                let turned = if moved != 0.0 { self.phi[k] / moved } else { 0.0 };
                unexplained(trace.accel[k * cells + u], g0, g1, turned)[a]
            });
            *l = fit.fit(residual)?[1];
        }
        Some(lever)
    }
}

/// A sample's acceleration less gravity, turned from `g0` a fraction
/// `turned` of the way to `g1` with the DoF, m/s^2.
pub(crate) fn unexplained(sample: [f32; 3], g0: &[f64; 3], g1: &[f64; 3], turned: f64) -> [f64; 3] {
    std::array::from_fn(|a| f64::from(sample[a]) - g0[a] - (g1[a] - g0[a]) * turned)
}

fn norm(v: &[f64; 3]) -> f64 {
    (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn window(mean: [f64; 3], var: f64, n: u32, saturated: bool) -> Window {
        Window { mean: vec![mean], var: vec![[var; 3]], n: vec![n], saturated: vec![saturated] }
    }

    fn trace(accel: Vec<[f32; 3]>, q: Vec<f64>) -> Trace {
        Trace { accel, q0: 0.0, q, start: Vec::new(), positions: Vec::new(), saturated: vec![false] }
    }

    /// Any float at all, the edges included.
    fn edgy() -> impl Strategy<Value = f64> {
        prop_oneof![
            Just(0.0),
            Just(-0.0),
            Just(f64::NAN),
            Just(f64::INFINITY),
            Just(f64::MIN_POSITIVE),
            Just(f64::MAX),
            -20.0f64..20.0,
        ]
    }

    proptest! {
        #[test]
        fn any_numbers_give_a_decision_or_unknown_never_a_panic(
            mean0 in prop::array::uniform3(edgy()), mean1 in prop::array::uniform3(edgy()),
            var in edgy(), n in 2u32..500, saturated in any::<bool>(),
            accel in prop::collection::vec(prop::array::uniform3(edgy().prop_map(|x| x as f32)), 1..60),
            q in prop::collection::vec(edgy(), 1..60),
        ) {
            let len = accel.len().min(q.len());
            let t = trace(accel[..len].to_vec(), q[..len].to_vec());
            let step = Step::measure(&window(mean0, var, n, saturated), &window(mean1, var, n, false), &t, 0.004, 0.038);
            for kind in [DofKind::Revolute, DofKind::Prismatic] {
                let (readings, _) = step.decide(&StructureConfig::default(), kind);
                prop_assert_eq!(readings.len(), 1);
            }
        }

        #[test]
        fn nothing_changing_is_never_a_movement(
            g in prop::array::uniform3(-12.0f64..12.0), var in 0.0f64..0.1, n in 2u32..300, ticks in 1usize..80,
        ) {
            let still = trace(vec![g.map(|x| x as f32); ticks], vec![0.0; ticks]);
            let step = Step::measure(&window(g, var, n, false), &window(g, var, n, false), &still, 0.004, 0.038);
            for kind in [DofKind::Revolute, DofKind::Prismatic] {
                let (readings, _) = step.decide(&StructureConfig::default(), kind);
                prop_assert!(!matches!(readings[0], Reading::Moved { .. }), "{:?}", readings[0]);
            }
        }
    }

    #[test]
    fn nan_samples_decide_nothing() {
        let nan = [f64::NAN; 3];
        let t = trace(vec![[f32::NAN; 3]; 40], (0..40).map(|k| 0.0025 * f64::from(k)).collect());
        let step =
            Step::measure(&window(nan, f64::NAN, 50, false), &window(nan, f64::NAN, 50, false), &t, 0.004, 0.038);
        for kind in [DofKind::Revolute, DofKind::Prismatic] {
            assert!(matches!(step.decide(&StructureConfig::default(), kind).0[..], [Reading::Unknown(_)]));
        }
    }

    /// A still window at rest with gravity along `g`, datasheet-like noise.
    fn rest(g: [f64; 3]) -> Window {
        window(g, 0.03 * 0.03, 50, false)
    }

    /// A raised-cosine step of `delta` over 50 ticks, the cell seeing
    /// `lever` m of tangential acceleration along x (no noise).
    fn stepped(delta: f64, lever: f64, g: [f64; 3]) -> Trace {
        let (tick, n) = (0.004, 50usize);
        let duration = tick * n as f64;
        let q: Vec<f64> = (1..=n)
            .map(|k| {
                let tau = (k as f64 * tick / duration).min(1.0);
                delta * (tau - (std::f64::consts::TAU * tau).sin() / std::f64::consts::TAU)
            })
            .collect();
        let t = Trace {
            accel: Vec::new(),
            q0: 0.0,
            q: q.clone(),
            start: Vec::new(),
            positions: Vec::new(),
            saturated: vec![false],
        };
        let (_, _, alpha) = t.motion(tick);
        let accel = alpha.iter().map(|a| [(g[0] + lever * a) as f32, g[1] as f32, g[2] as f32]).collect();
        Trace { accel, ..t }
    }

    #[test]
    fn a_cell_on_a_vertical_axis_is_unknown_never_still() {
        // Gravity along the cell's z; a vertical axis turns nothing the
        // accelerometer sees, so the static test is blind.
        let g = [0.0, 0.0, G0];
        let cfg = StructureConfig::default();
        for lever in [0.0, 1e-4, 2e-4] {
            let step = Step::measure(&rest(g), &rest(g), &stepped(0.2, lever, g), 0.004, 0.038);
            let (readings, blind) = step.decide(&cfg, DofKind::Revolute);
            assert!(blind);
            assert_eq!(readings[0], Reading::Unknown(Doubt::NearAxis), "lever {lever} m");
        }
        // A lever of 3 cm is a movement in one step, with or without
        // gravity's help (smaller ones need pooled repeats: `structure`).
        let step = Step::measure(&rest(g), &rest(g), &stepped(0.2, 0.03, g), 0.004, 0.038);
        assert_eq!(step.decide(&cfg, DofKind::Revolute).0[0], Reading::Moved { by_static: false });
    }

    #[test]
    fn one_step_sees_any_lever_where_gravity_tells_and_only_large_ones_about_a_vertical_axis() {
        let cfg = StructureConfig::default();
        // About a vertical axis the gravity test is blind: only a lever
        // above the threshold, with its noise margin, is seen.
        let g = [0.0, 0.0, G0];
        let blind = Step::measure(&rest(g), &rest(g), &stepped(0.2, 0.0, g), 0.004, 0.038);
        let seen = blind.seen(&cfg, DofKind::Revolute)[0];
        assert!(seen > cfg.lever_threshold_m && seen < 2.0 * cfg.lever_threshold_m, "{seen} m");
        // Turning gravity by the step: a cell on the axis shows it too.
        let turned = [G0 * 0.2f64.sin(), 0.0, G0 * 0.2f64.cos()];
        let tilted = Step::measure(&rest(g), &rest(turned), &stepped(0.2, 0.0, g), 0.004, 0.038);
        assert_eq!(tilted.seen(&cfg, DofKind::Revolute), vec![0.0]);
        // A prismatic DoF shows its axis wherever the cell sits.
        assert_eq!(blind.seen(&cfg, DofKind::Prismatic), vec![0.0]);
    }

    #[test]
    fn a_prismatic_dof_decides_still_from_the_missing_axis() {
        let g = [0.0, 0.0, G0];
        let cfg = StructureConfig::default();
        let still = Step::measure(&rest(g), &rest(g), &stepped(0.02, 0.0, g), 0.004, 0.038);
        assert_eq!(still.decide(&cfg, DofKind::Prismatic).0[0], Reading::Still { by_static: false });
        let moved = Step::measure(&rest(g), &rest(g), &stepped(0.02, 1.0, g), 0.004, 0.038);
        assert_eq!(moved.decide(&cfg, DofKind::Prismatic).0[0], Reading::Moved { by_static: false });
    }

    #[test]
    fn a_saturated_cell_is_never_still_by_its_lever() {
        let g = [0.0, 0.0, G0];
        let mut trace = stepped(0.2, 0.0, g);
        trace.saturated = vec![true];
        let step = Step::measure(&rest(g), &rest(g), &trace, 0.004, 0.038);
        assert_eq!(
            step.decide(&StructureConfig::default(), DofKind::Revolute).0[0],
            Reading::Unknown(Doubt::Saturated)
        );
    }

    #[test]
    fn or_prefers_a_sure_movement_then_a_sure_stillness() {
        use Activity::*;
        assert_eq!(Unknown.or(Moved), Moved);
        assert_eq!(Still.or(Moved), Moved);
        assert_eq!(Unknown.or(Still), Still);
        assert_eq!(Unknown.or(Unknown), Unknown);
    }
}
