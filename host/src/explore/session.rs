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
/// A DoF is at rest when it moves less than [`REST_MOTION`] (rad or m)
/// over [`REST_TICKS`] ticks: 5 mrad/s at 4 ms ticks, well above
/// encoder noise, well below any commanded motion.
const REST_TICKS: usize = 5;
const REST_MOTION: f64 = 1e-4;

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
        let elapsed = s.elapsed_s;
        let mut s = Session::with_cells(s.rig, cells, range);
        s.elapsed_s = elapsed;
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
        Ok(trace)
    }

    /// Moves to `pose` in joint space at up to `speed` rad/s, then holds
    /// until every DoF is within `tolerance` rad (or `timeout_s` passes).
    pub fn move_to(&mut self, pose: &[f64], speed: f64, tolerance: f64, timeout_s: f64) -> Result<(), ExploreError> {
        if pose.len() != self.dofs {
            return Err(ExploreError::Config(format!("a pose of {} values for {} DoFs", pose.len(), self.dofs)));
        }
        let deadline = self.elapsed_s + timeout_s;
        loop {
            let q = self.rig.positions();
            let error = pose.iter().zip(&q).map(|(p, q)| (p - q).abs()).fold(0.0, f64::max);
            if error <= tolerance {
                break;
            }
            if self.elapsed_s >= deadline {
                let worst =
                    pose.iter().zip(&q).map(|(p, q)| (p - q).abs()).enumerate().max_by(|a, b| a.1.total_cmp(&b.1));
                let dof = worst.map_or(0, |(d, _)| d);
                return Err(ExploreError::Stuck(self.rig.dof_names()[dof].clone()));
            }
            for ((c, p), q) in self.command.iter_mut().zip(pose).zip(&q) {
                *c = (POSITION_GAIN * (p - q)).clamp(-speed, speed);
            }
            self.tick()?;
        }
        self.command.fill(0.0);
        Ok(())
    }

    fn ticks(&self, seconds: f64) -> usize {
        (seconds / self.tick_s).round().max(0.0) as usize
    }
}
