//! One control period: events, grasp, equation (14) and trajectory.
//!
//! Samples and cell events are taken as they arrive ([`Controller::receive`],
//! O(1) each); [`Controller::step`] then runs the grasp state machine on
//! the period's level changes, applies the entry directive of a new state
//! at once (so pain is evaded in the very period it is felt), sums the
//! tactile reactions and the trajectory, and limits the result. The cost of
//! a step grows with the number of touched cells, not with the skin.

use skin_protocol::message::TactileEvent;
use skin_protocol::{Address, Sample};
use tracing::{debug, info};

use super::areas::{AreaKind, Areas};
use super::cells::CellIndex;
use super::events::{Events, Modality, TouchEvent};
use super::grasp::{Grasp, State, Transition};
use super::params::Params;
use super::reaction::{Group, Reactions, Stimulus};
use super::teach::{Guidance, KeyPoses};
use super::trajectory::{Trajectory, TrajectoryEvent};
use super::{ControlError, MotorMap};

/// What a cell sent.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Input {
    /// A sensor sample.
    Sample(Sample),
    /// A tactile event the cell detected itself.
    Event(TactileEvent),
}

/// What drives the robot.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mode {
    /// Kinesthetic guidance: every cell reacts with the guidance gains.
    Guide(Guidance),
    /// The grasp state machine.
    Grasp,
}

/// The whole tactile controller of one robot.
#[derive(Clone, Debug)]
pub struct Controller {
    index: CellIndex,
    areas: Areas,
    params: Params,
    events: Events,
    reactions: Reactions,
    grasp: Grasp,
    poses: KeyPoses,
    mode: Mode,
    trajectory: Option<Trajectory>,
    trajectory_event: Option<TrajectoryEvent>,
    pending: Vec<TouchEvent>,
    period_events: Vec<TouchEvent>,
    transitions: Vec<Transition>,
    command: Vec<f64>,
    scratch: Vec<f64>,
    last_time_s: Option<f64>,
    unknown_cells: u64,
    /// The joints each contact area moves (each joint to the area that
    /// moves it most), found from the map at the first grasp step.
    arms: Option<Vec<Vec<usize>>>,
}

impl Controller {
    /// A controller for the cells of `index` (the map's rows) in `areas`,
    /// for `dofs` DoFs, starting in proximity guidance.
    pub fn new(index: CellIndex, areas: Areas, dofs: usize, params: Params) -> Result<Controller, ControlError> {
        params.check()?;
        let events = Events::new(&areas, &params.levels)?;
        let mut reactions = Reactions::new(dofs, areas.groups(), vec![params.guide.proximity; areas.len()])?;
        reactions.set_smoothing(params.smoothing_s)?;
        Ok(Controller {
            grasp: Grasp::new(params.transitions),
            index,
            areas,
            events,
            reactions,
            params,
            poses: KeyPoses::new(),
            mode: Mode::Guide(Guidance::Proximity),
            trajectory: None,
            trajectory_event: None,
            pending: Vec::new(),
            period_events: Vec::new(),
            transitions: Vec::new(),
            command: vec![0.0; dofs],
            scratch: vec![0.0; dofs],
            last_time_s: None,
            unknown_cells: 0,
            arms: None,
        })
    }

    /// Drives the robot by touch; any trajectory is dropped.
    pub fn guide(&mut self, guidance: Guidance) {
        self.mode = Mode::Guide(guidance);
        self.trajectory = None;
        let gains = guidance.gains(&self.params.guide);
        for area in self.areas.ids() {
            self.reactions.set_group(Group(area.0), gains).expect("checked with the parameters");
        }
    }

    /// Hands the robot to the grasp state machine, at rest; every key pose
    /// a state moves to must be among `poses`.
    pub fn start_grasp(&mut self, poses: KeyPoses) -> Result<(), ControlError> {
        for state in State::ALL {
            if let Some((pose, _)) = state.params(&self.params.state).motion() {
                poses.get(pose)?;
            }
        }
        self.poses = poses;
        self.mode = Mode::Grasp;
        self.grasp = Grasp::new(self.params.transitions);
        self.enter(State::Home)
    }

    /// Takes what a cell sent. Unknown cells are counted and ignored.
    pub fn receive(&mut self, cell: Address, input: &Input) {
        let Some(row) = self.index.row(cell) else {
            self.unknown_cells += 1;
            return;
        };
        match input {
            Input::Sample(s) => {
                self.events.sample(row, cell, s, &mut self.pending);
                self.reactions.stimulate(row, Stimulus::from(s));
            }
            Input::Event(e) => self.events.event(row, cell, e, &mut self.pending),
        }
    }

    /// One control period at `pose` and `time_s`: the joint velocity
    /// command, rad/s.
    pub fn step(&mut self, map: &impl MotorMap, pose: &[f64], time_s: f64) -> Result<&[f64], ControlError> {
        let dofs = self.command.len();
        if pose.len() != dofs || map.dofs() != dofs {
            return Err(ControlError::Dimension {
                expected: dofs,
                got: if pose.len() != dofs { pose.len() } else { map.dofs() },
            });
        }
        if map.cells().len() != self.index.len() {
            return Err(ControlError::Dimension { expected: self.index.len(), got: map.cells().len() });
        }
        std::mem::swap(&mut self.pending, &mut self.period_events);
        self.pending.clear();
        let dt_s = self.last_time_s.map_or(self.params.control_period_s, |t| time_s - t);
        self.last_time_s = Some(time_s);

        if self.mode == Mode::Grasp {
            if self.arms.is_none() {
                let arms = self.arm_joints(map, pose);
                debug!(?arms, "the joints each contact area moves");
                self.arms = Some(arms);
            }
            if let Some(tr) = self.grasp.step(&self.events, self.trajectory_event.take(), time_s) {
                info!(from = ?tr.from, to = ?tr.to, cause = ?tr.cause, time_s, "grasp");
                self.transitions.push(tr);
                self.enter(tr.to)?;
            }
        }
        let tactile = self.reactions.step(map, pose, dt_s);
        self.command.copy_from_slice(tactile);
        if let Some(t) = &mut self.trajectory {
            // Near the chest the arms close on the object each at its own
            // pace: held back there, they looked still to the person, who
            // let go of an object the pull's light grip does not carry.
            if t.is_together()
                && self.events.any(AreaKind::Chest, Modality::Proximity, self.params.transitions.contact_proximity)
            {
                t.apart();
            }
            self.trajectory_event = t.step(pose, time_s, &mut self.scratch)?;
            if let Some(e) = self.trajectory_event.filter(|_| tracing::enabled!(tracing::Level::DEBUG)) {
                // Each area's levels, proximity then force: what the grasp
                // decides on when a pose is reached or the arms stall.
                let touch: Vec<_> = self
                    .areas
                    .ids()
                    .map(|a| {
                        let level = |m| self.events.level(a, m);
                        (self.areas.name(a), level(Modality::Proximity), level(Modality::Force))
                    })
                    .collect();
                debug!(pose = t.name(), event = ?e, time_s, ?touch, q = ?pose, "trajectory");
            }
            for (c, w) in self.command.iter_mut().zip(&self.scratch) {
                *c += w;
            }
        }
        let limit = if self.state() == Some(State::Evade) {
            self.params.evade_max_velocity
        } else {
            self.params.max_joint_velocity
        };
        // Scale the whole vector, so an evasion keeps its direction.
        let peak = self.command.iter().fold(0.0, |m: f64, w| m.max(w.abs()));
        if peak > limit {
            let k = limit / peak;
            self.command.iter_mut().for_each(|w| *w *= k);
        }
        Ok(&self.command)
    }

    fn enter(&mut self, state: State) -> Result<(), ControlError> {
        let directive = state.params(&self.params.state);
        for area in self.areas.ids() {
            self.reactions.set_group(Group(area.0), directive.gains(self.areas.kind(area)))?;
        }
        self.trajectory_event = None;
        self.trajectory = match directive.motion() {
            Some((pose, motion)) => {
                let t = Trajectory::new(pose, self.poses.get(pose)?, motion, directive.timing(self.params.timing))?;
                let arms = if directive.together { self.arms.clone().unwrap_or_default() } else { Vec::new() };
                Some(t.together(arms))
            }
            None => None,
        };
        Ok(())
    }

    /// The joints each contact area moves: each joint goes to the area
    /// whose cells it moves most (summed weights of `map` at `pose`).
    fn arm_joints(&self, map: &impl MotorMap, pose: &[f64]) -> Vec<Vec<usize>> {
        let Some(tile) = map.nearest_tile(pose) else { return Vec::new() };
        let dofs = self.command.len();
        let moved: Vec<Vec<f64>> = self
            .areas
            .of_kind(AreaKind::Contact)
            .map(|area| {
                let mut w = vec![0.0; dofs];
                for row in self.areas.rows(area) {
                    for (m, x) in w.iter_mut().zip(map.weights(tile, row)) {
                        *m += f64::from(x.abs());
                    }
                }
                w
            })
            .collect();
        let mut arms = vec![Vec::new(); moved.len()];
        for j in 0..dofs {
            let most = moved.iter().enumerate().max_by(|a, b| a.1[j].total_cmp(&b.1[j]));
            if let Some((a, _)) = most.filter(|(_, w)| w[j] > 0.0) {
                arms[a].push(j);
            }
        }
        arms
    }

    /// The grasp state, in grasp mode.
    pub fn state(&self) -> Option<State> {
        (self.mode == Mode::Grasp).then(|| self.grasp.state())
    }

    /// The mode.
    pub fn mode(&self) -> Mode {
        self.mode
    }

    /// Level changes handled in the last step.
    pub fn period_events(&self) -> &[TouchEvent] {
        &self.period_events
    }

    /// Every grasp transition so far.
    pub fn transitions(&self) -> &[Transition] {
        &self.transitions
    }

    /// The current trajectory, if any.
    pub fn trajectory(&self) -> Option<&Trajectory> {
        self.trajectory.as_ref()
    }

    /// Current tactile levels.
    pub fn touch(&self) -> &Events {
        &self.events
    }

    /// The touch areas.
    pub fn areas(&self) -> &Areas {
        &self.areas
    }

    /// The cell index (map rows).
    pub fn index(&self) -> &CellIndex {
        &self.index
    }

    /// The reaction controllers.
    pub fn reactions(&self) -> &Reactions {
        &self.reactions
    }

    /// The parameters.
    pub fn params(&self) -> &Params {
        &self.params
    }

    /// Samples from cells the map does not know.
    pub fn unknown_cells(&self) -> u64 {
        self.unknown_cells
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::control::areas::parse_specs;
    use crate::control::dense::DenseMap;

    const DOFS: usize = 4;
    /// Cells 1 pat, 2 left CA, 3 right CA, 4 chest, 5 and 6 non-contact.
    const CELLS: usize = 6;

    fn map() -> DenseMap {
        // Every cell has a distinct evasion direction; the chest moves nothing.
        #[rustfmt::skip]
        let w = vec![
            0.0, 0.0, 1.0, 0.0,
            1.0, 0.0, 0.0, 0.0,
            0.0, -1.0, 0.0, 0.0,
            0.0, 0.0, 0.0, 0.0,
            0.6, 0.0, 0.0, 0.8,
            0.0, 0.6, -0.8, 0.0,
        ];
        DenseMap::new(CELLS, DOFS, vec![(vec![0.0; DOFS], w)])
    }

    fn poses() -> KeyPoses {
        let mut k = KeyPoses::new();
        for (name, q) in [("home", 0.0), ("open", 0.2), ("closed", -0.2), ("pulled", -0.3)] {
            k.record(name, &[q; DOFS]).unwrap();
        }
        k
    }

    fn controller() -> Controller {
        let ix = CellIndex::new(&(1..=CELLS as u16).map(Address).collect::<Vec<_>>()).unwrap();
        let specs = parse_specs(
            "[[area]]\nname='pat'\nkind='pat'\ncells=[1]\n[[area]]\nname='left'\nkind='contact'\ncells=[2]\n\
             [[area]]\nname='right'\nkind='contact'\ncells=[3]\n[[area]]\nname='chest'\nkind='chest'\ncells=[4]",
        )
        .unwrap();
        let areas = Areas::resolve(&specs, &ix, |_| None).unwrap();
        Controller::new(ix, areas, DOFS, Params::default()).unwrap()
    }

    fn sample(proximity: f64, force: f64) -> Input {
        let s =
            Sample::new((proximity * 65535.0).round() as u16, [(force * 4095.0).round() as u16, 0, 0], [0; 3], 0, 0);
        Input::Sample(s.unwrap())
    }

    /// A test rig: a robot that integrates the commands, on a virtual clock.
    struct Rig {
        c: Controller,
        map: DenseMap,
        pose: Vec<f64>,
        time_s: f64,
        command: Vec<f64>,
    }

    impl Rig {
        fn new() -> Rig {
            let mut c = controller();
            c.start_grasp(poses()).unwrap();
            Rig { c, map: map(), pose: vec![0.0; DOFS], time_s: 0.0, command: vec![0.0; DOFS] }
        }

        fn touch(&mut self, cell: u16, proximity: f64, force: f64) {
            self.c.receive(Address(cell), &sample(proximity, force));
        }

        fn step(&mut self) -> State {
            self.time_s += 0.004;
            self.command = self.c.step(&self.map, &self.pose, self.time_s).unwrap().to_vec();
            for (q, w) in self.pose.iter_mut().zip(&self.command) {
                *q += w * 0.004;
            }
            self.c.state().unwrap()
        }

        fn until(&mut self, state: State, seconds: f64) {
            for _ in 0..(seconds / 0.004) as usize {
                if self.step() == state {
                    return;
                }
            }
            panic!("not in {state:?} after {seconds} s but {:?}; {:?}", self.c.state(), self.c.transitions());
        }

        fn pat(&mut self) {
            self.touch(1, 0.0, 0.2);
            self.step();
            self.touch(1, 0.0, 0.0);
            self.step();
        }

        /// Drives the machine into `state` through real inputs only.
        fn reach(state: State) -> Rig {
            let mut r = Rig::new();
            if state == State::Home {
                return r;
            }
            if state == State::Evade {
                r.touch(5, 0.0, 0.5);
                r.until(State::Evade, 0.1);
                return r;
            }
            r.pat();
            if state == State::Cancel || state == State::Cancelled {
                r.pat();
                if state == State::Cancelled {
                    r.until(State::Cancelled, 10.0);
                }
                return r;
            }
            if state == State::Open {
                return r;
            }
            r.until(State::Approach, 10.0);
            if state == State::Approach {
                return r;
            }
            r.touch(2, 0.03, 0.0);
            r.touch(3, 0.03, 0.0);
            r.until(State::Contact, 0.1);
            if state == State::Contact {
                return r;
            }
            r.touch(2, 0.2, 0.0);
            r.touch(3, 0.2, 0.0);
            r.until(State::Load, 0.1);
            if state == State::Load {
                return r;
            }
            r.touch(2, 0.9, 0.15);
            r.touch(3, 0.9, 0.15);
            r.until(State::Pull, 0.1);
            if state == State::Pull {
                return r;
            }
            r.touch(4, 0.9, 0.0);
            r.until(State::Squeeze, 0.1);
            if state == State::Squeeze {
                return r;
            }
            r.touch(4, 0.9, 0.35);
            r.until(State::Hold, 0.1);
            if state == State::Hold {
                return r;
            }
            r.pat();
            if state == State::Release {
                return r;
            }
            r.touch(2, 0.0, 0.0);
            r.touch(3, 0.0, 0.0);
            r.until(State::Done, 0.1);
            r
        }
    }

    #[test]
    fn pain_is_evaded_within_one_period_in_every_state() {
        for state in State::ALL {
            for cell in 1..=CELLS as u16 {
                let mut r = Rig::reach(state);
                assert_eq!(r.c.state(), Some(state));
                r.touch(cell, 0.9, 0.5);
                assert_eq!(r.step(), State::Evade, "pain on cell {cell} in {state:?}");
                assert!(r.c.trajectory().is_none(), "the trajectory is cancelled");
                let w = r.map.weights(0, usize::from(cell - 1));
                // Motion of the cell into its surface: the weights' sense.
                let evasion: f64 = w.iter().zip(&r.command).map(|(w, c)| f64::from(*w) * c).sum();
                let peak = r.command.iter().fold(0.0, |m: f64, c| m.max(c.abs()));
                assert!(peak <= Params::default().evade_max_velocity + 1e-12, "slowly: {peak}");
                if w.iter().any(|w| *w != 0.0) {
                    assert!(evasion > 0.0, "cell {cell} in {state:?} evades: {:?}", r.command);
                }
            }
        }
    }

    #[test]
    fn each_arm_is_the_joints_its_contact_area_moves() {
        let mut r = Rig::new();
        r.step();
        // Left CA (cell 2) moves joint 0, right CA (cell 3) joint 1; the
        // pat and non-contact cells move 2 and 3, no arm's.
        assert_eq!(r.c.arms, Some(vec![vec![0], vec![1]]));
        assert!(Params::default().state.pull.together, "the pull keeps them together");
    }

    #[test]
    fn no_object_ends_cancelled() {
        let mut r = Rig::new();
        r.pat();
        r.until(State::Cancelled, 30.0);
        let path: Vec<State> = r.c.transitions().iter().map(|t| t.to).collect();
        assert_eq!(path, [State::Open, State::Approach, State::Cancel, State::Cancelled]);
    }

    #[test]
    fn tactile_reactions_dominate_the_trajectory() {
        let mut r = Rig::reach(State::Approach);
        // Proximity on the left contact area (row 1, evasion +DoF 0) while the
        // trajectory closes the arms (towards -0.2 on every DoF).
        r.touch(2, 0.015, 0.0);
        r.step();
        let traj_only = r.command[0];
        r.touch(2, 0.019, 0.0);
        r.step();
        assert!(r.command[0] > traj_only, "the reaction adds to DoF 0");
    }

    /// Section 5.3: with proximity guidance the robot starts to react about
    /// 5 cm before a hand touches it (the VCNL4010 model and a hand of the
    /// simulated scene, read through a sample like any other).
    #[cfg(feature = "sim")]
    #[test]
    fn proximity_guidance_reacts_about_5_cm_before_contact() {
        use rand::SeedableRng;
        use skin_sim::scene::{hand::Hand, Scene, SkinModel};
        let mut c = controller();
        c.guide(Guidance::Proximity);
        let m = map();
        let mut scene = Scene::new(SkinModel::default());
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        let cell = nalgebra::Isometry3::identity();
        let offset = scene.skin().surface_offset_m;
        let mut reacted_at = None;
        for k in 0..=200u32 {
            let gap = 0.1 - 0.0005 * f64::from(k);
            scene.set_hands(vec![Hand::facing(&cell, offset, gap)]);
            let time = f64::from(k) * 0.004;
            let sense = scene.sense(time, &[cell])[0];
            let (p, f) = scene.skin().counts(&sense, &mut rng);
            c.receive(Address(2), &Input::Sample(Sample::new(p, f, [0; 3], 0, 0).unwrap()));
            let w = c.step(&m, &[0.0; DOFS], time).unwrap();
            if w[0] > 0.0 && reacted_at.is_none() {
                reacted_at = Some(gap);
            }
        }
        let gap = reacted_at.expect("the robot reacts");
        assert!((gap - 0.05).abs() < 0.003, "reacts {gap} m before contact");
    }

    #[test]
    fn guidance_drives_the_robot_and_poses_are_checked() {
        let mut c = controller();
        let m = map();
        c.guide(Guidance::Force);
        c.receive(Address(2), &sample(0.0, 0.14));
        let w = c.step(&m, &[0.0; DOFS], 0.004).unwrap();
        assert!((w[0] - 0.09).abs() < 1e-3, "{w:?}");
        c.guide(Guidance::Proximity);
        c.receive(Address(2), &sample(0.011, 0.0));
        let w = c.step(&m, &[0.0; DOFS], 0.008).unwrap();
        assert!((w[0] - 0.4 * 0.001).abs() < 1e-4, "reacts at 1 % proximity: {w:?}");
        let mut partial = KeyPoses::new();
        partial.record("open", &[0.0; DOFS]).unwrap();
        assert!(matches!(c.start_grasp(partial), Err(ControlError::MissingPose(_))));
        assert!(c.step(&m, &[0.0; 3], 0.0).is_err());
        c.receive(Address(99), &sample(0.5, 0.5));
        assert_eq!(c.unknown_cells(), 1);
    }
}
