//! The structural exploration (section 4.2.5), made adaptive.
//!
//! Every DoF is stepped in turn and each cell decided from the evidence of
//! [`activity`](super::activity). Entries still undecided are measured again,
//! back the other way with twice the averaging. A DoF whose axis is aligned
//! with gravity leaves the static test blind; rather than trusting the
//! dynamic test alone, the exploration then turns the nearest DoF known to
//! carry it (one that moves every cell it moves) by `tilt_rad`, measures it
//! again in that posture and turns back: the paper's "change the posture of
//! the robot", done automatically and only where needed. Only a DoF with no
//! such DoF before it (the first joint of an arm on a level base) stays
//! blind, and is reported.

use super::activity::{Activity, ActivityMatrix, Step};
use super::session::{Session, Window};
use super::ExploreError;
use crate::robot::{Robot, SampleSource};

/// Parameters of the structural exploration (section 4.2).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StructureConfig {
    /// Position step of each DoF, rad (the paper: 0.1).
    pub step_rad: f64,
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
    /// A lever arm above this means the cell moved, m.
    pub lever_threshold_m: f64,
    /// Margin of every decision, in standard deviations of its noise.
    pub confidence_sigmas: f64,
    /// Repeats (back and forth, with doubled averaging) while entries stay undecided.
    pub retries: usize,
    /// How far a proximal DoF turns to tilt a gravity-aligned axis, rad.
    pub tilt_rad: f64,
}

impl Default for StructureConfig {
    /// 0.2 rad steps of 0.2 s, 0.05 s settling, 0.1 s averaging, one run:
    /// error-free over 1,000 seeds of the HRP-2-like robot in 6.5 s of robot
    /// time (the `explore` benchmark). The sweep's fastest error-free
    /// setting, 0.3 rad without settling and 0.05 s averaging (5.5 s), drives
    /// the arms at their 3 rad/s limit and leaves no settling margin.
    fn default() -> Self {
        StructureConfig {
            step_rad: 0.2,
            move_s: 0.2,
            settle_s: 0.05,
            average_s: 0.1,
            runs: 1,
            static_fraction: 0.1,
            lever_threshold_m: 0.01,
            confidence_sigmas: 6.0,
            retries: 2,
            tilt_rad: 0.3,
        }
    }
}

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

    /// Refuses values the method cannot work with.
    pub fn check(&self) -> Result<(), ExploreError> {
        let positive =
            [self.step_rad, self.move_s, self.average_s, self.lever_threshold_m, self.confidence_sigmas, self.tilt_rad];
        if !positive.iter().all(|v| v.is_finite() && *v > 0.0)
            || self.settle_s.is_nan()
            || self.settle_s < 0.0
            || self.runs == 0
        {
            return Err(ExploreError::Config(
                "step, move time, averaging window, lever threshold, confidence and tilt must be positive, settling not negative, and at least one run".into(),
            ));
        }
        if !(self.static_fraction > 0.0 && self.static_fraction < 1.0) {
            return Err(ExploreError::Config("the static threshold fraction must be between 0 and 1".into()));
        }
        Ok(())
    }
}

/// The or-ed activity matrix and the DoFs that stayed static-blind.
pub(crate) struct Outcome {
    pub activity: ActivityMatrix,
    pub blind: Vec<usize>,
}

/// Steps every DoF, run after run; `progress` gets the number of DoF
/// measurements done.
pub(crate) fn explore<R: Robot + SampleSource>(
    session: &mut Session<'_, R>,
    cfg: &StructureConfig,
    dof_names: &[String],
    progress: &mut dyn FnMut(usize),
) -> Result<Outcome, ExploreError> {
    let (cells, dofs) = (session.cells().len(), session.dofs());
    session.hold(cfg.settle_s)?;
    let pre = session.window(cfg.average_s)?;
    let mut x = Explorer { s: session, cfg, dof_names, pre };
    let mut activity = ActivityMatrix::unknown(cells, dofs);
    let mut measured = vec![false; dofs];
    let mut blind = vec![true; dofs];
    for run in 0..cfg.runs {
        let direction = if run % 2 == 0 { 1.0 } else { -1.0 };
        for d in 0..dofs {
            let (mut column, mut is_blind) = x.measure(d, direction)?;
            if is_blind {
                for p in carriers(&activity, &measured, &column, d) {
                    let turned = x.turn(p, cfg.tilt_rad)?;
                    let (tilted, still_blind) = x.measure(d, direction)?;
                    x.turn(p, -turned)?;
                    for (c, t) in column.iter_mut().zip(tilted) {
                        *c = c.or(t);
                    }
                    is_blind = still_blind;
                    if !is_blind {
                        break;
                    }
                }
            }
            blind[d] &= is_blind;
            measured[d] = true;
            for (u, a) in column.into_iter().enumerate() {
                activity.or(u, d, a);
            }
            progress(run * dofs + d + 1);
        }
    }
    Ok(Outcome { activity, blind: (0..dofs).filter(|&d| blind[d]).collect() })
}

/// DoFs already measured that move every cell `column` says DoF `d`
/// moved, so turning them tilts `d`'s axis: nearest (fewest cells) first.
fn carriers(activity: &ActivityMatrix, measured: &[bool], column: &[Activity], d: usize) -> Vec<usize> {
    let moved: Vec<usize> = (0..column.len()).filter(|&u| column[u] == Activity::Moved).collect();
    if moved.is_empty() {
        return Vec::new();
    }
    let mut carriers: Vec<(usize, usize)> = (0..measured.len())
        .filter(|&p| p != d && measured[p] && moved.iter().all(|&u| activity.is_moved(u, p)))
        .map(|p| ((0..activity.cells()).filter(|&u| activity.is_moved(u, p)).count(), p))
        .collect();
    carriers.sort_unstable();
    carriers.into_iter().map(|(_, p)| p).collect()
}

struct Explorer<'x, 'r, R> {
    s: &'x mut Session<'r, R>,
    cfg: &'x StructureConfig,
    dof_names: &'x [String],
    /// The still window before the next motion.
    pre: Window,
}

impl<R: Robot + SampleSource> Explorer<'_, '_, R> {
    /// Steps DoF `d` (the other way if it is at a limit, again while
    /// entries stay undecided) and returns its decided column and whether
    /// every measurement was static-blind.
    fn measure(&mut self, d: usize, direction: f64) -> Result<(Vec<Activity>, bool), ExploreError> {
        let cfg = self.cfg;
        let mut column = vec![Activity::Unknown; self.s.cells().len()];
        let (mut direction, mut attempt, mut blocked, mut blind) = (direction, 0, 0, true);
        loop {
            let average_s = cfg.average_s * f64::from(1u32 << attempt.min(16));
            let step = self.step(d, direction * cfg.step_rad, average_s)?;
            // Less than a quarter of the step: at a limit.
            if step.moved_rad.abs() < 0.25 * cfg.step_rad {
                blocked += 1;
                if blocked > 1 {
                    return Err(ExploreError::Stuck(self.dof_names[d].clone()));
                }
                direction = -direction;
                continue;
            }
            let (decisions, is_blind) = step.decide(cfg);
            blind &= is_blind;
            for (c, a) in column.iter_mut().zip(decisions) {
                *c = c.or(a);
            }
            if !column.contains(&Activity::Unknown) || attempt >= cfg.retries {
                return Ok((column, blind));
            }
            attempt += 1;
            direction = -direction;
        }
    }

    /// Turns DoF `p` by about `delta` (the other way if it is at a limit)
    /// and returns how far it really turned, rad.
    fn turn(&mut self, p: usize, delta: f64) -> Result<f64, ExploreError> {
        let mut turned = self.step(p, delta, self.cfg.average_s)?.moved_rad;
        if turned.abs() < 0.25 * delta.abs() {
            turned += self.step(p, -delta, self.cfg.average_s)?.moved_rad;
        }
        Ok(turned)
    }

    /// One step of DoF `d` by `delta`: the motion, settling, and a still
    /// window of `average_s` that is also the next step's "before".
    fn step(&mut self, d: usize, delta: f64, average_s: f64) -> Result<Step, ExploreError> {
        let move_s = self.cfg.move_s * (delta.abs() / self.cfg.step_rad).sqrt().max(1.0);
        let trace = self.s.trace(d, move_s + self.cfg.settle_s, |t| raised_cosine(delta, move_s, t))?;
        let post = self.s.window(average_s)?;
        let step = Step::measure(&self.pre, &post, &trace, self.s.tick_s(), self.s.lsb_mps2());
        self.pre = post;
        Ok(step)
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
        let bad = StructureConfig { runs: 0, ..StructureConfig::default() };
        assert!(matches!(bad.check(), Err(ExploreError::Config(_))));
        let bad = StructureConfig { average_s: f64::NAN, ..StructureConfig::default() };
        assert!(matches!(bad.check(), Err(ExploreError::Config(_))));
    }

    #[test]
    fn carriers_are_the_dofs_moving_every_moved_cell_nearest_first() {
        use Activity::*;
        // Cells 0..3; DoF 0 moves 1, 2, 3; DoF 1 moves 2, 3; DoF 2 moves 1.
        let rows = vec![
            vec![false, false, false, false],
            vec![true, false, true, false],
            vec![true, true, false, false],
            vec![true, true, false, false],
        ];
        let am = ActivityMatrix::from_rows(&rows);
        let measured = [true, true, true, false];
        // DoF 3 moved cells 2 and 3 (cell 0 undecided).
        let column = [Unknown, Still, Moved, Moved];
        assert_eq!(carriers(&am, &measured, &column, 3), vec![1, 0]);
        assert!(carriers(&am, &measured, &[Unknown, Still, Still, Still], 3).is_empty());
    }
}
