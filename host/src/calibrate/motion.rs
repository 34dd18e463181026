//! One excitation's record turned into every cell's lever equations.
//!
//! The skin's samples and the joint feedback reach the host by different
//! paths, so a sample may belong to a slightly earlier or later moment of
//! the motion than the feedback beside it: in the simulator the
//! accelerometer sees a tick's mean acceleration, half a tick before the
//! feedback's; on a real robot bus and filter latencies add to that. A
//! half-tick error alone biases levers by millimetres, so the delay is
//! found first, on the cells that show the motion best, by the residual of
//! their fit, and the motion is then read at that delay for every cell.

use nalgebra::{Isometry3, Vector3};
use skin_model::robot::kinematics::{self, BodyState, DofMotion};
use skin_model::robot::Robot as Model;
use skin_protocol::message::G0;
use skin_protocol::sample::ACCEL_MAX;

use super::lever::{Lever, LinkMotion};
use super::Candidate;
use crate::explore::session::Trace;

/// Cells the delay is judged on.
const DELAY_CELLS: usize = 8;
/// An excitation whose DoF turned less than this share of its amplitude,
/// or that moved another DoF by more than [`PUSHED_SHARE`] of it, ran into
/// something (a finger into its neighbour). Measured: the LEAP hand's
/// index finger spreading into the middle one stopped at 60 %; free
/// joints reach 100 %, the Panda's gripper slide 89 % (its servo).
const REACHED_SHARE: f64 = 0.75;
const PUSHED_SHARE: f64 = 0.1;
/// Steps of the delay search, ticks.
const DELAY_STEP_TICKS: f64 = 0.25;

/// One excitation of interface DoF `dof`, the others held (each read as
/// it moved: a held joint gives a little under its neighbours' reactions).
pub struct Record<'a> {
    model: &'a Model,
    urdf_dof: &'a [usize],
    trace: &'a Trace,
    lsb_mps2: f64,
    /// Every interface DoF's motion (position, velocity, acceleration per
    /// tick), differenced once for all the delays tried.
    motions: Vec<(Vec<f64>, Vec<f64>, Vec<f64>)>,
}

impl<'a> Record<'a> {
    pub fn new(model: &'a Model, urdf_dof: &'a [usize], trace: &'a Trace, tick_s: f64, lsb_mps2: f64) -> Self {
        let motions = (0..urdf_dof.len()).map(|d| trace.motion_of(d, tick_s)).collect();
        Record { model, urdf_dof, trace, lsb_mps2, motions }
    }

    /// The delay of the samples behind the feedback within `max_ticks`
    /// that leaves the smallest residual on the cells moving most (each on
    /// the body its still fit prefers).
    pub fn delay_ticks(&self, cells: &[Vec<Candidate>], max_ticks: f64) -> f64 {
        let mut spread: Vec<(f64, usize)> = (0..cells.len())
            .filter(|&u| cells[u].first().is_some_and(|c| c.gravity.is_some()))
            .map(|u| {
                let (mut sum, mut sq, mut n) = (Vector3::zeros(), 0.0, 0.0);
                for k in 0..self.trace.len() {
                    if let Some(s) = self.sample(k, u, cells.len()) {
                        sum += s;
                        sq += s.norm_squared();
                        n += 1.0;
                    }
                }
                let var = if n > 1.0 { sq / n - (sum / n).norm_squared() } else { 0.0 };
                (var, u)
            })
            .collect();
        spread.sort_by(|a, b| b.0.total_cmp(&a.0));
        let chosen: Vec<(usize, Candidate)> = spread
            .iter()
            .take(DELAY_CELLS)
            .map(|&(_, u)| (u, Candidate { lever: Lever::position_only(), ..cells[u][0].clone() }))
            .collect();
        let steps = (max_ticks / DELAY_STEP_TICKS).floor() as i64;
        let mut best = (f64::INFINITY, 0.0);
        for i in -steps..=steps {
            let delay = i as f64 * DELAY_STEP_TICKS;
            let mut trial = chosen.clone();
            self.accumulate(delay, cells.len(), trial.iter_mut().map(|(u, c)| (*u, c)));
            let ss: f64 = trial.iter().filter_map(|(_, c)| c.lever.residual_rms()).map(|r| r * r).sum();
            if ss < best.0 {
                best = (ss, delay);
            }
        }
        best.1
    }

    /// Adds every cell's equations on each of its candidate bodies, the
    /// motion read `delay` ticks earlier than the samples' own ticks.
    pub fn add(&self, delay: f64, cells: &mut [Vec<Candidate>]) {
        let n = cells.len();
        let each = cells.iter_mut().enumerate().flat_map(|(u, c)| c.iter_mut().map(move |c| (u, c)));
        self.accumulate(delay, n, each);
    }

    fn accumulate<'c>(&self, delay: f64, cells: usize, targets: impl Iterator<Item = (usize, &'c mut Candidate)>) {
        let mut targets: Vec<(usize, &mut Candidate)> = targets.filter(|(_, c)| c.gravity.is_some()).collect();
        let n = self.model.dofs().len();
        let (mut q, mut qd, mut qdd) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
        let up = Vector3::new(0.0, 0.0, G0);
        let base = BodyState::at_rest(Isometry3::identity());
        let mut states = Vec::new();
        for k in 0..self.trace.len() {
            let at = k as f64 - delay;
            for ((&m, (phi, omega, alpha)), start) in self.urdf_dof.iter().zip(&self.motions).zip(&self.trace.start) {
                q[m] = start + lerp(phi, at, 0.0);
                qd[m] = lerp(omega, at, 0.0);
                qdd[m] = lerp(alpha, at, 0.0);
            }
            kinematics::forward(self.model, &base, DofMotion { q: &q, qd: &qd, qdd: &qdd }, &mut states);
            for (u, c) in targets.iter_mut() {
                let (Some(fit), Some(s)) = (c.gravity, self.sample(k, *u, cells)) else { continue };
                let state = &states[c.body];
                let in_link = fit.frame * (s - fit.offset).component_div(&fit.gain);
                let link = LinkMotion {
                    rotation: *state.pose.rotation.to_rotation_matrix().matrix(),
                    omega: state.omega,
                    alpha: state.alpha,
                    origin_force: state.accel + up,
                };
                c.lever.add(&link, &fit, &(link.rotation * in_link));
            }
        }
        for (_, c) in targets.iter_mut() {
            c.lever.finish_excitation();
        }
    }

    /// Cell `u`'s reading at tick `k`, m/s^2, unless missing or on a rail.
    fn sample(&self, k: usize, u: usize, cells: usize) -> Option<Vector3<f64>> {
        let rail = (f64::from(ACCEL_MAX) - 0.5) * self.lsb_mps2;
        let s = Vector3::from(self.trace.accel[k * cells + u]).cast::<f64>();
        s.iter().all(|x| x.is_finite() && x.abs() < rail).then_some(s)
    }
}

/// Why the excitation of DoF `dof` by `amplitude` is not the motion that
/// was planned, if it is not: the DoF fell short of the amplitude, or
/// another DoF was shoved. Such a record is left out whole: the impact
/// jolts the cells (readings on the rail, spikes between two joint
/// readings) in ways no joint feedback shows, and a fit through it puts
/// cells centimetres off with confidence.
pub fn departure(trace: &Trace, dof: usize, amplitude: f64, names: &[String]) -> Option<String> {
    let reached = trace.q.iter().map(|q| (q - trace.q0) / amplitude).fold(0.0, f64::max);
    if reached < REACHED_SHARE {
        return Some(format!("it stopped at {:.0} % of its {:.3} amplitude", reached * 100.0, amplitude));
    }
    let dofs = trace.start.len();
    let (pushed, by) = (0..dofs)
        .filter(|&d| d != dof)
        .map(|d| {
            let moved = trace.positions.iter().skip(d).step_by(dofs).map(|q| (q - trace.start[d]).abs());
            (d, moved.fold(0.0, f64::max))
        })
        .fold((dof, 0.0), |best, m| if m.1 > best.1 { m } else { best });
    (by > PUSHED_SHARE * amplitude.abs()).then(|| format!("it moved {} by {by:.3}", names[pushed]))
}

/// `values` read at the fractional index `at`; before the start, `before`;
/// past the end, the last value.
fn lerp(values: &[f64], at: f64, before: f64) -> f64 {
    let value = |i: i64| match values.last() {
        Some(&last) if i >= 0 => values.get(i as usize).copied().unwrap_or(last),
        _ => before,
    };
    let i = at.floor();
    let f = at - i;
    value(i as i64) * (1.0 - f) + value(i as i64 + 1) * f
}

#[cfg(test)]
mod tests {
    use super::*;

    /// DoF 0 traced along `q0`, DoF 1 along `q1`, from rest at zero.
    fn trace(q0: &[f64], q1: &[f64]) -> Trace {
        Trace {
            accel: Vec::new(),
            q0: 0.0,
            q: q0.to_vec(),
            start: vec![0.0, 0.0],
            positions: q0.iter().zip(q1).flat_map(|(&a, &b)| [a, b]).collect(),
            saturated: Vec::new(),
        }
    }

    #[test]
    fn an_excitation_is_the_planned_motion_only_if_it_reached_its_amplitude_and_shoved_nothing() {
        let names = ["a".to_owned(), "b".to_owned()];
        let free = trace(&[0.0, 0.2, 0.5, 0.2, 0.0], &[0.0, 0.001, 0.002, 0.001, 0.0]);
        assert_eq!(departure(&free, 0, 0.5, &names), None);
        // Stopped against something at 0.3 of 0.5.
        let stopped = trace(&[0.0, 0.2, 0.3, 0.3, 0.0], &[0.0; 5]);
        assert!(departure(&stopped, 0, 0.5, &names).is_some_and(|why| why.contains("60 %")));
        // Went the other way than planned: that reaches nothing.
        assert!(departure(&free, 0, -0.5, &names).is_some());
        // Reached, but pushed b by 0.15 on the way.
        let shoving = trace(&[0.0, 0.2, 0.5, 0.2, 0.0], &[0.0, 0.05, 0.15, 0.1, 0.0]);
        assert!(departure(&shoving, 0, 0.5, &names).is_some_and(|why| why.contains("moved b by 0.150")));
    }
}
