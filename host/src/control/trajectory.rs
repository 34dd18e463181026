//! Trajectories between key poses in joint space (section 6.2).
//!
//! The generator drives the current pose towards a desired key pose along a
//! straight line in joint space: the joint with the farthest to go moves at
//! the maximum joint velocity, the others in proportion, and near the goal
//! the speed falls off with a settling time constant so the pose is reached
//! without overshoot. An event is sent when the pose is within the postural
//! accuracy, and another when the robot stops making progress (the tactile
//! reactions, superposed and dominant, hold it back: it touches something).
//! Joint groups (the arms) may be kept together on the way: a group
//! further along its own path than another waits for it.

use serde::{Deserialize, Serialize};

use super::ControlError;

/// How a trajectory moves.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Motion {
    /// Largest joint velocity, rad/s.
    pub max_velocity: f64,
    /// Postural accuracy: reached when every joint is this close, rad.
    pub accuracy: f64,
    /// Stop commanding once reached (else keep holding the pose).
    #[serde(default = "yes")]
    pub stop_at_target: bool,
}

fn yes() -> bool {
    true
}

/// Timing common to all trajectories.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Timing {
    /// Time constant of the final approach, s.
    pub settle_s: f64,
    /// Window over which progress is judged, s.
    pub stall_window_s: f64,
    /// Less progress than this over the window is a stall, rad.
    pub stall_rad: f64,
}

impl Default for Timing {
    fn default() -> Timing {
        Timing { settle_s: 0.25, stall_window_s: 1.0, stall_rad: 0.005 }
    }
}

impl Timing {
    /// Checks every value is positive and within what a robot's key-pose
    /// motion can use (a typo such as `1e300` is refused with its key).
    pub fn check(&self) -> Result<(), ControlError> {
        within("timing.settle_s", self.settle_s, 10.0, "a time in (0, 10] s")?;
        within("timing.stall_window_s", self.stall_window_s, 60.0, "a time in (0, 60] s")?;
        within("timing.stall_rad", self.stall_rad, std::f64::consts::PI, "an angle in (0, pi] rad")
    }
}

/// `Ok` when `0 < v <= max`.
fn within(what: &str, v: f64, max: f64, expected: &'static str) -> Result<(), ControlError> {
    if v > 0.0 && v <= max {
        Ok(())
    } else {
        Err(ControlError::Range { what: what.to_owned(), value: v, expected })
    }
}

impl Motion {
    /// Checks the velocity and accuracy are positive and bounded.
    pub fn check(&self) -> Result<(), ControlError> {
        within("max_velocity", self.max_velocity, 10.0, "a velocity in (0, 10] rad/s")?;
        within("accuracy", self.accuracy, std::f64::consts::PI, "an angle in (0, pi] rad")
    }
}

/// What a trajectory reports.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum TrajectoryEvent {
    /// The key pose is reached within the accuracy.
    Reached,
    /// No progress over the stall window.
    Stalled,
}

/// A trajectory to one key pose.
#[derive(Clone, Debug)]
pub struct Trajectory {
    name: String,
    target: Vec<f64>,
    motion: Motion,
    timing: Timing,
    reached: bool,
    stalled: bool,
    window: Option<(f64, f64)>,
    together: Vec<Vec<usize>>,
    start: Option<Vec<f64>>,
}

/// A group this much further along its path than the one furthest
/// behind (as shares of each group's path at the first step) moves at
/// full speed; [`STOP_AHEAD`] ahead it waits, in between it slows.
const FREE_AHEAD: f64 = 0.05;
const STOP_AHEAD: f64 = 0.15;
/// A group with less than this to go at the first step is not kept
/// with the others (its share of a path so short is noise), rad.
const SHORTEST_PATH_RAD: f64 = 0.05;

impl Trajectory {
    /// A trajectory to `target`, named after its key pose.
    pub fn new(name: &str, target: &[f64], motion: Motion, timing: Timing) -> Result<Trajectory, ControlError> {
        motion.check()?;
        timing.check()?;
        if target.iter().any(|q| !q.is_finite()) {
            return Err(ControlError::BadPose(name.to_owned()));
        }
        Ok(Trajectory {
            name: name.to_owned(),
            target: target.to_vec(),
            motion,
            timing,
            reached: false,
            stalled: false,
            window: None,
            together: Vec::new(),
            start: None,
        })
    }

    /// Keeps the joint `groups` (indices into the pose) together: each
    /// covers its own path from where the first step finds it as fast as
    /// the one furthest behind. Two arms pulling an object, one held back
    /// by its force reaction (it feels the object) and the other not (its
    /// bare surface pushes where no cell feels), otherwise push it across
    /// into the arm that yields. Indices past the pose are left out.
    pub fn together(mut self, groups: Vec<Vec<usize>>) -> Trajectory {
        let dofs = self.target.len();
        self.together = groups.into_iter().map(|g| g.into_iter().filter(|&j| j < dofs).collect()).collect();
        self
    }

    /// Lets every joint go its own pace from now on.
    pub fn apart(&mut self) {
        self.together.clear();
    }

    /// Whether joint groups are kept together.
    pub fn is_together(&self) -> bool {
        !self.together.is_empty()
    }

    /// The key pose's name.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// The key pose.
    pub fn target(&self) -> &[f64] {
        &self.target
    }

    /// Whether the pose has been reached.
    pub fn reached(&self) -> bool {
        self.reached
    }

    /// Writes the joint velocities for `pose` at `time_s` into `out` and
    /// returns an event when the pose is reached or progress stalls.
    pub fn step(
        &mut self,
        pose: &[f64],
        time_s: f64,
        out: &mut [f64],
    ) -> Result<Option<TrajectoryEvent>, ControlError> {
        if pose.len() != self.target.len() || out.len() != self.target.len() {
            return Err(ControlError::Dimension { expected: self.target.len(), got: pose.len().min(out.len()) });
        }
        let far = pose.iter().zip(&self.target).map(|(q, t)| (t - q).abs()).fold(0.0, f64::max);
        let distance = pose.iter().zip(&self.target).map(|(q, t)| (t - q) * (t - q)).sum::<f64>().sqrt();
        let mut event = None;
        if far <= self.motion.accuracy && !self.reached {
            self.reached = true;
            event = Some(TrajectoryEvent::Reached);
        }
        if self.reached && self.motion.stop_at_target {
            out.fill(0.0);
            return Ok(event);
        }
        let scale = if far > 0.0 { (self.motion.max_velocity / far).min(1.0 / self.timing.settle_s) } else { 0.0 };
        for ((o, q), t) in out.iter_mut().zip(pose).zip(&self.target) {
            *o = (t - q) * scale;
        }
        self.keep_together(pose, out);
        if !self.reached {
            event = event.or(self.watch_progress(distance, time_s));
        }
        Ok(event)
    }

    /// Slows each group ahead of the one furthest behind (see [`together`](Self::together)).
    fn keep_together(&mut self, pose: &[f64], out: &mut [f64]) {
        if self.together.len() < 2 {
            return;
        }
        let to_go = |g: &Vec<usize>| g.iter().map(|&j| (self.target[j] - pose[j]).powi(2)).sum::<f64>().sqrt();
        let left: Vec<f64> = self.together.iter().map(to_go).collect();
        let start = self.start.get_or_insert_with(|| left.clone());
        let share: Vec<Option<f64>> =
            left.iter().zip(start.iter()).map(|(l, s)| (*s >= SHORTEST_PATH_RAD).then(|| l / s)).collect();
        let behind = share.iter().flatten().fold(f64::NEG_INFINITY, |m, s| m.max(*s));
        for (g, s) in self.together.iter().zip(&share) {
            let Some(s) = s else { continue };
            let k = ((STOP_AHEAD - (behind - s)) / (STOP_AHEAD - FREE_AHEAD)).clamp(0.0, 1.0);
            for &j in g {
                out[j] *= k;
            }
        }
    }

    /// Progress is judged on the whole pose (Euclidean distance to the
    /// target): some joints may be held back while others still move.
    fn watch_progress(&mut self, distance: f64, time_s: f64) -> Option<TrajectoryEvent> {
        let (start_s, start) = *self.window.get_or_insert((time_s, distance));
        if time_s - start_s < self.timing.stall_window_s {
            return None;
        }
        self.window = Some((time_s, distance));
        let stalled = start - distance < self.timing.stall_rad;
        let new = stalled && !self.stalled;
        self.stalled = stalled;
        new.then_some(TrajectoryEvent::Stalled)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const DT: f64 = 0.004;

    fn run(
        t: &mut Trajectory,
        pose: &mut [f64],
        seconds: f64,
        hold_back: impl Fn(&[f64]) -> Vec<f64>,
    ) -> Vec<(f64, TrajectoryEvent)> {
        let mut events = Vec::new();
        let mut w = vec![0.0; pose.len()];
        for k in 0..(seconds / DT) as usize {
            let time = k as f64 * DT;
            if let Some(e) = t.step(pose, time, &mut w).unwrap() {
                events.push((time, e));
            }
            let back = hold_back(pose);
            for ((q, w), b) in pose.iter_mut().zip(&w).zip(back) {
                *q += (w + b) * DT;
            }
        }
        events
    }

    #[test]
    fn moves_at_max_velocity_in_a_straight_line_and_reaches_once() {
        let motion = Motion { max_velocity: 0.4, accuracy: 0.01, stop_at_target: true };
        let mut t = Trajectory::new("open", &[1.0, -0.5], motion, Timing::default()).unwrap();
        let mut w = [0.0; 2];
        t.step(&[0.0, 0.0], 0.0, &mut w).unwrap();
        assert!((w[0] - 0.4).abs() < 1e-12 && (w[1] + 0.2).abs() < 1e-12, "{w:?}");
        let mut pose = [0.0, 0.0];
        let events = run(&mut t, &mut pose, 6.0, |_| vec![0.0; 2]);
        assert_eq!(events.len(), 1);
        let (time, e) = events[0];
        assert_eq!(e, TrajectoryEvent::Reached);
        // 0.9 rad at full speed, then the settling tail from 0.1 to 0.01 rad.
        let expected = 0.9 / 0.4 + 0.25 * (0.1f64 / 0.01).ln();
        assert!((time - expected).abs() < 0.05, "reached after {time} s, expected {expected}");
        assert!((pose[0] - 1.0).abs() <= 0.01 && (pose[1] + 0.5).abs() <= 0.01);
        t.step(&pose, 7.0, &mut w).unwrap();
        assert_eq!(w, [0.0, 0.0], "stops at the target");
    }

    #[test]
    fn a_trajectory_held_back_stalls_once() {
        let motion = Motion { max_velocity: 0.1, accuracy: 0.01, stop_at_target: true };
        let mut t = Trajectory::new("closed", &[1.0], motion, Timing::default()).unwrap();
        let mut pose = [0.0];
        // Something at 0.3 rad pushes back harder than the trajectory drives.
        let events = run(&mut t, &mut pose, 10.0, |q| vec![if q[0] > 0.3 { -0.4 * (q[0] - 0.3) * 10.0 } else { 0.0 }]);
        assert_eq!(events.iter().map(|e| e.1).collect::<Vec<_>>(), [TrajectoryEvent::Stalled]);
        assert!(pose[0] > 0.3 && pose[0] < 0.35);
    }

    #[test]
    fn a_group_ahead_waits_for_the_one_held_back() {
        let motion = Motion { max_velocity: 0.2, accuracy: 0.01, stop_at_target: true };
        let new = || Trajectory::new("pulled", &[1.0, -1.0], motion, Timing::default()).unwrap();
        // Joint 1 is held where it is for 5 s (an arm yielding to force).
        let held = |t: &mut Trajectory| {
            let mut pose = [0.0, 0.0];
            let mut w = [0.0; 2];
            for k in 0..(5.0 / DT) as usize {
                t.step(&pose, k as f64 * DT, &mut w).unwrap();
                pose[0] += w[0] * DT;
            }
            pose
        };
        let alone = held(&mut new());
        assert!(alone[0] > 0.6, "without groups joint 0 goes on: {alone:?}");
        let mut together = new().together(vec![vec![0], vec![1], vec![7]]);
        let pose = held(&mut together);
        assert!(pose[0] > FREE_AHEAD && pose[0] <= STOP_AHEAD + 1e-9, "waits {STOP_AHEAD} of its way ahead: {pose:?}");
        // Let go, both arrive; apart, joint 0 alone goes on.
        let mut pose = pose;
        run(&mut together, &mut pose, 10.0, |_| vec![0.0; 2]);
        assert!((pose[0] - 1.0).abs() <= 0.01 && (pose[1] + 1.0).abs() <= 0.01, "{pose:?}");
        let mut apart = new().together(vec![vec![0], vec![1]]);
        apart.apart();
        assert!(held(&mut apart)[0] > 0.6);
    }

    #[test]
    fn bad_motions_and_poses_are_refused() {
        let ok = Motion { max_velocity: 0.4, accuracy: 0.01, stop_at_target: true };
        assert!(Trajectory::new("x", &[f64::NAN], ok, Timing::default()).is_err());
        assert!(Trajectory::new("x", &[0.0], Motion { max_velocity: 0.0, ..ok }, Timing::default()).is_err());
        assert!(Trajectory::new("x", &[0.0], Motion { accuracy: -1.0, ..ok }, Timing::default()).is_err());
        let mut t = Trajectory::new("x", &[0.0, 0.0], ok, Timing::default()).unwrap();
        assert!(t.step(&[0.0], 0.0, &mut [0.0]).is_err());
    }
}
