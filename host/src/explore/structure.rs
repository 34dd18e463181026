//! The structural exploration (section 4.2.5), made adaptive.
//!
//! Every DoF is stepped in turn and each cell read from the evidence of
//! [`activity`](super::activity). Then only the DoFs with undecided entries
//! are measured again, each with the remedy its doubt calls for:
//!
//! - *noise*: the next measurement averages twice as long and steps
//!   further, until decided or the robot-time budget is spent, so time
//!   grows with noise instead of the exploration failing;
//! - *near a vertical axis*: averaging cannot help, so the robot chooses
//!   another posture. It turns a DoF known to carry the undecided one (one
//!   that moves every cell it moves, nearest first) by `tilt_rad`, which
//!   tilts the axis out of gravity's line, measures again and turns back:
//!   the paper's "change the posture of the robot", done by the robot;
//! - *near an axis no posture tilts*, or *on a coupled DoF* (mimic joints,
//!   where a cell that shows no gravity change may still move): more
//!   repeats of the step, pooled, until each still cell's lever is bounded
//!   below the mounting clearance. Near the axis,
//!   a cell whose pooled lever stands far above what the cells decided
//!   still show moves, however close to the axis; a coupled DoF's step
//!   rocks the base, and the rocking those cells record is regressed out
//!   of the others' (`rocking.rs`);
//! - *sharpening*: about a vertical axis no posture tilts, the repeats go
//!   on, fast within the joint's velocity limit, until a lever of the
//!   mounting clearance would be decided by evidence against the floor,
//!   for at most `SHARPEN_SHARE` of the budget.
//!
//! Every entry keeps the smallest lever its evidence would have decided
//! as a movement (`Step::seen`, then the pooled and floor thresholds).
//!
//! Between measurements, entries that the decided ones imply in a
//! kinematic tree are settled without moving (`infer`): the cells of two
//! DoFs are nested or disjoint. What no reachable posture decides is
//! settled on the mounting clearance: the user's declared one, else the
//! default from the cell pitch (see [`Clearance`]), each such entry
//! reported with the lever bound its evidence reached; with `strict`, it
//! stays undecided, with its [`Doubt`], and the exploration says so.

use super::activity::{Activity, ActivityMatrix, Basis, Doubt, Evidence, Reading, Step, SURE_LEVER};
use super::rocking::Sums;
use super::session::{Session, Window};
use super::ExploreError;
use crate::robot::{DofKind, Robot, SampleSource};

/// Parameters of the structural exploration (section 4.2).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StructureConfig {
    /// Position step of each revolute DoF, rad (the paper: 0.1).
    pub step_rad: f64,
    /// Position step of each prismatic DoF, m.
    pub step_m: f64,
    /// Duration of each step, a raised-cosine velocity profile, s.
    pub move_s: f64,
    /// Still time after a step before averaging, s (the paper: 0.5).
    pub settle_s: f64,
    /// Averaging window of the gravity vectors, s (the paper: 1.0).
    pub average_s: f64,
    /// Postural runs, alternately incremental and decremental, or-ed (the paper: 2).
    pub runs: usize,
    /// Static threshold floor as a fraction of the largest change `g |step|`
    /// (the paper: 0.1 m/s^2 for 0.1 rad, i.e. 10 %).
    pub static_fraction: f64,
    /// A lever arm above this in one step means the cell moved, m (below
    /// it, a standing robot still ringing from the step before can fake one).
    pub lever_threshold_m: f64,
    /// The same for the pooled repeats of a step whose axis is aligned with
    /// gravity, which does not rock the base: the resolution of "on the
    /// axis", m.
    pub axis_lever_m: f64,
    /// Margin of every decision, in standard deviations of its noise.
    pub confidence_sigmas: f64,
    /// Robot time the structural exploration may spend, s; past it, what is
    /// undecided is reported as such.
    pub budget_s: f64,
    /// How far a carrying DoF turns to tilt a gravity-aligned axis, rad.
    pub tilt_rad: f64,
    /// Declared by the user: in the start posture no cell lies closer than
    /// this to the axis line of a joint that moves it, m (0: nothing
    /// declared); for a DoF that drives coupled (mimic) joints, no cell it
    /// moves moves less than this per radian. With it, a cell that shows
    /// no lever to a gravity-aligned axis that no posture can tilt (a yaw
    /// joint on the fixed base), or no gravity change and no lever with a
    /// coupled DoF, is still once pooled repeats bound its lever below the
    /// clearance. Without it, the default of [`StructureConfig::clearance`]
    /// is assumed, and said.
    pub axis_clearance_m: f64,
    /// Centre-to-centre distance of two wired cells, m: the size of a
    /// cell's board, from which the default mounting clearance follows.
    pub cell_pitch_m: f64,
    /// Refuse rather than assume: with no clearance declared, the entries
    /// only a mounting clearance settles are reported as undecided.
    pub strict: bool,
}

/// The default mounting clearance, as a fraction of the cell pitch. A
/// cell's accelerometer sits at the middle of its board, a pitch across:
/// on a link's side, along or around an axis, it sits at least the link's
/// radius from it; it comes within 1/25 of a pitch (1 mm for 25 mm cells)
/// of an axis only on an end cap centred on that axis to that precision.
pub const DEFAULT_CLEARANCE_PER_PITCH: f64 = 0.04;

/// The mounting clearance the exploration settles entries on.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Clearance {
    /// No cell lies closer than this to the axis of a joint that moves it, m.
    pub m: f64,
    /// Declared by the user (`false`: the default, from the cell pitch).
    pub declared: bool,
}

impl Clearance {
    /// The assumption, in words.
    pub fn describe(&self, pitch_m: f64) -> String {
        if self.declared {
            format!("the declared mounting clearance of {:.2} mm", self.m * 1e3)
        } else {
            format!(
                "the default mounting clearance of {:.2} mm ({} of the {:.0} mm cell pitch: no cell centred on an end cap over the axis)",
                self.m * 1e3,
                fraction(DEFAULT_CLEARANCE_PER_PITCH),
                pitch_m * 1e3
            )
        }
    }
}

/// `x` as `1/n` when it is one.
fn fraction(x: f64) -> String {
    let n = (1.0 / x).round();
    if (n * x - 1.0).abs() < 1e-9 {
        format!("1/{n:.0}")
    } else {
        format!("{x}")
    }
}

impl Default for StructureConfig {
    /// 0.2 rad steps of 0.2 s, 0.05 s settling, 0.1 s averaging, one run:
    /// error-free over 1,000 seeds of the HRP-2-like robot (the `explore`
    /// benchmark and the `explore_seeds` test).
    fn default() -> Self {
        StructureConfig {
            step_rad: 0.2,
            step_m: 0.02,
            move_s: 0.2,
            settle_s: 0.05,
            average_s: 0.1,
            runs: 1,
            static_fraction: 0.1,
            lever_threshold_m: 0.01,
            axis_lever_m: 0.003,
            confidence_sigmas: 6.0,
            budget_s: 1800.0,
            tilt_rad: 0.3,
            axis_clearance_m: 0.0,
            cell_pitch_m: skin_model::skin::CELL_PITCH_M,
            strict: false,
        }
    }
}

/// Doublings of the averaging window at most (0.1 s becomes 102 s).
const MAX_EFFORT: u32 = 10;
/// Repeats of a step whose static test is blind, pooled for the lever.
const MAX_REPEATS: u32 = 4096;
/// Blind repeats of one DoF in a row.
const BATCH: u32 = 16;
/// The effort from which steps stop growing: twice the configured step.
const MAX_GROWTH_EFFORT: u32 = 4;
/// Carrying DoFs turned at most to tilt one DoF's axis.
const MAX_TILTS: usize = 3;
/// Halvings of a step that meets a limit both ways before the DoF counts as stuck.
const MAX_HALVINGS: u32 = 4;
/// A pooled lever this many times the floor of the cells a DoF leaves
/// still is that DoF's own (see [`Explorer::still_floor`]).
const FLOOR_RATIO: f64 = 5.0;
/// Cells decided still that a floor is taken from, at least.
const MIN_FLOOR_CELLS: usize = 4;
/// The share of the robot-time budget that sharpening may spend: it lowers
/// what the evidence sees, and must not starve the entries still open.
const SHARPEN_SHARE: f64 = 0.25;
/// The share of a DoF's velocity limit its fast repeats reach at peak.
const VELOCITY_SHARE: f64 = 0.8;
/// Peak angular acceleration of the fast repeats, rad/s^2: two and a half
/// times the default step's (0.2 rad in 0.2 s: 31 rad/s^2), whose lever
/// signal grows with it.
const FAST_ACCEL_RAD_S2: f64 = 80.0;
/// How long a fast repeat moves, s: 25 ticks of a 250 Hz skin to regress on.
const FAST_MOVE_S: f64 = 0.1;

impl StructureConfig {
    /// The paper's HRP-2 setting: 0.1 rad steps, 0.5 s settling, 1.0 s
    /// averaging, two postural runs.
    pub fn paper() -> Self {
        StructureConfig {
            step_rad: 0.1,
            move_s: 0.5,
            settle_s: 0.5,
            average_s: 1.0,
            runs: 2,
            ..StructureConfig::default()
        }
    }

    /// The clearance entries are settled on: the declared one, else (but
    /// with [`StructureConfig::strict`]) the default from the cell pitch.
    pub fn clearance(&self) -> Option<Clearance> {
        if self.axis_clearance_m > 0.0 {
            Some(Clearance { m: self.axis_clearance_m, declared: true })
        } else if self.strict {
            None
        } else {
            Some(Clearance { m: self.cell_pitch_m * DEFAULT_CLEARANCE_PER_PITCH, declared: false })
        }
    }

    /// Refuses values the method cannot work with.
    pub fn check(&self) -> Result<(), ExploreError> {
        let positive = [
            self.step_rad,
            self.step_m,
            self.move_s,
            self.average_s,
            self.lever_threshold_m,
            self.axis_lever_m,
            self.confidence_sigmas,
            self.tilt_rad,
            self.budget_s,
            self.cell_pitch_m,
        ];
        let not_negative = [self.settle_s, self.axis_clearance_m];
        if !positive.iter().all(|v| v.is_finite() && *v > 0.0)
            || !not_negative.iter().all(|v| v.is_finite() && *v >= 0.0)
            || self.runs == 0
        {
            return Err(ExploreError::Config(
                "steps, move time, averaging window, lever thresholds, confidence, tilt, budget and cell pitch must be positive, settling and clearance not negative, and at least one run".into(),
            ));
        }
        if !(self.static_fraction > 0.0 && self.static_fraction < 1.0) {
            return Err(ExploreError::Config("the static threshold fraction must be between 0 and 1".into()));
        }
        Ok(())
    }
}

/// What the structural exploration found.
pub(crate) struct Outcome {
    /// The or-ed activity matrix, each entry with its basis.
    pub activity: ActivityMatrix,
    /// Every posture measured in, the start first, DoF positions.
    pub postures: Vec<Vec<f64>>,
    /// The last doubt of each entry (cell-major, like the matrix): why it
    /// is undecided, for the entries that are.
    pub doubts: Vec<Option<Doubt>>,
    /// Per DoF: the carrying DoFs turned to tilt its axis.
    pub tilted_by: Vec<Vec<usize>>,
    /// Longest averaging window used, s.
    pub longest_average_s: f64,
    /// Steps measured.
    pub measurements: usize,
    /// Per DoF: repeats of its blind step pooled for the lever.
    pub repeats: Vec<u32>,
    /// Per entry (cell-major): the smallest bound on its lever seen while
    /// its axis was vertical or its DoF coupled, m.
    pub lever_bounds: Vec<f64>,
    /// Every still window with the DoF positions it was taken at: gravity
    /// seen from each link in as many postures, for the calibration.
    pub stills: Vec<(Vec<f64>, Window)>,
    /// Per entry (cell-major): the smallest lever its evidence would have
    /// decided as a movement, m (see [`Step::seen`]).
    pub seen: Vec<f64>,
}

/// Steps every DoF, then again the DoFs with undecided entries, until all
/// are decided, no remedy is left or the budget is spent; `progress` gets
/// the measurements done and planned.
pub(crate) fn explore<R: Robot + SampleSource>(
    session: &mut Session<'_, R>,
    cfg: &StructureConfig,
    kinds: &[DofKind],
    progress: &mut dyn FnMut(usize, usize),
) -> Result<Outcome, ExploreError> {
    let (cells, dofs) = (session.cells().len(), session.dofs());
    session.hold(cfg.settle_s)?;
    let pre = session.window(cfg.average_s)?;
    let deadline_s = session.elapsed_s() + cfg.budget_s;
    let postures = vec![session.positions()];
    let stills = vec![(session.positions(), pre.clone())];
    let mut x = Explorer {
        s: session,
        cfg,
        kinds,
        pre,
        pre_s: cfg.average_s,
        deadline_s,
        postures,
        stills,
        posture: 0,
        effort: vec![0; dofs],
        repeats: vec![0; dofs],
        grow: vec![0; dofs],
        tilt: vec![None; dofs],
        last_blind: false,
        last_surely_blind: false,
        last_step: None,
        step_before: None,
        pooled: vec![[0.0; 4]; cells * dofs],
        sums: (0..dofs).map(|_| None).collect(),
        direction: vec![1.0; dofs],
        tilted_by: vec![Vec::new(); dofs],
        blind: vec![true; dofs],
        measured: vec![false; dofs],
        doubts: vec![None; cells * dofs],
        lever_bound: vec![f64::INFINITY; cells * dofs],
        seen: vec![f64::INFINITY; cells * dofs],
        sharpen_until_s: deadline_s - (1.0 - SHARPEN_SHARE) * cfg.budget_s,
        sharpened: false,
        done: 0,
        total: cfg.runs * dofs,
        longest_average_s: cfg.average_s,
    };
    let mut m = ActivityMatrix::unknown(cells, dofs);
    for run in 0..cfg.runs {
        for d in 0..dofs {
            x.direction[d] = if run % 2 == 0 { 1.0 } else { -1.0 };
            x.measure(&mut m, d)?;
            progress(x.done, x.total);
        }
    }
    x.settle(&mut m);
    // Measure again only what is undecided, each DoF with its remedy.
    loop {
        let mut acted = false;
        for d in 0..dofs {
            if !m.column_undecided(d) || x.out_of_time() {
                continue;
            }
            x.total += 1;
            if x.resolve(&mut m, d)? {
                acted = true;
                x.settle(&mut m);
            } else {
                x.total -= 1;
            }
            progress(x.done, x.total);
        }
        if !acted || x.out_of_time() || m.undecided().is_empty() {
            break;
        }
    }
    // What sharpening left to the clearance, it now settles.
    x.sharpened = true;
    x.settle(&mut m);
    Ok(Outcome {
        activity: m,
        postures: x.postures,
        doubts: x.doubts,
        tilted_by: x.tilted_by,
        longest_average_s: x.longest_average_s,
        measurements: x.done,
        repeats: x.repeats,
        lever_bounds: x.lever_bound,
        stills: x.stills,
        seen: x.seen,
    })
}

struct Explorer<'x, 'r, R> {
    s: &'x mut Session<'r, R>,
    cfg: &'x StructureConfig,
    kinds: &'x [DofKind],
    /// The still window before the next motion, and its length, s.
    pre: Window,
    pre_s: f64,
    /// Robot time at which the budget is spent, s.
    deadline_s: f64,
    /// Postures measured in; `posture` is the current one.
    postures: Vec<Vec<f64>>,
    posture: usize,
    /// Still windows taken, with where.
    stills: Vec<(Vec<f64>, Window)>,
    /// Doublings of averaging (and growth of the step) per DoF.
    effort: Vec<u32>,
    /// Repeats of each DoF's blind step.
    repeats: Vec<u32>,
    /// Effort whose step size a DoF's steps use at least.
    grow: Vec<u32>,
    /// The carrier whose turn tilted each DoF's axis out of gravity's line.
    tilt: Vec<Option<usize>>,
    /// The last measurement's static test was blind.
    last_blind: bool,
    /// ... and surely so: no longer averaging would change it.
    last_surely_blind: bool,
    /// The DoF of the last step, and of the step before it.
    last_step: Option<usize>,
    step_before: Option<usize>,
    /// Per entry, the inverse-variance weighted sum of the lever vectors of
    /// blind steps in the start posture and the sum of weights.
    pooled: Vec<[f64; 4]>,
    /// Per coupled DoF, its repeated steps summed, for the lever with the
    /// base's rocking regressed out.
    sums: Vec<Option<Sums>>,
    /// Direction of each DoF's next step, alternating.
    direction: Vec<f64>,
    tilted_by: Vec<Vec<usize>>,
    blind: Vec<bool>,
    measured: Vec<bool>,
    /// The last doubt of each entry, cell-major.
    doubts: Vec<Option<Doubt>>,
    /// Smallest upper bound seen on each entry's lever while its axis was
    /// vertical or its DoF coupled, m.
    lever_bound: Vec<f64>,
    /// Per entry, the smallest lever its evidence would have decided as a
    /// movement, m.
    seen: Vec<f64>,
    /// Robot time at which sharpening's share of the budget is spent, s.
    sharpen_until_s: f64,
    /// Sharpening is over (no remedy left): the clearance settles what it can.
    sharpened: bool,
    done: usize,
    total: usize,
    longest_average_s: f64,
}

impl<R: Robot + SampleSource> Explorer<'_, '_, R> {
    fn out_of_time(&self) -> bool {
        self.s.elapsed_s() >= self.deadline_s
    }

    /// One more measurement of DoF `d` with the remedy its doubts call
    /// for; false when none is left.
    fn resolve(&mut self, m: &mut ActivityMatrix, d: usize) -> Result<bool, ExploreError> {
        let open = self.open_doubts(m, d);
        let near_axis = open.contains(&Doubt::NearAxis);
        let noisy = open.iter().any(|&doubt| doubt != Doubt::NearAxis);
        let coupled = open.contains(&Doubt::Coupled);
        let tightens = self.tightens(m, d) || self.sharpens(m, d);
        // A cell of a coupled DoF that pooling cannot settle may turn about
        // an axis aligned with gravity: tilted, it shows the turn.
        let tilt_coupled = coupled && !tightens;
        if (near_axis || self.blind[d] || tilt_coupled) && self.kinds[d] == DofKind::Revolute {
            // A posture that tilted the axis before, or a new one.
            let carrier = match self.tilt[d] {
                Some(p) if noisy && self.effort[d] < MAX_EFFORT => {
                    self.effort[d] += 1;
                    Some(p)
                }
                // Averaging is spent there: another posture, tilted further.
                Some(_) | None => self.next_carrier(m, d),
            };
            if let Some(p) = carrier {
                self.measure_tilted(m, d, p)?;
                return Ok(true);
            }
        }
        if ((noisy || tightens) && self.blind[d] && self.tilt[d].is_none()) || (coupled && tightens) {
            // Only the lever can tell: more of the same (larger) step, a
            // batch in a row so the base stops ringing, pooled; longer
            // still windows would not help.
            if self.repeats[d] < MAX_REPEATS {
                self.grow[d] = MAX_GROWTH_EFFORT;
                for _ in 0..BATCH {
                    self.repeats[d] += 1;
                    self.measure(m, d)?;
                    if self.repeats[d] >= MAX_REPEATS
                        || self.out_of_time()
                        || !(self.noisy(m, d) || self.tightens(m, d) || self.sharpens(m, d))
                    {
                        break;
                    }
                }
                return Ok(true);
            }
        } else if noisy && !self.blind[d] && self.effort[d] < MAX_EFFORT {
            self.effort[d] += 1;
            self.measure(m, d)?;
            return Ok(true);
        }
        Ok(false)
    }

    /// The doubts of DoF `d`'s undecided entries.
    fn open_doubts(&self, m: &ActivityMatrix, d: usize) -> Vec<Doubt> {
        let dofs = m.dofs();
        (0..m.cells()).filter(|&u| m.get(u, d) == Activity::Unknown).filter_map(|u| self.doubts[u * dofs + d]).collect()
    }

    /// DoF `d` has entries undecided for noise or saturation.
    fn noisy(&self, m: &ActivityMatrix, d: usize) -> bool {
        self.open_doubts(m, d).into_iter().any(|doubt| matches!(doubt, Doubt::Noise | Doubt::Saturated))
    }

    /// More pooled repeats of DoF `d`'s step could settle an entry on the
    /// mounting clearance (declared, or the default): its lever bound is still above the clearance,
    /// the pooled lever does not already show it farther out (a cell that
    /// really moves at a lever between the clearance and what counts as a
    /// movement stays undecided, not pooled forever), and the entry waits
    /// for the clearance: near an axis no posture tilts, or on a coupled
    /// DoF, where gravity cannot say still.
    fn tightens(&self, m: &ActivityMatrix, d: usize) -> bool {
        let Some(Clearance { m: clearance, .. }) = self.cfg.clearance() else { return false };
        let (dofs, k) = (m.dofs(), self.cfg.confidence_sigmas);
        let waits = self.waits_for_clearance(m, d);
        (0..m.cells()).any(|u| {
            let i = u * dofs + d;
            let lever = self.sums[d].as_ref().and_then(|s| s.lever(u)).or_else(|| self.pooled_lever(i));
            let below = lever.is_none_or(|(lever, sigma)| lever - k * sigma < clearance);
            m.get(u, d) == Activity::Unknown && waits(self.doubts[i]) && self.lever_bound[i] >= clearance && below
        })
    }

    /// More pooled repeats of DoF `d`'s step could lower what its evidence
    /// sees below the mounting clearance, so that a cell that close to
    /// the axis is decided moved by evidence before the clearance settles
    /// the rest: an entry waiting for the clearance sees no lever of that
    /// size yet, and the floor of the still cells it is measured against
    /// is still the noise's margin, not a lever (the base's sway, or a
    /// cell truly that close), which no repeat lowers. It spends at most
    /// [`SHARPEN_SHARE`] of the budget.
    fn sharpens(&self, m: &ActivityMatrix, d: usize) -> bool {
        let Some(Clearance { m: clearance, .. }) = self.cfg.clearance() else { return false };
        if self.sharpened || self.s.elapsed_s() >= self.sharpen_until_s || self.kinds[d] != DofKind::Revolute {
            return false;
        }
        let dofs = m.dofs();
        let waits = self.waits_for_clearance(m, d);
        let blunt = (0..m.cells()).any(|u| {
            let i = u * dofs + d;
            m.get(u, d) == Activity::Unknown
                && self.doubts[i] == Some(Doubt::NearAxis)
                && waits(self.doubts[i])
                && self.seen[i] > clearance
        });
        let noise_bound = self
            .floor_cells(m, d)
            .into_iter()
            .filter_map(|u| self.pooled_lever(u * dofs + d))
            .all(|(lever, sigma)| self.cfg.confidence_sigmas * sigma > lever);
        blunt && noise_bound && self.still_floor(m, d).is_some()
    }

    /// Which doubts of DoF `d` the mounting clearance settles once a lever
    /// is bounded below it: a cell that a coupled DoF moves without turning
    /// it shows no gravity change, and one near a revolute axis no posture
    /// can tilt any more shows none either.
    fn waits_for_clearance(&self, m: &ActivityMatrix, d: usize) -> impl Fn(Option<Doubt>) -> bool {
        let untiltable = self.kinds[d] == DofKind::Revolute && self.next_carrier(m, d).is_none();
        move |doubt| match doubt {
            Some(Doubt::Coupled) => true,
            Some(Doubt::NearAxis) => untiltable,
            _ => false,
        }
    }

    /// Turns carrier `p` to tilt DoF `d`'s axis, measures `d` there (with
    /// longer averaging while the static test stays blind) and turns back.
    fn measure_tilted(&mut self, m: &mut ActivityMatrix, d: usize, p: usize) -> Result<(), ExploreError> {
        if !self.tilted_by[d].contains(&p) {
            self.tilted_by[d].push(p);
        }
        let turned = self.turn(m, p, self.cfg.tilt_rad)?;
        self.postures.push(self.s.positions());
        self.posture = self.postures.len() - 1;
        // In the tilted posture the static test has power once the
        // averaging beats the noise.
        let measured = loop {
            let measured = self.measure(m, d);
            if measured.is_err()
                || !self.last_blind
                || self.last_surely_blind
                || self.effort[d] >= MAX_EFFORT
                || self.out_of_time()
            {
                break measured;
            }
            self.effort[d] += 1;
        };
        if measured.is_ok() && !self.last_blind {
            self.tilt[d] = Some(p);
        }
        self.turn(m, p, -turned)?;
        self.posture = 0;
        measured
    }

    /// The next DoF to turn so that DoF `d`'s axis tilts: one known to
    /// carry `d` (it moves every cell `d` moves), nearest (fewest cells)
    /// first; if `d` moved no cell yet, any DoF not known to sit below it,
    /// nearest the root first. None once `MAX_TILTS` were tried.
    fn next_carrier(&self, m: &ActivityMatrix, d: usize) -> Option<usize> {
        if self.tilted_by[d].len() >= MAX_TILTS {
            return None;
        }
        let moved: Vec<usize> = (0..m.cells()).filter(|&u| m.is_moved(u, d)).collect();
        let count = |p: usize| (0..m.cells()).filter(|&u| m.is_moved(u, p)).count();
        let mut candidates: Vec<(isize, usize)> = (0..m.dofs())
            .filter(|&p| p != d && self.measured[p] && self.kinds[p] == DofKind::Revolute)
            .filter(|p| !self.tilted_by[d].contains(p))
            .filter(|&p| count(p) > 0)
            .filter(|&p| if moved.is_empty() { !below(m, p, d) } else { moved.iter().all(|&u| m.is_moved(u, p)) })
            .map(|p| (if moved.is_empty() { -(count(p) as isize) } else { count(p) as isize }, p))
            .collect();
        candidates.sort_unstable();
        candidates.first().map(|&(_, p)| p)
    }

    /// Steps DoF `d` once at its current effort and ors what it shows
    /// into `m`.
    fn measure(&mut self, m: &mut ActivityMatrix, d: usize) -> Result<(), ExploreError> {
        let cfg = self.cfg;
        let effort = self.effort[d];
        let average_s = cfg.average_s * f64::from(1u32 << effort);
        self.longest_average_s = self.longest_average_s.max(average_s);
        let base = match self.kinds[d] {
            DofKind::Revolute => cfg.step_rad,
            DofKind::Prismatic => cfg.step_m,
        };
        // Larger steps give a larger static change and lever signal.
        let growth = effort.max(self.grow[d]).min(MAX_GROWTH_EFFORT);
        let mut delta = base * (1.0 + 0.25 * f64::from(growth));
        let mut move_s = self.move_s(d, delta);
        if growth >= MAX_GROWTH_EFFORT {
            if let Some(fast) = self.fast(m, d) {
                (delta, move_s) = fast;
            }
        }
        let mut blocked = 0;
        let step = loop {
            let delta_now = self.direction[d] * delta;
            let step = self.step(d, delta_now, move_s, average_s)?;
            self.direction[d] = -self.direction[d];
            // Less than a quarter of the step: at a limit. Try the other
            // way, then smaller steps (a short prismatic or revolute range).
            if step.moved_rad.abs() >= 0.25 * delta {
                break step;
            }
            blocked += 1;
            if blocked % 2 == 0 {
                if blocked / 2 > MAX_HALVINGS {
                    return Err(ExploreError::Stuck(self.s.dof_name(d)));
                }
                delta *= 0.5;
            }
        };
        self.done += 1;
        self.measured[d] = true;
        self.record(m, d, &step);
        Ok(())
    }

    /// Ors a step's readings of DoF `d` into `m` and notes the doubts.
    fn record(&mut self, m: &mut ActivityMatrix, d: usize, step: &Step) {
        let (readings, blind) = step.decide(self.cfg, self.kinds[d]);
        // The latest word on the start posture: a first step's noise can
        // pass for a gravity change, the repeats' cannot all.
        if self.posture == 0 {
            self.blind[d] = blind;
        }
        self.last_blind = blind;
        self.last_surely_blind = blind && step.surely_blind(self.cfg);
        let posture = self.posture;
        let dofs = m.dofs();
        for (u, seen) in step.seen(self.cfg, self.kinds[d]).into_iter().enumerate() {
            let i = u * dofs + d;
            self.seen[i] = self.seen[i].min(seen);
        }
        for (u, (reading, e)) in readings.into_iter().zip(&step.evidence).enumerate() {
            let (activity, basis) = match reading {
                Reading::Moved { by_static } => (Activity::Moved, basis(by_static, posture)),
                Reading::Still { by_static } => (Activity::Still, basis(by_static, posture)),
                Reading::Unknown(doubt) => {
                    let i = u * dofs + d;
                    let k = self.cfg.confidence_sigmas;
                    let (mut doubt, mut bound) = (doubt, e.lever_m + k * e.lever_sigma);
                    // Pool only steps that follow a step of the same DoF:
                    // another DoF's step leaves the base ringing.
                    let pooling = blind || doubt == Doubt::Coupled;
                    if pooling && posture == 0 && doubt != Doubt::Saturated && self.step_before == Some(d) {
                        // A coupled DoF's step is not blind: the base may
                        // rock with it, so only a sure lever is a movement.
                        let moved_m =
                            if blind { self.cfg.axis_lever_m } else { SURE_LEVER * self.cfg.lever_threshold_m };
                        let pooled = self.pool(i, e);
                        if let Some((_, sigma)) = pooled {
                            self.seen[i] = self.seen[i].min(moved_m + k * sigma);
                        }
                        match pooled {
                            Some((lever, sigma)) if lever - k * sigma > moved_m => {
                                m.or(u, d, Activity::Moved, Basis::Dynamic { posture });
                                continue;
                            }
                            Some((lever, sigma)) if blind && lever + k * sigma < self.cfg.axis_lever_m => {
                                (doubt, bound) = (Doubt::NearAxis, bound.min(lever + k * sigma));
                            }
                            Some((lever, sigma)) => bound = bound.min(lever + k * sigma),
                            None => {}
                        }
                    }
                    self.doubts[i] = Some(doubt);
                    if matches!(doubt, Doubt::NearAxis | Doubt::Coupled) {
                        self.lever_bound[i] = self.lever_bound[i].min(bound);
                    }
                    continue;
                }
            };
            m.or(u, d, activity, basis);
        }
        self.unrock(m, d);
    }

    /// Lowers the lever bounds of DoF `d`'s coupled cells with the base's
    /// rocking regressed out (see [`Sums`]), the cells decided still
    /// serving as the reference.
    fn unrock(&mut self, m: &ActivityMatrix, d: usize) {
        let Some(sums) = self.sums[d].as_mut() else { return };
        let (cells, dofs) = (m.cells(), m.dofs());
        let open: Vec<usize> = (0..cells)
            .filter(|&u| m.get(u, d) == Activity::Unknown && self.doubts[u * dofs + d] == Some(Doubt::Coupled))
            .collect();
        if open.is_empty() {
            return;
        }
        let still: Vec<usize> = (0..cells).filter(|&u| m.get(u, d) == Activity::Still).collect();
        sums.update(&still, &open, MIN_FLOOR_CELLS);
        let k = self.cfg.confidence_sigmas;
        for u in open {
            if let Some((lever, sigma)) = sums.lever(u) {
                let bound = &mut self.lever_bound[u * dofs + d];
                *bound = bound.min(lever + k * sigma);
            }
        }
    }

    /// Pools a blind step's lever of entry `i` with the earlier ones (in
    /// the start posture the lever vector of a cell is the same every
    /// time); returns the pooled lever and its standard deviation, m.
    fn pool(&mut self, i: usize, e: &Evidence) -> Option<(f64, f64)> {
        let w = 1.0 / (e.lever_sigma * e.lever_sigma);
        if !(w.is_finite() && w > 0.0) || e.trace_saturated || !e.lever.iter().all(|x| x.is_finite()) {
            return None;
        }
        let p = &mut self.pooled[i];
        for (sum, l) in p.iter_mut().zip(e.lever) {
            *sum += w * l;
        }
        p[3] += w;
        self.pooled_lever(i)
    }

    /// Settles what decided entries imply, then what the mounting
    /// clearance (declared, or the default) does.
    fn settle(&mut self, m: &mut ActivityMatrix) {
        infer(m);
        if self.clear(m) {
            infer(m);
        }
    }

    /// On the mounting clearance (declared, or the default; none when
    /// strict): a cell waiting for it (see
    /// [`Explorer::waits_for_clearance`]) whose lever is bounded below the
    /// clearance would move less per radian than any cell the DoF moves,
    /// so by the clearance the DoF does not move it. Near an axis aligned
    /// with gravity, those cells measure the floor of what still cells
    /// show (see [`Explorer::still_floor`]): a waiting cell whose pooled
    /// lever stands surely above [`FLOOR_RATIO`] times it moved, however
    /// close to the axis it sits. (A coupled DoF's step rocks the base,
    /// more at some cells than at others; there the rocking is regressed
    /// out instead, see [`Sums`].) True if an entry changed.
    fn clear(&mut self, m: &mut ActivityMatrix) -> bool {
        let Some(Clearance { m: clearance, .. }) = self.cfg.clearance() else { return false };
        let (cells, dofs) = (m.cells(), m.dofs());
        let mut changed = false;
        for d in 0..dofs {
            if !m.column_undecided(d) {
                continue;
            }
            let waits = self.waits_for_clearance(m, d);
            let sharpening = self.sharpens(m, d);
            for u in 0..cells {
                let i = u * dofs + d;
                let settles = self.lever_bound[i] < clearance && waits(self.doubts[i]) && !sharpening;
                if m.get(u, d) == Activity::Unknown && settles {
                    changed |= m.or(u, d, Activity::Still, Basis::Clearance);
                }
            }
            let Some(moved_m) = self.still_floor(m, d) else { continue };
            let k = self.cfg.confidence_sigmas;
            for u in 0..cells {
                let i = u * dofs + d;
                if self.doubts[i] == Some(Doubt::NearAxis) {
                    if let Some((_, sigma)) = self.pooled_lever(i) {
                        self.seen[i] = self.seen[i].min(moved_m + k * sigma);
                    }
                }
                let surely_above = self.pooled_lever(i).is_some_and(|(lever, sigma)| lever - k * sigma > moved_m);
                if m.get(u, d) == Activity::Unknown && self.doubts[i] == Some(Doubt::NearAxis) && surely_above {
                    changed |= m.or(u, d, Activity::Moved, Basis::Dynamic { posture: 0 });
                }
            }
        }
        changed
    }

    /// The lever a cell must surely show to move with DoF `d`:
    /// [`FLOOR_RATIO`] times the most lever, with its margin, that the
    /// pooled steps show on the cells it leaves still
    /// ([`Explorer::floor_cells`]), at least [`MIN_FLOOR_CELLS`] of them,
    /// or `None`. During the step every link
    /// the DoF does not move is held rigidly to the base, so what those
    /// cells show is one rigid body's acceleration field, affine in the
    /// place; a turn about a vertical axis does not rock the robot on its
    /// feet, so what remains is noise and sway, measured small over the
    /// cells of a whole robot and not many times larger at another cell of
    /// it. A lever far above it is the DoF's own.
    fn still_floor(&self, m: &ActivityMatrix, d: usize) -> Option<f64> {
        let (dofs, k) = (m.dofs(), self.cfg.confidence_sigmas);
        let pooled: Vec<(f64, f64)> =
            self.floor_cells(m, d).into_iter().filter_map(|u| self.pooled_lever(u * dofs + d)).collect();
        let most = pooled.iter().map(|(lever, sigma)| lever + k * sigma).fold(0.0, f64::max);
        (pooled.len() >= MIN_FLOOR_CELLS).then_some(FLOOR_RATIO * most)
    }

    /// The cells whose pooled levers make DoF `d`'s floor: those decided
    /// still, and those waiting for the mounting clearance whose levers
    /// the evidence already bounds below it. The floor is what their
    /// levers measure, whether or not the clearance settles them yet.
    fn floor_cells(&self, m: &ActivityMatrix, d: usize) -> Vec<usize> {
        let dofs = m.dofs();
        let clearance = self.cfg.clearance().map_or(0.0, |c| c.m);
        let waits = self.waits_for_clearance(m, d);
        (0..m.cells())
            .filter(|&u| {
                let i = u * dofs + d;
                m.get(u, d) == Activity::Still
                    || (m.get(u, d) == Activity::Unknown && waits(self.doubts[i]) && self.lever_bound[i] < clearance)
            })
            .collect()
    }

    /// Entry `i`'s pooled lever and its standard deviation, m, if any step was pooled.
    fn pooled_lever(&self, i: usize) -> Option<(f64, f64)> {
        let [x, y, z, w] = self.pooled[i];
        (w > 0.0).then(|| ((x * x + y * y + z * z).sqrt() / w, 1.0 / w.sqrt()))
    }

    /// Turns DoF `p` by about `delta` (the other way if it is at a limit),
    /// ors what the turn shows about `p` into `m`, and returns how far it
    /// really turned, rad.
    fn turn(&mut self, m: &mut ActivityMatrix, p: usize, delta: f64) -> Result<f64, ExploreError> {
        let average_s = self.cfg.average_s;
        let step = self.step(p, delta, self.move_s(p, delta), average_s)?;
        let mut turned = step.moved_rad;
        self.record(m, p, &step);
        if turned.abs() < 0.25 * delta.abs() {
            let back = self.step(p, -delta, self.move_s(p, -delta), average_s)?;
            turned += back.moved_rad;
            self.record(m, p, &back);
        }
        Ok(turned)
    }

    /// A still window of `average_s`, kept with the posture it was taken in.
    fn still(&mut self, average_s: f64) -> Result<Window, ExploreError> {
        let window = self.s.window(average_s)?;
        self.stills.push((self.s.positions(), window.clone()));
        Ok(window)
    }

    /// How long a step of DoF `d` by `delta` moves, s: the configured time,
    /// longer for a larger step so that its peak acceleration stays the
    /// configured step's. (Its peak velocity, `2 delta / time`, is what
    /// the configuration asks, 2 rad/s by default: a robot with slower
    /// joints clips it.)
    fn move_s(&self, d: usize, delta: f64) -> f64 {
        let base = match self.kinds[d] {
            DofKind::Revolute => self.cfg.step_rad,
            DofKind::Prismatic => self.cfg.step_m,
        };
        self.cfg.move_s * (delta.abs() / base).sqrt().max(1.0)
    }

    /// The fast repeat of a revolute DoF about an axis aligned with
    /// gravity (it moves cells and turns none) whose velocity limit the
    /// robot gives, `(step, move time)`: in [`FAST_MOVE_S`], peak
    /// acceleration [`FAST_ACCEL_RAD_S2`] or less so that the peak velocity
    /// stays within [`VELOCITY_SHARE`] of the limit; the lever's noise
    /// falls with the acceleration. None where it would not beat the configured step's
    /// acceleration, where the DoF is coupled, or where it moved no cell
    /// yet, so that its axis may be horizontal: such steps rock a standing
    /// robot, the faster the more.
    fn fast(&self, m: &ActivityMatrix, d: usize) -> Option<(f64, f64)> {
        let dofs = self.s.dofs();
        let coupled = self.doubts.iter().skip(d).step_by(dofs).any(|&doubt| doubt == Some(Doubt::Coupled));
        let vertical = self.blind[d] && (0..m.cells()).any(|u| m.is_moved(u, d));
        if self.kinds[d] != DofKind::Revolute || !vertical || self.posture != 0 || coupled {
            return None;
        }
        let limit = VELOCITY_SHARE * self.s.velocity_limit(d)?;
        let move_s = FAST_MOVE_S;
        // Peak velocity 2 delta / t, peak acceleration 2 pi delta / t^2.
        let delta = (FAST_ACCEL_RAD_S2 * move_s * move_s / std::f64::consts::TAU).min(0.5 * limit * move_s);
        let accel = |delta: f64, move_s: f64| std::f64::consts::TAU * delta / (move_s * move_s);
        let configured = accel(self.cfg.step_rad, self.cfg.move_s);
        (accel(delta, move_s) > configured).then_some((delta, move_s))
    }

    /// One step of DoF `d` by `delta` in `move_s`: the motion, settling,
    /// and a still window of `average_s` that is also the next step's
    /// "before".
    fn step(&mut self, d: usize, delta: f64, move_s: f64, average_s: f64) -> Result<Step, ExploreError> {
        // The "before" must be as long as the "after", or its noise rules.
        if self.pre_s < average_s {
            self.pre = self.still(average_s)?;
            self.pre_s = average_s;
        }
        self.step_before = self.last_step.replace(d);
        let trace = self.s.trace(d, move_s + self.cfg.settle_s, |t| raised_cosine(delta, move_s, t))?;
        let post = self.still(average_s)?;
        let step = Step::measure(&self.pre, &post, &trace, self.s.tick_s(), self.s.lsb_mps2());
        let dofs = self.s.dofs();
        let coupled = self.doubts.iter().skip(d).step_by(dofs).any(|&doubt| doubt == Some(Doubt::Coupled));
        if coupled && self.posture == 0 && self.step_before == Some(d) {
            let (_, _, alpha) = trace.motion(self.s.tick_s());
            let noise: Vec<f64> = step.evidence.iter().map(|e| e.noise_var).collect();
            let cells = noise.len();
            self.sums[d].get_or_insert_with(|| Sums::new(cells)).add(&self.pre, &post, &trace, &alpha, &noise);
        }
        self.pre = post;
        self.pre_s = average_s;
        Ok(step)
    }
}

fn basis(by_static: bool, posture: usize) -> Basis {
    if by_static {
        Basis::Static { posture }
    } else {
        Basis::Dynamic { posture }
    }
}

/// DoF `e` surely does not sit below DoF `d`: it moves a cell `d` does not.
fn not_below(m: &ActivityMatrix, e: usize, d: usize) -> bool {
    (0..m.cells()).any(|y| m.is_moved(y, e) && m.is_still(y, d))
}

/// DoF `e` surely sits below DoF `d` (or beside it in one joint): they
/// move a cell together, and `d` moves a cell `e` does not, so `e` does
/// not carry `d`.
fn below(m: &ActivityMatrix, e: usize, d: usize) -> bool {
    let comparable = (0..m.cells()).any(|x| m.is_moved(x, d) && m.is_moved(x, e));
    comparable && not_below(m, d, e)
}

/// Settles the undecided entries that the decided ones imply in a
/// kinematic tree, where the cells any two DoFs move are nested or
/// disjoint: if `e` sits below `d`, what `e` moves `d` moves and what `d`
/// leaves still `e` leaves still; if they sit on different branches, what
/// one moves the other leaves still. Never turns a decided entry.
pub(crate) fn infer(m: &mut ActivityMatrix) {
    let (cells, dofs) = (m.cells(), m.dofs());
    let mut changed = true;
    while changed {
        changed = false;
        for d in 0..dofs {
            if !m.column_undecided(d) {
                continue;
            }
            for e in (0..dofs).filter(|&e| e != d) {
                let e_below_d = below(m, e, d);
                let d_below_e = below(m, d, e);
                let apart = !e_below_d && !d_below_e && not_below(m, e, d) && not_below(m, d, e);
                let open: Vec<usize> = (0..cells).filter(|&u| m.get(u, d) == Activity::Unknown).collect();
                for u in open {
                    let implied = match m.get(u, e) {
                        Activity::Moved if e_below_d => Activity::Moved,
                        Activity::Moved if apart => Activity::Still,
                        Activity::Still if d_below_e => Activity::Still,
                        _ => continue,
                    };
                    changed |= m.or(u, d, implied, Basis::Tree);
                }
            }
        }
    }
}

/// Position of a step of `delta` rad over `duration` s with a raised-cosine
/// velocity: it starts and ends at rest with zero acceleration, so the only
/// jolt it gives is the tangential acceleration the lever test looks for.
fn raised_cosine(delta: f64, duration: f64, t: f64) -> f64 {
    let tau = (t / duration).clamp(0.0, 1.0);
    delta * (tau - (std::f64::consts::TAU * tau).sin() / std::f64::consts::TAU)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn a_raised_cosine_step_lands_exactly_and_smoothly() {
        assert_eq!(raised_cosine(0.1, 0.2, 0.0), 0.0);
        assert!((raised_cosine(0.1, 0.2, 0.1) - 0.05).abs() < 1e-15);
        assert_eq!(raised_cosine(0.1, 0.2, 0.2), 0.1);
        assert_eq!(raised_cosine(0.1, 0.2, 5.0), 0.1);
        // Velocity at both ends is zero.
        let h = 1e-6;
        assert!(raised_cosine(0.1, 0.2, h) / h < 1e-6);
        assert!((0.1 - raised_cosine(0.1, 0.2, 0.2 - h)) / h < 1e-6);
    }

    #[test]
    fn the_papers_setting_is_valid_and_bad_settings_are_refused() {
        assert!(StructureConfig::paper().check().is_ok());
        assert!(StructureConfig::default().check().is_ok());
        for bad in [
            StructureConfig { runs: 0, ..StructureConfig::default() },
            StructureConfig { average_s: f64::NAN, ..StructureConfig::default() },
            StructureConfig { budget_s: 0.0, ..StructureConfig::default() },
            StructureConfig { axis_clearance_m: -0.01, ..StructureConfig::default() },
            StructureConfig { axis_clearance_m: f64::INFINITY, ..StructureConfig::default() },
            StructureConfig { cell_pitch_m: 0.0, ..StructureConfig::default() },
        ] {
            assert!(matches!(bad.check(), Err(ExploreError::Config(_))), "{bad:?}");
        }
    }

    #[test]
    fn the_clearance_is_the_declared_one_else_the_default_from_the_pitch_else_none_when_strict() {
        let default = StructureConfig::default().clearance().unwrap();
        assert!(!default.declared);
        assert!((default.m - 0.001).abs() < 1e-12, "1/25 of the 25 mm pitch: {} m", default.m);
        assert!(default.describe(0.025).contains("1/25 of the 25 mm cell pitch"), "{}", default.describe(0.025));
        let pitch = StructureConfig { cell_pitch_m: 0.05, ..StructureConfig::default() };
        assert!((pitch.clearance().unwrap().m - 0.002).abs() < 1e-12);
        let declared = StructureConfig { axis_clearance_m: 0.02, strict: true, ..StructureConfig::default() };
        assert_eq!(declared.clearance(), Some(Clearance { m: 0.02, declared: true }));
        assert_eq!(StructureConfig { strict: true, ..StructureConfig::default() }.clearance(), None);
    }

    /// Rows of a true activity matrix: chain 0 -> 1 (cells 1..=3), a branch
    /// 2 beside them (cells 4, 5), cell 0 on the root.
    fn truth() -> Vec<Vec<bool>> {
        vec![
            vec![false, false, false],
            vec![true, false, false],
            vec![true, true, false],
            vec![true, true, false],
            vec![false, false, true],
            vec![false, false, true],
        ]
    }

    #[test]
    fn the_tree_settles_what_it_implies() {
        let rows = truth();
        let mut m = ActivityMatrix::unknown(6, 3);
        // Decided: DoF 1's cells are moved by 0 (cell 2), 0 moves cell 1
        // that 1 leaves still; DoF 2 moves 4 and 0 leaves 4 still.
        for (u, d) in [(1, 0), (2, 0), (2, 1), (1, 1), (4, 2), (4, 0), (1, 2), (3, 1)] {
            m.or(u, d, if rows[u][d] { Activity::Moved } else { Activity::Still }, Basis::Dynamic { posture: 0 });
        }
        infer(&mut m);
        // Cell 3 moves with DoF 1, which sits below DoF 0.
        assert_eq!(m.get(3, 0), Activity::Moved);
        assert_eq!(m.basis(3, 0), Some(Basis::Tree));
        // DoF 2 is on another branch than 0: what 0 moves it leaves still.
        assert_eq!(m.get(2, 2), Activity::Still);
        assert_eq!(m.get(3, 2), Activity::Still);
        // Nothing about the root cell or cell 5 can be implied.
        assert_eq!(m.get(0, 0), Activity::Unknown);
        assert_eq!(m.get(5, 0), Activity::Unknown);
    }

    proptest! {
        /// Whatever part of a true tree's matrix is known, inference never
        /// contradicts the truth.
        #[test]
        fn inference_never_contradicts_the_truth(known in prop::collection::vec(any::<bool>(), 18)) {
            let rows = truth();
            let mut m = ActivityMatrix::unknown(6, 3);
            for (i, k) in known.iter().enumerate() {
                let (u, d) = (i / 3, i % 3);
                if *k {
                    m.or(u, d, if rows[u][d] { Activity::Moved } else { Activity::Still }, Basis::Static { posture: 0 });
                }
            }
            infer(&mut m);
            for (u, row) in rows.iter().enumerate() {
                for (d, &moved) in row.iter().enumerate() {
                    let truth = if moved { Activity::Moved } else { Activity::Still };
                    prop_assert!(m.get(u, d) == Activity::Unknown || m.get(u, d) == truth, "cell {} DoF {}", u, d);
                }
            }
        }
    }
}
