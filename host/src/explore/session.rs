//! One exploration session on the robot: commands go out and samples come
//! in one tick at a time, only through [`Robot`] and [`SampleSource`].
//!
//! Raw accelerometer counts become m/s^2 here (the host knows the range it
//! configured); everything downstream works on per-cell accelerations.

use std::collections::HashMap;

use skin_protocol::message::AccelRange;
use skin_protocol::message::G0;
use skin_protocol::sample::{ACCEL_MAX, ACCEL_MIN};
use skin_protocol::{Address, Sample};

use super::ExploreError;
use crate::robot::{Robot, RobotError, SampleSource};

/// Proportional gain of position corrections, 1/s.
const POSITION_GAIN: f64 = 8.0;

/// Ticks a session waits for the first samples: a skin on its own clock
/// (not in lockstep with the robot) can leave a tick without a datagram.
const DISCOVER_TICKS: usize = 25;
/// Longest wait after a trace's commanded motion for the DoF to come to rest, s.
const MAX_SETTLE_S: f64 = 1.0;
/// A move whose worst DoF has not come half its tolerance closer to its
/// target for this long is blocked, s: a free joint, even one creeping
/// the last millimetres against a coupling, gets closer than that.
const STALL_S: f64 = 3.0;
/// A DoF is at rest when it moves less than [`REST_MOTION`] (rad or m)
/// over [`REST_TICKS`] ticks: 5 mrad/s at 4 ms ticks, well above
/// encoder noise, well below any commanded motion.
const REST_TICKS: usize = 5;
const REST_MOTION: f64 = 1e-4;
/// Spacing of the waypoints a move records for [`Session::retrace`], rad
/// (or m) on the DoF that moved most: fine enough that going back from one
/// to the one before does not cut a corner the robot's own shape forbids.
const RETRACE_STEP: f64 = 0.02;

/// Ticks of a trace left out on either side of one that took other than
/// one period of the robot's clock: the motion's central differences reach
/// one tick beyond it, and the calibration's delay search up to three more
/// (`CalibrateConfig::max_delay_ticks`), plus the fraction interpolated.
const IRREGULAR_REACH_TICKS: usize = 5;

/// Mean and spread of every cell's acceleration over a still window.
#[derive(Clone, Debug)]
pub(crate) struct Window {
    /// Mean per cell, m/s^2.
    pub mean: Vec<[f64; 3]>,
    /// Sample variance per cell and axis, (m/s^2)^2.
    pub var: Vec<[f64; 3]>,
    /// Samples per cell.
    pub n: Vec<u32>,
    /// A cell hit the end of its range during the window.
    pub saturated: Vec<bool>,
}

/// Every cell's acceleration and the DoFs' positions, tick by tick.
#[derive(Clone, Debug)]
pub(crate) struct Trace {
    /// `accel[k * cells + u]`, m/s^2 (NaN where a sample was missing).
    pub accel: Vec<[f32; 3]>,
    /// Position of the traced DoF before the first tick, rad.
    pub q0: f64,
    /// Position of the traced DoF at each tick, rad.
    pub q: Vec<f64>,
    /// Every DoF's position before the first tick: the others are held,
    /// but a real robot's joints give a little under their neighbours'
    /// reactions.
    pub start: Vec<f64>,
    /// Every DoF's position at each tick, `positions[k * dofs + d]`.
    pub positions: Vec<f64>,
    /// A cell hit the end of its range during the trace.
    pub saturated: Vec<bool>,
}

impl Trace {
    /// Ticks recorded.
    pub fn len(&self) -> usize {
        self.q.len()
    }

    /// The ticks with a sample of any cell: a regression on the trace's
    /// motion skips the others, which say nothing of any cell (ticks
    /// [`Session::trace`] left out, or where the whole skin sent nothing).
    pub fn sampled_ticks(&self) -> Vec<usize> {
        let cells = self.saturated.len();
        (0..self.len())
            .filter(|&k| {
                let samples = self.accel.get(k * cells..(k + 1) * cells).unwrap_or_default();
                samples.iter().any(|a| a.iter().all(|x| x.is_finite()))
            })
            .collect()
    }

    /// Leaves out the samples of the ticks `irregular` and of those within
    /// [`IRREGULAR_REACH_TICKS`] of them: the motion read there spans a
    /// stretch of the robot's clock the feedback did not see.
    fn leave_out(&mut self, irregular: &[usize]) {
        let cells = self.saturated.len();
        for &k in irregular {
            let ticks = k.saturating_sub(IRREGULAR_REACH_TICKS)..(k + IRREGULAR_REACH_TICKS + 1).min(self.len());
            self.accel[ticks.start * cells..ticks.end * cells].fill([f32::NAN; 3]);
        }
        if !irregular.is_empty() {
            tracing::info!(
                ticks = irregular.len(),
                of = self.len(),
                "ticks took other than one period of the robot's clock (the host fell behind it): their samples and those around them left out"
            );
        }
    }

    /// The traced DoF's motion at each tick from its position feedback
    /// (central differences): position relative to the start, rad; velocity,
    /// rad/s; acceleration, rad/s^2. The DoF is taken at rest outside the trace.
    pub fn motion(&self, tick_s: f64) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
        differences(&self.q, self.q0, tick_s)
    }

    /// DoF `d`'s motion, as [`Trace::motion`] gives the traced DoF's.
    pub fn motion_of(&self, d: usize, tick_s: f64) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
        let q: Vec<f64> = self.positions.iter().skip(d).step_by(self.start.len()).copied().collect();
        differences(&q, self.start[d], tick_s)
    }
}

/// Position relative to `q0`, velocity and acceleration at each tick of
/// `q` by central differences, at rest before and after.
fn differences(q: &[f64], q0: f64, tick_s: f64) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let n = q.len() as isize;
    let at = |k: isize| if k < 0 { q0 } else { q[k.min(n - 1) as usize] };
    let phi = (0..n).map(|k| at(k) - q0).collect();
    let omega = (0..n).map(|k| (at(k + 1) - at(k - 1)) / (2.0 * tick_s)).collect();
    let alpha = (0..n).map(|k| (at(k + 1) - 2.0 * at(k) + at(k - 1)) / (tick_s * tick_s)).collect();
    (phi, omega, alpha)
}

pub(crate) struct Session<'r, R> {
    rig: &'r mut R,
    cells: Vec<Address>,
    index: HashMap<Address, usize>,
    dofs: usize,
    mps2_per_count: f64,
    tick_s: f64,
    elapsed_s: f64,
    samples: Vec<(Address, Sample)>,
    accel: Vec<[f64; 3]>,
    fresh: Vec<bool>,
    saturated: Vec<bool>,
    command: Vec<f64>,
    /// The robot's clock at the last feedback, s, where it tells it.
    robot_s: Option<f64>,
    /// The last tick took one period of the robot's clock (or it has none).
    regular: bool,
    /// Whether the user was told of irregular ticks.
    warned_irregular: bool,
    /// The last [`Session::move_to`]'s way, from where it started to where
    /// it ended, every [`RETRACE_STEP`].
    path: Vec<Vec<f64>>,
}

impl<'r, R: Robot + SampleSource> Session<'r, R> {
    /// Opens a session on the cells that report in the first tick that
    /// brings samples, within [`DISCOVER_TICKS`].
    pub fn discover(rig: &'r mut R, range: AccelRange) -> Result<Session<'r, R>, ExploreError> {
        let mut s = Session::with_cells(rig, Vec::new(), range);
        for _ in 0..DISCOVER_TICKS {
            s.tick()?;
            if !s.samples.is_empty() {
                break;
            }
        }
        let mut cells: Vec<Address> = s.samples.iter().map(|(a, _)| *a).collect();
        cells.sort_unstable();
        cells.dedup();
        if cells.is_empty() {
            return Err(ExploreError::NoCells);
        }
        let (elapsed, robot_s) = (s.elapsed_s, s.robot_s);
        let mut s = Session::with_cells(s.rig, cells, range);
        (s.elapsed_s, s.robot_s) = (elapsed, robot_s);
        Ok(s)
    }

    /// Opens a session on known cells.
    pub fn with_cells(rig: &'r mut R, cells: Vec<Address>, range: AccelRange) -> Session<'r, R> {
        let dofs = rig.dof_count();
        let u = cells.len();
        Session {
            index: cells.iter().enumerate().map(|(i, a)| (*a, i)).collect(),
            cells,
            dofs,
            mps2_per_count: G0 / range.counts_per_g(),
            tick_s: rig.tick_s(),
            elapsed_s: 0.0,
            rig,
            samples: Vec::new(),
            accel: vec![[f64::NAN; 3]; u],
            fresh: vec![false; u],
            saturated: vec![false; u],
            command: vec![0.0; dofs],
            robot_s: None,
            regular: true,
            warned_irregular: false,
            path: Vec::new(),
        }
    }

    pub fn cells(&self) -> &[Address] {
        &self.cells
    }

    pub fn dofs(&self) -> usize {
        self.dofs
    }

    pub fn tick_s(&self) -> f64 {
        self.tick_s
    }

    /// Robot time spent so far, s.
    pub fn elapsed_s(&self) -> f64 {
        self.elapsed_s
    }

    /// One LSB of the accelerometers, m/s^2.
    pub fn lsb_mps2(&self) -> f64 {
        self.mps2_per_count
    }

    pub fn dof_name(&self, d: usize) -> String {
        self.rig.dof_names().get(d).cloned().unwrap_or_else(|| format!("#{d}"))
    }

    pub fn positions(&self) -> Vec<f64> {
        self.rig.positions()
    }

    /// DoF `d`'s velocity limit, where the robot says.
    pub fn velocity_limit(&self, d: usize) -> Option<f64> {
        self.rig.velocity_limits().get(d).copied().flatten()
    }

    /// Sends the current command, waits one tick and takes in its samples.
    fn tick(&mut self) -> Result<(), ExploreError> {
        self.rig.command_velocities(&self.command)?;
        self.samples.clear();
        self.rig.next_tick(&mut self.samples)?;
        if let Some(d) = self.rig.positions().iter().position(|q| !q.is_finite()) {
            return Err(RobotError::FeedbackNotFinite(d).into());
        }
        self.elapsed_s += self.tick_s;
        let now = self.rig.robot_time_s();
        self.regular = match (self.robot_s, now) {
            (Some(before), Some(now)) => ((now - before) / self.tick_s - 1.0).abs() < 0.5,
            _ => true,
        };
        self.robot_s = now;
        self.fresh.fill(false);
        for (addr, s) in &self.samples {
            // Cells that join after discovery are not part of this session.
            let Some(&u) = self.index.get(addr) else { continue };
            let counts = s.accel();
            self.accel[u] = counts.map(|c| f64::from(c) * self.mps2_per_count);
            self.fresh[u] = true;
            self.saturated[u] = counts.iter().any(|&c| c == ACCEL_MIN || c == ACCEL_MAX);
        }
        Ok(())
    }

    /// Holds still for `seconds` without recording.
    pub fn hold(&mut self, seconds: f64) -> Result<(), ExploreError> {
        self.command.fill(0.0);
        for _ in 0..self.ticks(seconds) {
            self.tick()?;
        }
        Ok(())
    }

    /// Holds still for `seconds` and averages every cell.
    pub fn window(&mut self, seconds: f64) -> Result<Window, ExploreError> {
        let u = self.cells.len();
        let mut sum = vec![[0.0; 3]; u];
        let mut sum_sq = vec![[0.0; 3]; u];
        let mut n = vec![0u32; u];
        let mut saturated = vec![false; u];
        self.command.fill(0.0);
        for _ in 0..self.ticks(seconds).max(2) {
            self.tick()?;
            for c in 0..u {
                if !self.fresh[c] {
                    continue;
                }
                n[c] += 1;
                saturated[c] |= self.saturated[c];
                for k in 0..3 {
                    sum[c][k] += self.accel[c][k];
                    sum_sq[c][k] += self.accel[c][k] * self.accel[c][k];
                }
            }
        }
        if let Some(c) = n.iter().position(|&k| k < 2) {
            return Err(ExploreError::Silent(self.cells[c]));
        }
        let mean: Vec<[f64; 3]> = (0..u).map(|c| sum[c].map(|s| s / f64::from(n[c]))).collect();
        let var = (0..u)
            .map(|c| {
                let k = f64::from(n[c]);
                std::array::from_fn(|a| ((sum_sq[c][a] - k * mean[c][a] * mean[c][a]) / (k - 1.0)).max(0.0))
            })
            .collect();
        Ok(Window { mean, var, n, saturated })
    }

    /// Drives DoF `dof` along the position profile `phi(t)` (rad, relative
    /// to the start, `phi(0) = 0`) for `seconds`, recording every tick. Each
    /// tick commands the profile's mean velocity over that tick, so the
    /// commanded positions are exact at every tick.
    pub fn trace(&mut self, dof: usize, seconds: f64, phi: impl Fn(f64) -> f64) -> Result<Trace, ExploreError> {
        let u = self.cells.len();
        let ticks = self.ticks(seconds);
        let start = self.rig.positions();
        let mut trace = Trace {
            accel: Vec::with_capacity(ticks * u),
            q0: start[dof],
            q: Vec::with_capacity(ticks),
            positions: Vec::with_capacity(ticks * start.len()),
            start,
            saturated: vec![false; u],
        };
        let mut irregular = Vec::new();
        self.command.fill(0.0);
        // A real joint lags a command faster than its motors can follow:
        // the trace goes on, commanding nothing, until the DoF has come to
        // rest, so that the motion is whole and what follows is still.
        let settle = self.ticks(MAX_SETTLE_S);
        for k in 0.. {
            let moving = trace.q.len() >= REST_TICKS
                && (trace.q[trace.q.len() - 1] - trace.q[trace.q.len() - REST_TICKS]).abs() > REST_MOTION;
            if k >= ticks + settle || (k >= ticks && !moving) {
                break;
            }
            let t = k as f64 * self.tick_s;
            self.command[dof] = if k < ticks { (phi(t + self.tick_s) - phi(t)) / self.tick_s } else { 0.0 };
            self.tick()?;
            if !self.regular {
                irregular.push(k);
            }
            let q = self.rig.positions();
            trace.q.push(q[dof]);
            trace.positions.extend_from_slice(&q);
            for c in 0..u {
                let a = if self.fresh[c] { self.accel[c].map(|x| x as f32) } else { [f32::NAN; 3] };
                trace.accel.push(a);
                trace.saturated[c] |= self.saturated[c];
            }
        }
        self.command.fill(0.0);
        trace.leave_out(&irregular);
        if !irregular.is_empty() && !std::mem::replace(&mut self.warned_irregular, true) {
            tracing::warn!(
                "the host fell behind the robot's clock: motion samples of ticks that took other than one period are left out of the fits (RUST_LOG=info counts them per motion)"
            );
        }
        Ok(trace)
    }

    /// Moves to `pose` in joint space at up to `speed` rad/s, then holds
    /// until every DoF is within `tolerance` rad. A DoF that stops short
    /// (its distance to the pose shrinking by less than half the tolerance
    /// over [`STALL_S`]) or is still short after `timeout_s` is
    /// [`ExploreError::Blocked`]: the robot is left where it stopped.
    pub fn move_to(&mut self, pose: &[f64], speed: f64, tolerance: f64, timeout_s: f64) -> Result<(), ExploreError> {
        if pose.len() != self.dofs {
            return Err(ExploreError::Config(format!("a pose of {} values for {} DoFs", pose.len(), self.dofs)));
        }
        let deadline = self.elapsed_s + timeout_s;
        // The worst distance to the pose when it last shrank by half the tolerance, and when.
        let mut progress: Option<(f64, f64)> = None;
        self.path.clear();
        loop {
            let q = self.rig.positions();
            let apart = |w: &Vec<f64>| w.iter().zip(&q).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
            if self.path.last().is_none_or(|w| apart(w) >= RETRACE_STEP) {
                self.path.push(q.clone());
            }
            let (dof, error) = pose
                .iter()
                .zip(&q)
                .map(|(p, q)| (p - q).abs())
                .enumerate()
                .max_by(|a, b| a.1.total_cmp(&b.1))
                .unwrap_or((0, 0.0));
            if error <= tolerance {
                break;
            }
            match progress {
                Some((last, _)) if error > last - 0.5 * tolerance => {}
                _ => progress = Some((error, self.elapsed_s)),
            }
            let stalled = progress.is_some_and(|(_, since)| self.elapsed_s - since >= STALL_S);
            if stalled || self.elapsed_s >= deadline {
                self.command.fill(0.0);
                return Err(ExploreError::Blocked { dof: self.rig.dof_names()[dof].clone(), short: error });
            }
            for ((c, p), q) in self.command.iter_mut().zip(pose).zip(&q) {
                *c = (POSITION_GAIN * (p - q)).clamp(-speed, speed);
            }
            self.tick()?;
        }
        self.command.fill(0.0);
        Ok(())
    }

    /// Goes back the way the last [`Session::move_to`] came, waypoint by
    /// waypoint, to where it started (within `tolerance`), no DoF ever
    /// turning away from that start. A move that stopped against another
    /// part of the robot took its other DoFs on to their goals while the
    /// blocked one stood; going straight back swings them through other
    /// places than they came by, where limbs can hook (a quadruped's
    /// calves, one across the other). Where the blocked DoF was pushed
    /// back on the way, the way back holds it instead of pressing it into
    /// the obstacle again. A waypoint the robot cannot reach now (a finger
    /// held by its neighbour) is passed over for the next; only the start
    /// must be reached.
    pub fn retrace(&mut self, speed: f64, tolerance: f64, timeout_s: f64) -> Result<(), ExploreError> {
        let path = std::mem::take(&mut self.path);
        let Some((start, way)) = path.split_first() else { return Ok(()) };
        let mut target = self.positions();
        for waypoint in way.iter().rev() {
            let q = self.positions();
            for (((t, &w), &s), &q) in target.iter_mut().zip(waypoint).zip(start).zip(&q) {
                // Nearer the start of the last target and where the DoF is.
                let near = if (q - s).abs() < (*t - s).abs() { q } else { *t };
                *t = w.clamp(near.min(s), near.max(s));
            }
            match self.move_to(&target.clone(), speed, RETRACE_STEP, timeout_s) {
                Ok(()) | Err(ExploreError::Blocked { .. }) => {}
                Err(e) => return Err(e),
            }
        }
        self.move_to(start, speed, tolerance, timeout_s)
    }

    fn ticks(&self, seconds: f64) -> usize {
        (seconds / self.tick_s).round().max(0.0) as usize
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// One DoF moving as commanded up to `stop` (where something blocks
    /// it) and one cell, on a robot clock that runs `periods(k)` periods
    /// during tick `k` (a host that stalls behind a real-time robot).
    struct Stalling {
        k: usize,
        periods: fn(usize) -> u32,
        q: f64,
        stop: f64,
        command: f64,
        time_s: f64,
    }

    const TICK_S: f64 = 0.004;

    impl Robot for Stalling {
        fn dof_names(&self) -> Vec<String> {
            vec!["j".to_owned()]
        }

        fn command_velocities(&mut self, omega_rad_s: &[f64]) -> Result<(), RobotError> {
            self.command = omega_rad_s[0];
            Ok(())
        }

        fn positions(&self) -> Vec<f64> {
            vec![self.q]
        }
    }

    impl SampleSource for Stalling {
        fn tick_s(&self) -> f64 {
            TICK_S
        }

        fn next_tick(&mut self, out: &mut Vec<(Address, Sample)>) -> Result<(), RobotError> {
            let periods = f64::from((self.periods)(self.k));
            self.k += 1;
            self.q = (self.q + self.command * TICK_S * periods).min(self.stop);
            self.time_s += TICK_S * periods;
            out.push((Address(1), Sample::saturating(0, [0; 3], [0, 0, 256], 0, self.k as u8)));
            Ok(())
        }

        fn robot_time_s(&self) -> Option<f64> {
            Some(self.time_s)
        }
    }

    fn traced(periods: fn(usize) -> u32) -> Trace {
        let mut rig = Stalling { k: 0, periods, q: 0.0, stop: f64::INFINITY, command: 0.0, time_s: 0.0 };
        let mut session = Session::with_cells(&mut rig, vec![Address(1)], AccelRange::G2);
        session.hold(0.04).unwrap();
        session.trace(0, 0.2, |t| 0.1 * t).unwrap()
    }

    #[test]
    fn a_move_that_stops_short_is_blocked_within_the_stall_time_and_says_where() {
        let mut rig = Stalling { k: 0, periods: |_| 1, q: 0.0, stop: 0.3, command: 0.0, time_s: 0.0 };
        let mut session = Session::with_cells(&mut rig, vec![Address(1)], AccelRange::G2);
        session.move_to(&[0.25], 0.8, 2e-3, 60.0).expect("a free move arrives");
        let free_s = session.elapsed_s();
        let err = session.move_to(&[0.5], 0.8, 2e-3, 60.0).expect_err("the DoF stops at 0.3");
        let ExploreError::Blocked { dof, short } = err else { panic!("not a blocked move: {err}") };
        assert_eq!(dof, "j");
        assert!((short - 0.2).abs() < 1e-9, "0.2 short, not {short}");
        // It arrived at the stop within a tenth of a second, then made no progress for the stall time.
        let blocked_s = session.elapsed_s() - free_s;
        assert!((STALL_S..STALL_S + 0.2).contains(&blocked_s), "blocked after {blocked_s} s, not the 60 s timeout");
        assert_eq!(session.command, [0.0], "the robot is left commanded still");
    }

    /// Two DoFs; the first cannot pass 0.3 while the second is above 0.5
    /// (a limb behind another), and is pushed back to 0.25 while the
    /// second is between 0.6 and 0.7 (the other limb pressing on it).
    struct Hooked {
        q: [f64; 2],
        command: [f64; 2],
        /// Every position the robot went through.
        visited: Vec<[f64; 2]>,
    }

    impl Robot for Hooked {
        fn dof_names(&self) -> Vec<String> {
            vec!["a".to_owned(), "b".to_owned()]
        }

        fn command_velocities(&mut self, omega_rad_s: &[f64]) -> Result<(), RobotError> {
            self.command = [omega_rad_s[0], omega_rad_s[1]];
            Ok(())
        }

        fn positions(&self) -> Vec<f64> {
            self.q.to_vec()
        }
    }

    impl SampleSource for Hooked {
        fn tick_s(&self) -> f64 {
            TICK_S
        }

        fn next_tick(&mut self, out: &mut Vec<(Address, Sample)>) -> Result<(), RobotError> {
            let mut next = [self.q[0] + self.command[0] * TICK_S, self.q[1] + self.command[1] * TICK_S];
            if next[1] > 0.5 {
                next[0] = next[0].min(0.3);
            }
            if (0.6..0.7).contains(&next[1]) {
                next[0] = next[0].min(0.25);
            }
            self.q = next;
            self.visited.push(next);
            out.push((Address(1), Sample::saturating(0, [0; 3], [0, 0, 256], 0, 0)));
            Ok(())
        }
    }

    #[test]
    fn a_blocked_move_is_retraced_the_way_it_came_without_pressing_on() {
        let start = [0.0, 1.0];
        let mut rig = Hooked { q: start, command: [0.0; 2], visited: Vec::new() };
        let mut session = Session::with_cells(&mut rig, vec![Address(1)], AccelRange::G2);
        let err = session.move_to(&[0.8, 0.6], 0.8, 2e-3, 60.0).expect_err("a stops at 0.25");
        assert!(matches!(err, ExploreError::Blocked { .. }), "not a blocked move: {err}");
        let turn = rig_len(&session);
        session.retrace(0.8, 2e-3, 60.0).expect("the way back is free");
        let q = session.positions();
        assert!(q.iter().zip(start).all(|(q, s)| (q - s).abs() <= 2e-3), "back at {q:?}, not at the start");
        let (out, back) = rig.visited.split_at(turn);
        // Every DoF heads for the start all the way: a, pushed back from
        // 0.3 to 0.25 on the way out, is not pressed towards 0.3 again.
        for d in 0..2 {
            let towards = |w: &[[f64; 2]]| (w[1][d] - w[0][d]) * (start[d] - w[0][d]) >= -1e-9;
            assert!(back.windows(2).all(towards), "DoF {d} turned away from its start on the way back");
        }
        // And it went back near the way it came (a straight line back would
        // bring a to 0 while b is still at 0.85, 0.15 off the way out).
        let off = back
            .iter()
            .map(|p| out.iter().map(|o| (o[0] - p[0]).abs().max((o[1] - p[1]).abs())).fold(f64::INFINITY, f64::min))
            .fold(0.0, f64::max);
        assert!(off < 0.06, "the way back strays {off} from the way out");
    }

    /// Ticks the session's robot has run.
    fn rig_len(session: &Session<'_, Hooked>) -> usize {
        session.rig.visited.len()
    }

    #[test]
    fn samples_around_a_tick_the_robot_clock_ran_on_are_left_out() {
        let regular = traced(|_| 1);
        assert!(regular.accel.iter().all(|a| a.iter().all(|x| x.is_finite())), "a steady clock leaves every sample");
        // The hold takes 10 ticks; trace tick 20 takes five periods.
        let stalled = traced(|k| if k == 30 { 5 } else { 1 });
        let missing: Vec<usize> = (0..stalled.len()).filter(|&k| stalled.accel[k][0].is_nan()).collect();
        let reach = IRREGULAR_REACH_TICKS;
        assert_eq!(missing, (20 - reach..=20 + reach).collect::<Vec<_>>());
        // The feedback shows the robot ran on: the positions are kept.
        assert!((stalled.q[20] - stalled.q[19] - 5.0 * 0.1 * TICK_S).abs() < 1e-12);
    }
}
