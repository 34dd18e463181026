//! Skin self-calibration: where every cell sits on its link and how its
//! accelerometer is turned, fitted on the robot's own description.
//!
//! After exploration the host knows which cells share a body part and
//! which DoFs carry it; [`matching`] puts that tree onto the URDF. Then the
//! robot itself gathers what the fit needs:
//! 1. still postures spread over the joint ranges, where gravity seen from
//!    each link turns through many directions: frame, gain and offset of
//!    every accelerometer ([`gravity`]);
//! 2. one smooth excitation per revolute DoF, where the tangential and
//!    centripetal accelerations of the turning links give every cell's
//!    position ([`lever`]).
//!
//! What the motion cannot show (the position along the axis of a link's
//! only joint, anything on the fixed base, the turn about gravity of a link
//! that never tilts) is reported as unobservable with its direction, not
//! filled with a guess. With the `sim` feature, `check` judges a
//! calibration against the simulator's truth.

#[cfg(feature = "sim")]
pub mod check;
pub mod export;
pub mod gravity;
pub mod lever;
pub mod matching;
mod motion;
pub mod neighbours;
mod plan;

use nalgebra::{Isometry3, Matrix3, Rotation3, Vector3};
use skin_model::robot::kinematics::{self, BodyState, DofMotion};
use skin_model::robot::Robot as Model;
use skin_protocol::message::AccelRange;
use skin_protocol::Address;

use crate::explore::session::{Session, Window};
use crate::explore::{Exploration, ExploreError, Progress};
use crate::robot::{Robot, SampleSource};
use gravity::{GravityFit, SensorPrior, Still};
use lever::Lever;
use matching::Matching;

/// Still readings are never trusted below this spread, m/s^2: a balancing
/// robot sways by about a milliradian, a hundredth of g.
const STILL_FLOOR_MPS2: f64 = 0.01;

/// How the robot is moved and how the fit decides.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CalibrateConfig {
    /// The accelerometer range the cells are set to.
    pub range: AccelRange,
    /// Still postures, the start and the exploration's own included.
    pub postures: usize,
    /// Farthest a still posture takes a revolute DoF from the start, rad
    /// (a tenth of it in m for a prismatic one).
    pub posture_spread_rad: f64,
    /// Distance kept from every joint limit, rad (a tenth in m).
    pub limit_margin_rad: f64,
    /// Joint speed between postures, rad/s.
    pub move_speed_rad_s: f64,
    /// Wait after arriving before averaging, s.
    pub settle_s: f64,
    /// Averaging per still posture, s.
    pub window_s: f64,
    /// Excitation frequency, Hz.
    pub excitation_hz: f64,
    /// Excitation periods per DoF.
    pub excitation_periods: u32,
    /// Largest excitation amplitude, rad.
    pub excitation_amplitude_rad: f64,
    /// Peak tangential acceleration allowed at the DoF's farthest reach,
    /// m/s^2: with gravity, it must stay inside the accelerometer's range.
    pub excitation_accel_mps2: f64,
    /// Largest delay of the skin's samples behind the joint feedback (or
    /// ahead of it) searched for, ticks.
    pub max_delay_ticks: f64,
    /// A position direction is observable when its standard deviation is below this, m.
    pub observable_sigma_m: f64,
    /// An orientation is observable when its worst standard deviation is below this, rad.
    pub observable_sigma_rad: f64,
    /// The sensors' spread before calibration.
    pub prior: SensorPrior,
    /// Seed of the posture choice.
    pub seed: u64,
}

impl Default for CalibrateConfig {
    fn default() -> Self {
        CalibrateConfig {
            range: AccelRange::G2,
            postures: 12,
            posture_spread_rad: 1.0,
            limit_margin_rad: 0.1,
            move_speed_rad_s: 0.8,
            settle_s: 0.5,
            window_s: 1.0,
            excitation_hz: 1.0,
            excitation_periods: 3,
            excitation_amplitude_rad: 0.6,
            excitation_accel_mps2: 5.0,
            max_delay_ticks: 3.0,
            observable_sigma_m: 0.002,
            observable_sigma_rad: 1f64.to_radians(),
            prior: SensorPrior::default(),
            seed: 0,
        }
    }
}

impl CalibrateConfig {
    /// Refuses settings no robot can run.
    pub fn check(&self) -> Result<(), CalibrateError> {
        let positive = [
            ("posture spread", self.posture_spread_rad),
            ("move speed", self.move_speed_rad_s),
            ("averaging window", self.window_s),
            ("excitation frequency", self.excitation_hz),
            ("excitation amplitude", self.excitation_amplitude_rad),
            ("excitation acceleration", self.excitation_accel_mps2),
            ("observable position sigma", self.observable_sigma_m),
            ("observable orientation sigma", self.observable_sigma_rad),
            ("offset prior", self.prior.offset_mps2),
            ("gain prior", self.prior.gain),
        ];
        if let Some((what, v)) = positive.iter().find(|(_, v)| !(v.is_finite() && *v > 0.0)) {
            return Err(CalibrateError::Config(format!("the {what} must be a finite number > 0, not {v}")));
        }
        let non_negative = [self.settle_s, self.limit_margin_rad, self.max_delay_ticks];
        if !non_negative.iter().all(|v| v.is_finite() && *v >= 0.0) || self.max_delay_ticks > 250.0 {
            return Err(CalibrateError::Config(
                "settling time, limit margin and delay search (up to 250 ticks) must be finite and >= 0".into(),
            ));
        }
        if self.postures < 2 || self.excitation_periods == 0 {
            return Err(CalibrateError::Config("at least 2 postures and 1 excitation period".into()));
        }
        Ok(())
    }
}

/// Why a calibration could not be made.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum CalibrateError {
    /// Moving the robot or reading the skin failed.
    #[error(transparent)]
    Explore(#[from] ExploreError),
    /// The robot link and the description name different DoFs.
    #[error("the robot's DoFs and the description's differ: not in the description: [{}]; in the description but not on the robot: [{}]", missing.join(", "), unused.join(", "))]
    DofMismatch {
        /// Interface DoFs the description lacks.
        missing: Vec<String>,
        /// Description DoFs the interface lacks.
        unused: Vec<String>,
    },
    /// A learned body part has no body in the description.
    #[error("cells {cells:?} move with exactly the DoFs [{dofs}], and no link of the description does")]
    NoSuchBody {
        /// The body part's cells.
        cells: Vec<Address>,
        /// The DoFs that move them.
        dofs: String,
    },
    /// A setting out of range.
    #[error("calibration settings: {0}")]
    Config(String),
}

/// One cell's calibrated pose and sensor.
#[derive(Clone, Debug, PartialEq)]
pub struct CellPose {
    /// Network ID.
    pub id: Address,
    /// Description body the cell sits on (its frame is that of the body's first link).
    pub body: usize,
    /// That link's name.
    pub link: String,
    /// Position in the link frame, m (zero along unobservable directions).
    pub position: Vector3<f64>,
    /// Accelerometer frame in the link frame.
    pub frame: Rotation3<f64>,
    /// Standard deviation per link axis, m; `inf` where unobservable.
    pub position_sigma_m: Vector3<f64>,
    /// Covariance of the position's known part, m^2 (nothing along unobservable directions).
    pub position_covariance_m2: Matrix3<f64>,
    /// Unit directions (link frame) the motion did not show.
    pub unobservable: Vec<Vector3<f64>>,
    /// Unit directions (link frame) the motion did not show and the
    /// skin's geometry did: the position along them comes from the cell's
    /// neighbours ([`neighbours`]).
    pub from_neighbours: Vec<Vector3<f64>>,
    /// Worst standard deviation of the frame, rad.
    pub orientation_sigma_rad: f64,
    /// Whether the frame is known to within the configured spread.
    pub orientation_observable: bool,
    /// Accelerometer gain per axis.
    pub gain: Vector3<f64>,
    /// Accelerometer offset per axis, m/s^2.
    pub offset_mps2: Vector3<f64>,
    /// Root mean square of what the link's motion leaves unexplained, m/s^2.
    pub motion_residual_mps2: f64,
    /// The cell moved in a way its link does not: it is on another body.
    pub inconsistent: bool,
    /// Other links whose motion explains the cell as well (mimic twins).
    pub ambiguous_with: Vec<String>,
}

impl CellPose {
    /// Which link axes (x, y, z) of the position are known: shown by the
    /// motion, or along a blind axis given by the neighbours.
    pub fn observable(&self) -> [bool; 3] {
        self.position_sigma_m.map(f64::is_finite).into()
    }

    /// The frame as URDF roll, pitch, yaw, rad.
    pub fn rpy(&self) -> [f64; 3] {
        let (r, p, y) = self.frame.euler_angles();
        [r, p, y]
    }
}

/// The calibrated skin.
#[derive(Clone, Debug)]
pub struct Calibration {
    /// One entry per cell, in exploration order.
    pub cells: Vec<CellPose>,
    /// The still postures this calibration reached and measured in
    /// (interface DoF order).
    pub postures: Vec<Vec<f64>>,
    /// Still windows of the exploration's that the gravity fit reused.
    pub reused_stills: usize,
    /// The start posture in the description's DoF order (for pictures of it).
    pub description_start: Vec<f64>,
    /// DoFs excited for positions.
    pub excited: Vec<String>,
    /// DoFs not excited, and why.
    pub skipped: Vec<(String, String)>,
    /// Delay of the skin's samples behind the joint feedback found in each excitation, ms.
    pub delays_ms: Vec<f64>,
    /// Robot time spent, s.
    pub robot_time_s: f64,
    /// Still postures left out and cells whose body is in doubt, in words.
    pub warnings: Vec<String>,
}

/// Calibrates the skin of an explored robot described by `model`, from
/// its current pose, to which it returns.
pub fn calibrate<R: Robot + SampleSource>(
    rig: &mut R,
    model: &Model,
    found: &Exploration,
    cfg: &CalibrateConfig,
    progress: &mut dyn FnMut(Progress),
) -> Result<Calibration, CalibrateError> {
    cfg.check()?;
    let matching = matching::matching(found, model)?;
    let start = rig.positions();
    let mut session = Session::with_cells(rig, found.cells.clone(), cfg.range);
    // The exploration's still windows already show gravity in each of its
    // postures (the start among them): only the rest are planned.
    let fresh = cfg.postures.saturating_sub(found.postures.len());
    let postures = plan::still_postures(model, &matching.urdf_dof, &start, fresh, cfg);
    let excitations = plan::excitations(model, &matching, &start, cfg);
    let planned = postures.len();
    let total = planned + excitations.planned.len();

    // 1. Still postures: gravity in many directions. The postures are
    // drawn inside the joint limits, blind to the robot's own shape: one
    // the robot cannot reach (a limb against another) is left out, and
    // the robot goes back to the last one it reached, the way it came
    // (the path its joints took, not a straight line).
    let mut stills: Vec<(Vec<f64>, Window)> = found.stills.clone();
    let mut reached = Vec::with_capacity(postures.len());
    let mut warnings = Vec::new();
    for (k, pose) in postures.into_iter().enumerate() {
        match session.move_to(&pose, cfg.move_speed_rad_s, 2e-3, 60.0) {
            Ok(()) => {
                session.hold(cfg.settle_s)?;
                let window = session.window(cfg.window_s)?;
                stills.push((session.positions(), window));
                reached.push(pose);
            }
            Err(ExploreError::Blocked { dof, short }) => {
                warnings.push(format!(
                    "still posture {} left out: {dof} stopped {short:.3} short of it (against another part of the robot, or a load beyond its force?)",
                    k + 1
                ));
                session.retrace(cfg.move_speed_rad_s, 2e-3, 60.0)?;
            }
            Err(e) => return Err(e.into()),
        }
        progress(Progress { done: k + 1, total });
    }
    session.move_to(&start, cfg.move_speed_rad_s, 2e-3, 60.0)?;
    session.hold(cfg.settle_s)?;
    let mut candidates = fit_stills(model, &matching, &stills, cfg);

    // 2. Excitations: positions from the motion, and which body moves as
    // the cell does. One that runs into another part of the robot is left
    // out and made the other way, where there is room.
    let mut delays_ms = Vec::with_capacity(excitations.planned.len());
    let mut excited = Vec::with_capacity(excitations.planned.len());
    let mut skipped = excitations.skipped;
    let here = session.positions();
    for (i, e) in excitations.planned.iter().enumerate() {
        let seconds = f64::from(cfg.excitation_periods) / cfg.excitation_hz;
        let w = std::f64::consts::TAU * cfg.excitation_hz;
        let (mut left_out, mut made) = (Vec::new(), false);
        for amplitude in std::iter::once(e.amplitude).chain(e.reverse) {
            let trace = session.trace(e.dof, seconds, |t| amplitude * (1.0 - (w * t).cos()).powi(2) / 4.0)?;
            session.move_to(&here, cfg.move_speed_rad_s, 2e-3, 60.0)?;
            if let Some(why) = motion::departure(&trace, e.dof, amplitude, &found.dof_names) {
                left_out.push(format!("{amplitude:+.3}: {why}"));
                continue;
            }
            let record = motion::Record::new(model, &matching.urdf_dof, &trace, session.tick_s(), session.lsb_mps2());
            let delay = if e.levers {
                let delay = record.delay_ticks(&candidates, cfg.max_delay_ticks);
                delays_ms.push(delay * session.tick_s() * 1e3);
                delay
            } else {
                median(&delays_ms) / (session.tick_s() * 1e3)
            };
            record.add(delay, &mut candidates);
            excited.push(e.dof);
            made = true;
            break;
        }
        if !left_out.is_empty() {
            let name = &found.dof_names[e.dof];
            let why =
                format!("its excitation ran into something (another part of the robot?): {}", left_out.join("; "));
            if made {
                warnings.push(format!("{name}: {why}; made the other way instead"));
            } else {
                warnings.push(format!("{name} not excited: {why}"));
                skipped.push((e.dof, why));
            }
        }
        progress(Progress { done: planned + i + 1, total });
    }
    session.move_to(&start, cfg.move_speed_rad_s, 2e-3, 60.0)?;

    let noise = still_noise(&stills);
    let cells: Vec<CellPose> = found
        .cells
        .iter()
        .zip(&candidates)
        .zip(noise)
        .map(|((&id, c), noise)| pose_of(model, id, c, noise, cfg))
        .collect();
    warnings.extend(self::warnings(&cells));
    let mut description_start = model.home().to_vec();
    for (d, &m) in matching.urdf_dof.iter().enumerate() {
        description_start[m] = start[d];
    }
    Ok(Calibration {
        cells,
        description_start,
        reused_stills: found.stills.len(),
        postures: reached,
        excited: excited.iter().map(|&d| found.dof_names[d].clone()).collect(),
        skipped: skipped.into_iter().map(|(d, why)| (found.dof_names[d].clone(), why)).collect(),
        delays_ms,
        robot_time_s: session.elapsed_s(),
        warnings,
    })
}

/// A body a cell may sit on, with what the fits say of it there.
#[derive(Clone, Debug)]
pub(crate) struct Candidate {
    body: usize,
    gravity: Option<GravityFit>,
    lever: Lever,
}

/// The still fit of every cell on each of its candidate bodies, the best
/// explained first.
fn fit_stills(
    model: &Model,
    matching: &Matching,
    stills: &[(Vec<f64>, Window)],
    cfg: &CalibrateConfig,
) -> Vec<Vec<Candidate>> {
    let states: Vec<Vec<BodyState>> = stills.iter().map(|(q, _)| at_rest(model, &matching.urdf_dof, q)).collect();
    matching
        .candidates
        .iter()
        .enumerate()
        .map(|(u, bodies)| {
            let mut fitted: Vec<Candidate> = bodies
                .iter()
                .map(|&body| {
                    let seen: Vec<Still> = stills
                        .iter()
                        .zip(&states)
                        .filter(|((_, w), _)| !w.saturated[u])
                        .map(|((_, w), s)| Still {
                            up: s[body].pose.rotation.inverse() * Vector3::z(),
                            mean: Vector3::from(w.mean[u]),
                            sigma: Vector3::from(w.var[u])
                                .map(|v| (v / f64::from(w.n[u]) + STILL_FLOOR_MPS2 * STILL_FLOOR_MPS2).sqrt()),
                        })
                        .collect();
                    Candidate { body, gravity: gravity::fit(&seen, &cfg.prior), lever: Lever::default() }
                })
                .collect();
            let rms = |c: &Candidate| c.gravity.map_or(f64::INFINITY, |g| g.rms_residual);
            fitted.sort_by(|a, b| rms(a).total_cmp(&rms(b)));
            fitted
        })
        .collect()
}

/// The median of `values`, 0 without any.
fn median(values: &[f64]) -> f64 {
    let mut v = values.to_vec();
    v.sort_by(f64::total_cmp);
    match v.len() {
        0 => 0.0,
        n if n % 2 == 1 => v[n / 2],
        n => (v[n / 2 - 1] + v[n / 2]) / 2.0,
    }
}

/// Each cell's reading noise while still, m/s^2 (the mean over postures and axes).
fn still_noise(stills: &[(Vec<f64>, Window)]) -> Vec<f64> {
    let cells = stills.first().map_or(0, |(_, w)| w.var.len());
    (0..cells)
        .map(|u| {
            let var: f64 = stills.iter().map(|(_, w)| w.var[u].iter().sum::<f64>() / 3.0).sum();
            (var / stills.len().max(1) as f64).sqrt()
        })
        .collect()
}

/// Every body at rest for interface positions `q`, the root upright at the origin.
fn at_rest(model: &Model, urdf_dof: &[usize], q: &[f64]) -> Vec<BodyState> {
    let mut full = vec![0.0; model.dofs().len()];
    for (d, &m) in urdf_dof.iter().enumerate() {
        full[m] = q[d];
    }
    at_rest_full(model, &full)
}

/// Every body at rest for positions `full` in the description's DoF order.
fn at_rest_full(model: &Model, full: &[f64]) -> Vec<BodyState> {
    let zero = vec![0.0; full.len()];
    let mut states = Vec::new();
    kinematics::forward(
        model,
        &BodyState::at_rest(Isometry3::identity()),
        DofMotion { q: full, qd: &zero, qdd: &zero },
        &mut states,
    );
    states
}

/// A cell whose motion leaves more than this many times its still noise
/// (plus a floor for the model's own error, m/s^2) unexplained does not
/// move as its body does.
const INCONSISTENT_NOISE: f64 = 3.0;
const INCONSISTENT_FLOOR_MPS2: f64 = 0.05;
/// Two bodies whose motion explains a cell within this ratio of
/// residuals cannot be told apart.
const AMBIGUOUS_RATIO: f64 = 1.2;
/// The motion corrects the still fit's frame by at most this turn, rad:
/// within it the fit's linearization errs less than the noise.
const MAX_TURN_RAD: f64 = 0.05;

fn pose_of(model: &Model, id: Address, candidates: &[Candidate], noise: f64, cfg: &CalibrateConfig) -> CellPose {
    let motion = |c: &Candidate| c.lever.residual_rms().unwrap_or(f64::INFINITY);
    let mut ranked: Vec<&Candidate> = candidates.iter().filter(|c| c.gravity.is_some()).collect();
    // Stable: among equal motion residuals the gravity order stands.
    ranked.sort_by(|a, b| motion(a).total_cmp(&motion(b)));
    let best = ranked.first().copied().or(candidates.first());
    let body = best.map_or(0, |c| c.body);
    let residual = best.map_or(f64::INFINITY, motion);
    let ambiguous_with: Vec<String> = ranked
        .iter()
        .skip(1)
        .filter(|c| motion(c) < AMBIGUOUS_RATIO * residual || !residual.is_finite())
        .map(|c| model.bodies()[c.body].name.clone())
        .collect();
    let inconsistent = residual.is_finite() && residual > INCONSISTENT_NOISE * noise + INCONSISTENT_FLOOR_MPS2;
    let unknown = || {
        (
            Vector3::zeros(),
            Vector3::repeat(f64::INFINITY),
            Matrix3::zeros(),
            vec![Vector3::x(), Vector3::y(), Vector3::z()],
        )
    };
    let still = best.and_then(|c| c.gravity);
    let (mut frame, mut gain, mut offset_mps2, mut orientation_sigma_rad) = match still {
        Some(f) => (f.frame, f.gain, f.offset, f.orientation_sigma_rad),
        None => (Rotation3::identity(), Vector3::repeat(1.0), Vector3::zeros(), f64::INFINITY),
    };
    let solved = best.zip(still).and_then(|(c, f)| c.lever.solve(cfg.observable_sigma_m, &f.information));
    let (position, position_sigma_m, position_covariance_m2, unobservable) = match solved {
        // Nothing is claimed for a cell whose body is in doubt.
        _ if inconsistent || !ambiguous_with.is_empty() => unknown(),
        // Position and sensor were fitted together: the motion sharpens the
        // sensor, and what it leaves loose widens the position.
        // Beyond a small turn the linear fit's corrections and directions
        // mean nothing: the still fit had no hold on the frame there.
        Some(l) if l.turn.norm() > MAX_TURN_RAD => unknown(),
        Some(l) => {
            frame = Rotation3::from_scaled_axis(l.turn) * frame;
            gain += l.gain;
            offset_mps2 += l.offset;
            orientation_sigma_rad = l.turn_sigma_rad;
            // A link that only turns about a vertical axis shows neither its
            // cells' azimuth nor their frames' turn about it: the two turn
            // together and every reading stays the same.
            if orientation_sigma_rad > cfg.observable_sigma_rad {
                unknown()
            } else {
                (l.position, l.sigma_m, l.covariance_m2, l.unobservable)
            }
        }
        None => unknown(),
    };
    CellPose {
        id,
        body,
        link: model.bodies()[body].name.clone(),
        position,
        frame,
        position_sigma_m,
        position_covariance_m2,
        unobservable,
        from_neighbours: Vec::new(),
        orientation_sigma_rad,
        orientation_observable: orientation_sigma_rad <= cfg.observable_sigma_rad
            && !inconsistent
            && ambiguous_with.is_empty(),
        gain,
        offset_mps2,
        motion_residual_mps2: residual,
        inconsistent,
        ambiguous_with,
    }
}

/// What the user must know: cells whose body the calibration doubts.
fn warnings(cells: &[CellPose]) -> Vec<String> {
    let mut out = Vec::new();
    let odd: Vec<String> =
        cells.iter().filter(|c| c.inconsistent).map(|c| format!("{} ({})", c.id.0, c.link)).collect();
    if !odd.is_empty() {
        out.push(format!(
            "cells {} move in a way their link's motion does not explain: the exploration put them on the wrong body part (is a declared --axis-clearance larger than the skin's real one?); their poses are left unknown",
            odd.join(", ")
        ));
    }
    let twins: Vec<String> = cells
        .iter()
        .filter(|c| !c.ambiguous_with.is_empty())
        .map(|c| format!("{} ({} or {})", c.id.0, c.link, c.ambiguous_with.join(" or ")))
        .collect();
    if !twins.is_empty() {
        out.push(format!(
            "cells {} sit on one of links that move alike (mimic joints) and nothing measured tells which; their poses are left unknown",
            twins.join(", ")
        ));
    }
    out
}
