//! The sensory-motor map (section 4.3): per pose, how much each DoF moves
//! each cell along its surface normal.
//!
//! At a pose, every DoF in turn runs one period of the sine velocity
//! pattern of equations (5)-(9). Each cell's three axes are freed of their
//! mean (offset and gravity), low-pass filtered (bandwidth above ten times
//! the pattern frequency) and reduced to an amplitude and a sign (equations
//! (10)-(11)); the normal axis' share of the amplitudes is the weight of
//! equation (12). Weights of DoFs that do not move the cell are cut with the
//! activity matrix (equation 13); a cell whose weight vector is small cannot
//! be grounded on the static body part and is suppressed, the others are
//! normalized so reactions have the same strength along a kinematic chain.
//!
//! Past the paper, [`Evaluation::Regression`] (the default) fits each axis
//! on the DoF's own position, acceleration and squared velocity (from
//! position feedback), so the turning gravity and the centripetal term are
//! removed instead of neglected, and takes the normal share of the
//! tangential term: a quarter of the amplitudes' error against the truth.
//!
//! A weight is only as good as the motion behind it: where the fitted
//! tangential term is within the noise (a cell near the DoF's axis), the
//! regression gives the weight the defined value 0 and an infinite
//! standard error instead of a ratio of noise, so two explorations agree
//! on it; every other weight carries its standard error.
//!
//! Sign convention (that of equation 11): a weight of +1 means a positive
//! velocity of the DoF moves the cell into its surface, away from a touch,
//! so `omega = w * reaction` is an evasive motion.

use skin_protocol::message::AccelRange;
use skin_protocol::Address;

use super::activity::ActivityMatrix;
use super::fit::LeastSquares;
use super::lowpass::Butterworth;
use super::session::{Session, Trace};
use super::ExploreError;
use crate::robot::{DofKind, Robot, SampleSource};

/// How a pattern's accelerations become a weight.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Evaluation {
    /// Equations (10)-(12): shares of the low-passed axes' peak-to-peak amplitudes.
    Amplitudes,
    /// Least squares on the DoF's motion: shares of the tangential term alone.
    Regression,
}

/// Parameters of the sensory-motor exploration.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SmmConfig {
    /// Velocity amplitude `A` of equation (6), rad/s.
    pub amplitude_rad_s: f64,
    /// The same for a prismatic DoF, m/s.
    pub amplitude_m_s: f64,
    /// Pattern frequency `f`, Hz.
    pub frequency_hz: f64,
    /// Window length `T` of equation (9), s.
    pub duration_s: f64,
    /// Low-pass bandwidth `B`, Hz; must exceed ten times `f`.
    pub lowpass_hz: f64,
    /// The regression past the paper, or equations (10)-(12).
    pub evaluation: Evaluation,
    /// Still time before each pattern, s.
    pub settle_s: f64,
    /// Recording time after each pattern, s.
    pub tail_s: f64,
    /// Weight vectors shorter than this (Euclidean norm) are suppressed.
    pub suppression: f64,
    /// Speed limit when moving to a tile's pose, rad/s.
    pub move_speed_rad_s: f64,
    /// How close every DoF must get to a tile's pose, rad.
    pub pose_tolerance_rad: f64,
}

impl Default for SmmConfig {
    fn default() -> Self {
        SmmConfig {
            amplitude_rad_s: 0.4,
            amplitude_m_s: 0.04,
            frequency_hz: 2.0,
            duration_s: 0.5,
            lowpass_hz: 25.0,
            evaluation: Evaluation::Regression,
            settle_s: 0.1,
            tail_s: 0.1,
            suppression: 0.1,
            move_speed_rad_s: 0.5,
            pose_tolerance_rad: 2e-3,
        }
    }
}

impl SmmConfig {
    /// Refuses values the method cannot work with.
    pub fn check(&self, tick_s: f64) -> Result<(), ExploreError> {
        let positive = [
            self.amplitude_rad_s,
            self.amplitude_m_s,
            self.frequency_hz,
            self.duration_s,
            self.move_speed_rad_s,
            self.pose_tolerance_rad,
        ];
        if !positive.iter().all(|v| v.is_finite() && *v > 0.0) {
            return Err(ExploreError::Config(
                "the pattern amplitude, frequency, duration, speed and tolerance must be positive".into(),
            ));
        }
        if self.lowpass_hz.is_nan()
            || self.lowpass_hz <= 10.0 * self.frequency_hz
            || Butterworth::new(self.lowpass_hz, 1.0 / tick_s).is_none()
        {
            return Err(ExploreError::Config(format!(
                "the low-pass bandwidth must exceed ten times the pattern frequency ({} Hz) and stay below half the sampling rate ({} Hz)",
                10.0 * self.frequency_hz,
                0.5 / tick_s
            )));
        }
        if !(self.settle_s >= 0.0 && self.tail_s >= 0.0 && self.suppression >= 0.0) {
            return Err(ExploreError::Config("settle, tail and suppression must not be negative".into()));
        }
        Ok(())
    }

    /// Position of equation (5) cut by the rectangular window of (9), rad
    /// or m.
    fn position(&self, kind: DofKind, t: f64) -> f64 {
        let amplitude = match kind {
            DofKind::Revolute => self.amplitude_rad_s,
            DofKind::Prismatic => self.amplitude_m_s,
        };
        let w = std::f64::consts::TAU * self.frequency_hz;
        amplitude / w * (1.0 - (w * t.min(self.duration_s)).cos())
    }
}

/// One tile of the map: the weights explored at one pose.
#[derive(Clone, Debug, PartialEq)]
pub struct Tile {
    pose: Vec<f64>,
    dofs: usize,
    raw: Vec<f32>,
    sigma: Option<Vec<f32>>,
    weights: Vec<f32>,
    time_s: f64,
}

impl Tile {
    /// The pose the tile was explored in, rad.
    pub fn pose(&self) -> &[f64] {
        &self.pose
    }

    /// Reaction weights of cell `u` (one per DoF): decoupled, suppressed
    /// and normalized, what tactile control maps reactions through.
    pub fn weights(&self, u: usize) -> &[f32] {
        &self.weights[u * self.dofs..(u + 1) * self.dofs]
    }

    /// The weights of equation (12) of cell `u`, before decoupling.
    pub fn raw_weights(&self, u: usize) -> &[f32] {
        &self.raw[u * self.dofs..(u + 1) * self.dofs]
    }

    /// Standard errors of cell `u`'s raw weights, where the evaluation
    /// gives them (the regression): infinite where the motion was within
    /// the noise and the weight is the defined 0.
    pub fn raw_weight_sigmas(&self, u: usize) -> Option<&[f32]> {
        self.sigma.as_ref().map(|s| &s[u * self.dofs..(u + 1) * self.dofs])
    }

    /// Robot time spent exploring this tile, s.
    pub fn exploration_time_s(&self) -> f64 {
        self.time_s
    }

    /// Joint velocities for per-cell reactions `(cell, strength)`: the sum
    /// over cells of weight vector times strength (equation 14).
    pub fn joint_velocities(&self, reactions: &[(usize, f64)]) -> Vec<f64> {
        let mut omega = vec![0.0; self.dofs];
        for &(u, r) in reactions {
            for (o, w) in omega.iter_mut().zip(self.weights(u)) {
                *o += f64::from(*w) * r;
            }
        }
        omega
    }
}

/// The sensory-motor map: tiles of weights, recalled by nearest pose.
#[derive(Clone, Debug)]
pub struct SensoryMotorMap {
    cells: Vec<Address>,
    kinds: Vec<DofKind>,
    activity: ActivityMatrix,
    range: AccelRange,
    cfg: SmmConfig,
    tiles: Vec<Tile>,
}

impl SensoryMotorMap {
    /// Explores the first tile at `pose`.
    pub(crate) fn explore<R: Robot + SampleSource>(
        session: &mut Session<'_, R>,
        activity: ActivityMatrix,
        kinds: &[DofKind],
        range: AccelRange,
        cfg: SmmConfig,
        pose: &[f64],
        progress: &mut dyn FnMut(usize),
    ) -> Result<SensoryMotorMap, ExploreError> {
        cfg.check(session.tick_s())?;
        let mut map = SensoryMotorMap {
            cells: session.cells().to_vec(),
            kinds: kinds.to_vec(),
            activity,
            range,
            cfg,
            tiles: Vec::new(),
        };
        map.explore_tile(session, pose, progress)?;
        Ok(map)
    }

    /// Explores a new tile at `pose` (e.g. a taught key pose) and adds it.
    pub fn add_tile<R: Robot + SampleSource>(&mut self, rig: &mut R, pose: &[f64]) -> Result<&Tile, ExploreError> {
        let mut session = Session::with_cells(rig, self.cells.clone(), self.range);
        self.explore_tile(&mut session, pose, &mut |_| ())
    }

    /// Cells, in row order.
    pub fn cells(&self) -> &[Address] {
        &self.cells
    }

    /// The row of cell `id`.
    pub fn cell_index(&self, id: Address) -> Option<usize> {
        self.cells.binary_search(&id).ok()
    }

    /// The activity matrix used for decoupling.
    pub fn activity(&self) -> &ActivityMatrix {
        &self.activity
    }

    /// All tiles, in the order explored.
    pub fn tiles(&self) -> &[Tile] {
        &self.tiles
    }

    /// The tile explored closest to `pose` (quadratic distance).
    pub fn nearest_tile(&self, pose: &[f64]) -> &Tile {
        let distance = |t: &Tile| t.pose.iter().zip(pose).map(|(a, b)| (a - b) * (a - b)).sum::<f64>();
        self.tiles.iter().min_by(|a, b| distance(a).total_cmp(&distance(b))).expect("a map has at least one tile")
    }

    fn explore_tile<R: Robot + SampleSource>(
        &mut self,
        session: &mut Session<'_, R>,
        pose: &[f64],
        progress: &mut dyn FnMut(usize),
    ) -> Result<&Tile, ExploreError> {
        let start = session.elapsed_s();
        let cfg = self.cfg;
        let settle_timeout = 10.0
            + 2.0 * pose.iter().zip(session.positions()).map(|(a, b)| (a - b).abs()).sum::<f64>()
                / cfg.move_speed_rad_s;
        session.move_to(pose, cfg.move_speed_rad_s, cfg.pose_tolerance_rad, settle_timeout)?;
        let (u_count, dofs) = (self.cells.len(), session.dofs());
        let lowpass = Butterworth::new(cfg.lowpass_hz, 1.0 / session.tick_s()).expect("checked with the config");
        let mut raw = vec![0.0f32; u_count * dofs];
        let mut sigma = match cfg.evaluation {
            Evaluation::Amplitudes => None,
            Evaluation::Regression => Some(vec![f32::INFINITY; u_count * dofs]),
        };
        for d in 0..dofs {
            session.hold(cfg.settle_s)?;
            let kind = self.kinds[d];
            let trace = session.trace(d, cfg.duration_s + cfg.tail_s, |t| cfg.position(kind, t))?;
            let (phi, omega, alpha) = trace.motion(session.tick_s());
            match cfg.evaluation {
                Evaluation::Amplitudes => {
                    for u in 0..u_count {
                        raw[u * dofs + d] = normal_weight(&trace, u, u_count, &lowpass, &alpha);
                    }
                }
                Evaluation::Regression => {
                    let ticks = trace.sampled_ticks();
                    let rows = ticks.iter().map(|&k| [1.0, phi[k], alpha[k], omega[k] * omega[k]]).collect();
                    if let (Some(fit), Some(sigma)) = (LeastSquares::new(rows), sigma.as_mut()) {
                        for u in 0..u_count {
                            let (w, s) = tangential_weight(&trace, &ticks, u, u_count, &fit);
                            raw[u * dofs + d] = w;
                            sigma[u * dofs + d] = s;
                        }
                    }
                }
            }
            // Back to the tile's pose before the next DoF.
            session.move_to(pose, cfg.move_speed_rad_s, cfg.pose_tolerance_rad, 10.0)?;
            progress(d);
        }
        let mut weights: Vec<f32> = (0..u_count * dofs)
            .map(|i| if self.activity.is_moved(i / dofs, i % dofs) { raw[i] } else { 0.0 })
            .collect();
        for row in weights.chunks_mut(dofs) {
            let norm = row.iter().map(|w| f64::from(*w).powi(2)).sum::<f64>().sqrt();
            let scale = if norm < cfg.suppression || norm == 0.0 { 0.0 } else { 1.0 / norm };
            row.iter_mut().for_each(|w| *w = (f64::from(*w) * scale) as f32);
        }
        self.tiles.push(Tile { pose: pose.to_vec(), dofs, raw, sigma, weights, time_s: session.elapsed_s() - start });
        Ok(self.tiles.last().expect("just pushed"))
    }
}

/// Equations (10)-(12) for cell `u`: the signed share of the normal (z)
/// axis in the pattern's acceleration amplitudes. Zero if the cell's trace
/// has gaps or shows no amplitude at all.
///
/// Equation (11) reads the phase from whether the maximum or the minimum
/// comes first. Over one full period the acceleration `cos(2 pi f t)` has
/// two equal maxima, at the start and at the end, so which is "first" is
/// decided by noise. The phase is therefore taken from the sign of the
/// correlation with the DoF's acceleration `alpha` (from position
/// feedback), with equation (11)'s convention: in phase gives -1.
fn normal_weight(trace: &Trace, u: usize, cells: usize, lowpass: &Butterworth, alpha: &[f64]) -> f32 {
    let mut amplitude = [0.0; 3];
    let mut sign = 0.0;
    for (a, amp) in amplitude.iter_mut().enumerate() {
        let mut x: Vec<f64> = (0..trace.len()).map(|k| f64::from(trace.accel[k * cells + u][a])).collect();
        if x.iter().any(|v| !v.is_finite()) {
            return 0.0;
        }
        let mean = x.iter().sum::<f64>() / x.len() as f64;
        x.iter_mut().for_each(|v| *v -= mean);
        lowpass.filtfilt(&mut x);
        let (lo, hi) = x.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| (lo.min(*v), hi.max(*v)));
        *amp = hi - lo;
        if a == 2 {
            sign = -x.iter().zip(alpha).map(|(v, al)| v * al).sum::<f64>().signum();
        }
    }
    let total: f64 = amplitude.iter().sum();
    if total > 0.0 {
        (sign * amplitude[2] / total) as f32
    } else {
        0.0
    }
}

/// Standard errors a tangential term must exceed to give a weight.
const SIGNIFICANT_SIGMAS: f64 = 6.0;

/// The regression's weight for cell `u` over the trace's `ticks`, the
/// normal share of the fitted tangential term with equation (11)'s sign,
/// and its standard error. A term within the noise (or a cell with gaps
/// in those ticks) gives the defined weight 0 with an infinite error.
fn tangential_weight(trace: &Trace, ticks: &[usize], u: usize, cells: usize, fit: &LeastSquares<4>) -> (f32, f32) {
    let (mut t, mut s) = ([0.0; 3], [0.0; 3]);
    for a in 0..3 {
        let y: Vec<f64> = ticks.iter().map(|&k| f64::from(trace.accel[k * cells + u][a])).collect();
        match fit.fit_with_errors(&y) {
            Some((coefficients, errors)) => (t[a], s[a]) = (coefficients[2], errors[2]),
            None => return (0.0, f32::INFINITY),
        }
    }
    let total: f64 = t.iter().map(|c| c.abs()).sum();
    let norm = t.iter().map(|c| c * c).sum::<f64>().sqrt();
    let worst = s.iter().copied().fold(0.0, f64::max);
    if !(norm > SIGNIFICANT_SIGMAS * worst && total > 0.0) {
        return (0.0, f32::INFINITY);
    }
    let w = -t[2] / total;
    // First-order propagation through w = -t_z / (|t_x| + |t_y| + |t_z|).
    let sigma = (s[2] * s[2] * (1.0 - w.abs()).powi(2) + w * w * (s[0] * s[0] + s[1] * s[1])).sqrt() / total;
    (w as f32, sigma as f32)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ticks_left_out_of_a_trace_leave_the_weight_to_the_others() {
        // One cell feeling the DoF's angular acceleration along its normal.
        let tick = 0.004;
        let q: Vec<f64> =
            (1..=125).map(|k| 0.1 * (1.0 - (std::f64::consts::TAU * 2.0 * k as f64 * tick).cos())).collect();
        let t =
            Trace { accel: Vec::new(), q0: 0.0, q, start: Vec::new(), positions: Vec::new(), saturated: vec![false] };
        let (phi, omega, alpha) = t.motion(tick);
        let mut trace = Trace { accel: alpha.iter().map(|a| [0.0, 0.0, (0.5 * a) as f32]).collect(), ..t };
        // A stall's ticks, as the session leaves them out.
        trace.accel[40..51].fill([f32::NAN; 3]);
        let ticks = trace.sampled_ticks();
        assert_eq!(ticks.len(), 125 - 11);
        let rows = ticks.iter().map(|&k| [1.0, phi[k], alpha[k], omega[k] * omega[k]]).collect();
        let fit = LeastSquares::new(rows).unwrap();
        let (w, sigma) = tangential_weight(&trace, &ticks, 0, 1, &fit);
        assert!((w + 1.0).abs() < 1e-6 && sigma.is_finite(), "weight {w}, sigma {sigma}");
    }
}
