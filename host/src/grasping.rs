//! The grasping experiment (sections 5.3 and 6.5) on an explored robot.
//!
//! After the robot has explored its body (section 4), a person teaches it
//! the key poses by proximity guidance, each key pose becomes a tile of the
//! sensory-motor map, and then the robot grasps objects of Figure 16,
//! launched and released by a pat on the shoulder, with one parameter set.
//! The controller runs on any [`Robot`] + [`SampleSource`] (in `skin demo`
//! and `skin grasp`, the simulated robot reached over UDP through
//! [`crate::remote::Remote`]) and sees only samples and joint positions.
//! The person, the objects and what only they can see are behind the
//! [`Experimenter`]: for `skin demo` and `skin grasp` the simulated person
//! of the robot's endpoint (the program's glue, not this library's), who
//! also names the cells of each touch area by the IDs
//! the host gave them, as an operator writes them into the configuration
//! of a real robot after touching the cells in `skin monitor`.
//!
//! Each grasp is judged by the simulator's truth ([`verdict`]), never by
//! the controller reaching Hold.
//!
//! [`crate::report::traces::write_traces`] writes what each grasp felt (Figure 18) as CSV and SVG.

pub mod verdict;

use std::collections::VecDeque;
use std::time::Instant;

use serde::Serialize;
use skin_protocol::{Address, Sample};
use skin_sim::scene::force::Calibration;
use skin_sim::scene::held::{ObjectTruth, BARE_PAIN_N};
use skin_sim::scene::operator::{Note, Order};
use skin_sim::scene::placement::ObjectAt;
use skin_sim::scene::stage::{TAKE_AWAY_M, TAKE_AWAY_M_PER_S};
use tracing::info;

use crate::control::areas::{parse_specs, AreaId, AreaKind, Areas};
use crate::control::cells::CellIndex;
use crate::control::controller::{Controller, Input};
use crate::control::grasp::{Cause, State};
use crate::control::params::Params;
use crate::control::teach::{Guidance, KeyPoses, KEY_POSES};
use crate::control::trajectory::{Motion, Timing, Trajectory, TrajectoryEvent};
use crate::control::ControlError;
use crate::explore::{ExploreError, SensoryMotorMap};
use crate::robot::{Robot, RobotError, SampleSource};

/// Longest one grasp may take, from the launching pat, s: seven hugs
/// again of a heavy box, each pull creeping 25-30 s before it stalls, took
/// up to 302 s in MuJoCo.
const GRASP_LIMIT_S: f64 = 330.0;
/// How long after the person took the object back the experimenter ends
/// a grasp the controller has not given up, s: the time the person takes
/// to carry it away out of the arms, and a second for the arms to notice
/// it is gone.
const CARRIED_AWAY_S: f64 = TAKE_AWAY_M / TAKE_AWAY_M_PER_S + 1.0;
/// Longest wait for the person to answer an order, robot time, s (a
/// lesson may take a minute).
const ANSWER_LIMIT_S: f64 = 90.0;
/// When the person pats to launch, s after the object is placed.
const LAUNCH_AT_S: f64 = 0.5;
/// How long the robot holds an object before the person pats to release it, s.
const HOLD_S: f64 = 3.0;
/// How long the robot may hold an object the person still holds up before
/// they pat to release it, s, in one hold: they wait 2 s for the arms to
/// be still and take 1.5 s to lower their hands, so at 3 s objects the
/// robot carried were released still on their hands, judged resting.
const LET_GO_LIMIT_S: f64 = 8.0;
/// Trace rows per second (every control period is 250).
const TRACE_HZ: f64 = 50.0;
/// Longest the robot may take to go home between grasps, robot time, s.
const HOME_LIMIT_S: f64 = 30.0;
/// How the robot goes home between grasps: as to the open pose (Table 4),
/// but to within 1 mrad, so every grasp starts from the same pose. Within
/// the open pose's 10 mrad on each joint, a grasp after another met its
/// object otherwise than alone: MuJoCo's `gen4_05` (noise seed 4), held
/// alone, rested on the person's hands after `gen4_04`.
const HOME_MOTION: Motion = Motion { max_velocity: 0.4, accuracy: 0.001, stop_at_target: true };

/// Why the experiment could not run.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum GraspError {
    /// A map tile could not be explored.
    #[error(transparent)]
    Explore(#[from] ExploreError),
    /// The controller refused its parameters, areas or poses.
    #[error(transparent)]
    Control(#[from] ControlError),
    /// The robot refused a command or stopped answering.
    #[error(transparent)]
    Robot(#[from] RobotError),
    /// The robot did not get home between grasps.
    #[error("the robot did not get home before a grasp: {0}")]
    NotHome(String),
    /// The person at the robot could not do what was asked, or is gone.
    #[error("the person at the robot: {0}")]
    Person(String),
    /// An object that is not in Figure 16.
    #[error("no object \"{0}\": choose trash_bin, sponge_rock, moving_box, box_lid, delivery_box, all or none, or give --object-file")]
    UnknownObject(String),
}

/// The experimenter's side: orders to the person at the robot, and what
/// they say.
pub trait Experimenter {
    /// Asks the person to do something, from the next control period on.
    fn order(&mut self, order: Order) -> Result<(), GraspError>;
    /// Appends what the person said since the last call.
    fn heard(&mut self, out: &mut Vec<Note>);
}

/// A taught key pose.
#[derive(Clone, Debug, Serialize)]
pub struct Lesson {
    /// The key pose.
    pub pose: String,
    /// Robot time the person guided, s.
    pub time_s: f64,
    /// How far each arm's cells ended from where the person pictured them
    /// (root mean square; right, left), m.
    pub error_m: [f64; 2],
}

/// What the robot knows after exploring and being taught.
#[derive(Clone, Debug)]
pub struct Taught {
    /// The sensory-motor map, with a tile at every key pose.
    pub map: SensoryMotorMap,
    /// The key poses.
    pub poses: KeyPoses,
    /// How the teaching went.
    pub lessons: Vec<Lesson>,
    /// The touch areas (the host's area file), cells by the host's IDs.
    pub areas_toml: String,
}

/// One transition of the grasp.
#[derive(Clone, Debug, Serialize)]
pub struct Logged {
    /// The state entered.
    pub state: State,
    /// When, s after the launching pat.
    pub time_s: f64,
    /// Why.
    pub cause: Cause,
}

/// When a force first reached its largest, and in which state.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct Peak {
    /// s after the launching pat (before it: negative).
    pub time_s: f64,
    /// The controller's state then.
    pub state: State,
}

/// One row of a grasp's trace.
#[derive(Clone, Debug, Serialize)]
pub struct TraceRow {
    /// s after the launching pat.
    pub time_s: f64,
    /// The grasp state.
    pub state: State,
    /// Joint positions, rad.
    pub joints_rad: Vec<f64>,
    /// Per touch area (right arm, left arm, chest): summed normalized
    /// force readings of its force cells.
    pub force: [f64; 3],
    /// Per touch area (right arm, left arm, chest): highest proximity.
    pub proximity: [f64; 3],
    /// Ground truth: where the object is and what presses on it.
    pub object: Option<ObjectTruth>,
}

/// What the person said they saw during one grasp.
#[derive(Clone, Copy, Debug, Default)]
struct Watched {
    max_force_n: f64,
    grip_force_max_n: f64,
    hand_force_max_n: f64,
    bare_force_max_n: Option<f64>,
    object: Option<ObjectTruth>,
    ever_gripped: bool,
    heard: bool,
}

impl Watched {
    fn hear(&mut self, note: &Note) {
        if let Note::Seen { max_force_n, grip_force_max_n, hand_force_max_n, bare_force_max_n, object, .. } = *note {
            *self = Watched {
                max_force_n,
                grip_force_max_n,
                hand_force_max_n,
                bare_force_max_n,
                object,
                ever_gripped: self.ever_gripped || object.is_some_and(|o| o.gripped()),
                heard: true,
            };
        }
    }

    /// The object stands on the person's hands or tray (resting, not
    /// fallen): the robot does not hold it alone yet.
    fn on_support(&self) -> bool {
        self.object.is_some_and(|o| o.resting == Some(true) && !o.fallen)
    }

    /// The hold phase the verdict judges: the controller `holding`, the
    /// person having let go.
    fn in_hold_phase(&self, holding: bool) -> bool {
        holding && !self.on_support()
    }
}

/// When the person pats to release: once the robot has held the object
/// for [`HOLD_S`] in all after they let go (an arm that lets go pulls
/// again meanwhile), at a moment it holds. Until they let go the robot
/// does not hold it alone (they wait for the arms to stop); a person who
/// has not let go after [`LET_GO_LIMIT_S`] of one hold never will, and
/// it is judged standing on their hands. A grip taken again (an arm lost
/// the object and pulled) starts that wait again, as it starts their
/// handover again: counted over every hold, a grip taken again 5 s in had
/// 3 s left, too short to wait 2 s and lower their hands 1.5 s
/// (`gen3_24`, noise seed 0).
#[derive(Default)]
struct ReleasePat {
    held_s: f64,
    supported_s: f64,
    released: bool,
}

impl ReleasePat {
    /// Whether the pat is due now, after one control period of `tick_s`,
    /// the controller `holding` and the object `on_support` or not; true
    /// once at most.
    fn due(&mut self, holding: bool, on_support: bool, tick_s: f64) -> bool {
        match (holding, on_support) {
            (true, true) => self.supported_s += tick_s,
            (true, false) => self.held_s += tick_s,
            (false, _) => self.supported_s = 0.0,
        }
        let due = holding && (self.held_s >= HOLD_S || self.supported_s >= LET_GO_LIMIT_S);
        due && !std::mem::replace(&mut self.released, true)
    }
}

/// Where an object was put, from the default spot.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct PlacementJson {
    /// Forward, left, up, m.
    pub offset_m: [f64; 3],
    /// Turn about the vertical, rad.
    pub yaw_rad: f64,
}

/// One grasp.
#[derive(Clone, Debug, Serialize)]
pub struct GraspRun {
    /// The object, or "none".
    pub object: String,
    /// Where it was put (none: nothing was).
    pub placement: Option<PlacementJson>,
    /// The truth's verdict: when the person patted to release, the object
    /// was between the arms, against the chest, both arms on it.
    pub succeeded: bool,
    /// Why not (none: held).
    pub reason: Option<verdict::Failure>,
    /// When the failure was decided and what decided it (none: held).
    pub failed: Option<verdict::Failed>,
    /// What the truth said when the person patted to release (none: the
    /// controller never held it that long).
    pub at_release: Option<ObjectTruth>,
    /// How far the object sank in the hold's last second before the
    /// release pat, m (none: not released).
    pub sank_at_release_m: Option<f64>,
    /// It had stopped sinking by the release pat ([`verdict::settled`];
    /// none: not released, or a world where objects never leave their
    /// table): a held object that had not was still sliding down.
    pub settled: Option<bool>,
    /// The state the controller ended in.
    pub controller_state: State,
    /// From the launching pat to the final state, s.
    pub time_s: f64,
    /// Ground truth: the largest force of the object on any one force
    /// cell, N (the grip; the person's pats not included).
    pub grip_force_max_n: f64,
    /// Ground truth: the largest force of the person's hands on any one
    /// force cell, N (the pats that launch and release).
    pub hand_force_max_n: f64,
    /// Ground truth: the largest force on any one force cell, N.
    pub max_cell_force_n: f64,
    /// When that force was reached, and in which state: where a grasp
    /// comes near pain (none: no force cell was touched).
    pub max_cell_force_at: Option<Peak>,
    /// Ground truth: the largest force of the object on one link's bare
    /// surface (its contacts there summed), where no force cell feels it,
    /// N (none: nothing was put in the world).
    pub bare_force_max_n: Option<f64>,
    /// Pain-level touches the controller evaded.
    pub pain_events: usize,
    /// Wall time of the grasp, from going home to the object taken away, s.
    pub wall_s: f64,
    /// Every transition.
    pub state_log: Vec<Logged>,
    /// What the skin felt, at 50 Hz.
    #[serde(skip)]
    pub trace: Vec<TraceRow>,
    /// The robot's names of the DoFs in the trace's joint positions.
    #[serde(skip)]
    pub dof_names: Vec<String>,
}

/// The robot and the person, on the experimenter's clock.
struct Lab<'a, R> {
    robot: &'a mut R,
    person: &'a mut dyn Experimenter,
    samples: Vec<(Address, Sample)>,
    notes: Vec<Note>,
    /// Robot time since the lab was opened, s.
    time_s: f64,
    /// The controller's transitions already told to the robot's viewers.
    told: usize,
}

impl<'a, R: Robot + SampleSource> Lab<'a, R> {
    fn new(robot: &'a mut R, person: &'a mut dyn Experimenter) -> Lab<'a, R> {
        Lab { robot, person, samples: Vec::new(), notes: Vec::new(), time_s: 0.0, told: 0 }
    }

    /// One control period under the held command: its samples, and what
    /// the person said meanwhile.
    fn advance(&mut self) -> Result<(), GraspError> {
        self.samples.clear();
        self.robot.next_tick(&mut self.samples)?;
        self.time_s += self.robot.tick_s();
        self.notes.clear();
        self.person.heard(&mut self.notes);
        Ok(())
    }

    /// One control period: the controller takes what arrived and commands
    /// the robot.
    fn period(&mut self, controller: &mut Controller, map: &SensoryMotorMap) -> Result<(), GraspError> {
        self.advance()?;
        for (cell, s) in &self.samples {
            controller.receive(*cell, &Input::Sample(*s));
        }
        let pose = self.robot.positions();
        let command = controller.step(map, &pose, self.time_s)?;
        self.robot.command_velocities(command)?;
        let transitions = controller.transitions();
        for t in transitions.get(self.told..).unwrap_or_default() {
            self.robot.grasp_entered(t);
        }
        self.told = transitions.len();
        Ok(())
    }

    /// Gives the person `order` and, with the robot held still, waits for
    /// the note `answer` picks out.
    fn ask<T>(&mut self, order: Order, answer: impl Fn(Note) -> Option<T>) -> Result<T, GraspError> {
        self.person.order(order.clone())?;
        self.robot.command_velocities(&vec![0.0; self.robot.dof_count()])?;
        let start = self.time_s;
        while self.time_s - start < ANSWER_LIMIT_S {
            self.advance()?;
            for note in self.notes.drain(..) {
                if let Note::Refused(why) = note {
                    return Err(GraspError::Person(why));
                }
                if let Some(t) = answer(note) {
                    return Ok(t);
                }
            }
        }
        Err(GraspError::Person(format!("no answer to {order:?} within {ANSWER_LIMIT_S} s")))
    }

    /// Drives the robot home along a trajectory, as the controller drives it
    /// to a key pose.
    fn go_home(&mut self, home: &[f64], timing: Timing) -> Result<(), GraspError> {
        // The last milliradian closes slower than the grasp's stall test
        // allows; half of it in a window is progress.
        let timing = Timing { stall_rad: HOME_MOTION.accuracy / 2.0, ..timing };
        let mut way = Trajectory::new("home", home, HOME_MOTION, timing)?;
        let mut command = vec![0.0; home.len()];
        let start = self.time_s;
        loop {
            match way.step(&self.robot.positions(), self.time_s, &mut command)? {
                Some(TrajectoryEvent::Reached) => break,
                Some(TrajectoryEvent::Stalled) => return Err(GraspError::NotHome("it stalled".into())),
                None if self.time_s - start > HOME_LIMIT_S => {
                    return Err(GraspError::NotHome(format!("it took over {HOME_LIMIT_S} s")))
                }
                None => {}
            }
            self.robot.command_velocities(&command)?;
            self.advance()?;
        }
        self.robot.command_velocities(&command)?;
        Ok(())
    }
}

fn controller(areas_toml: &str, map: &SensoryMotorMap, params: &Params) -> Result<Controller, GraspError> {
    let index = CellIndex::new(map.cells())?;
    let areas = Areas::resolve(&parse_specs(areas_toml)?, &index, |_| None)?;
    let dofs = map.tiles().first().map_or(0, |t| t.pose().len());
    Ok(Controller::new(index, areas, dofs, params.clone())?)
}

/// Lets the person name the touch areas and teach the key poses by
/// proximity guidance, starting at home; each key pose becomes a tile of
/// `map`, the robot's explored sensory-motor map.
pub fn learn<R: Robot + SampleSource>(
    robot: &mut R,
    person: &mut dyn Experimenter,
    mut map: SensoryMotorMap,
    params: &Params,
    progress: &mut dyn FnMut(&str),
) -> Result<Taught, GraspError> {
    let mut lab = Lab::new(robot, person);
    let areas_toml = lab.ask(Order::Areas, |n| if let Note::Areas(toml) = n { Some(toml) } else { None })?;
    let mut c = controller(&areas_toml, &map, params)?;
    c.guide(Guidance::Proximity);
    let mut poses = KeyPoses::new();
    poses.record("home", &lab.robot.positions())?;
    let mut lessons = Vec::new();
    for name in KEY_POSES.into_iter().skip(1) {
        progress(&format!("teaching \"{name}\""));
        lab.person.order(Order::Teach(name.to_owned()))?;
        let start = lab.time_s;
        let lesson = 'taught: loop {
            lab.period(&mut c, &map)?;
            for note in lab.notes.drain(..) {
                match note {
                    Note::Taught { pose, time_s, error_m } => break 'taught Lesson { pose, time_s, error_m },
                    Note::Refused(why) => return Err(GraspError::Person(why)),
                    _ => {}
                }
            }
            if lab.time_s - start > ANSWER_LIMIT_S {
                return Err(GraspError::Person(format!("did not finish teaching \"{name}\"")));
            }
        };
        info!(pose = name, time_s = lesson.time_s, error_m = ?lesson.error_m, "taught");
        lessons.push(lesson);
        let pose = lab.robot.positions();
        poses.record(name, &pose)?;
        progress(&format!("exploring a map tile at \"{name}\""));
        map.add_tile(&mut *lab.robot, &pose)?;
    }
    Ok(Taught { map, poses, lessons, areas_toml })
}

/// Brings the robot home, lets the person put `object` (or nothing)
/// between its arms, launch a grasp with a pat, release the object with
/// another once it has been held, and take it away. The verdict is the
/// truth's, as the person saw it when patting to release.
pub fn grasp<R: Robot + SampleSource>(
    robot: &mut R,
    person: &mut dyn Experimenter,
    taught: &Taught,
    object: Option<&ObjectAt>,
    params: &Params,
) -> Result<GraspRun, GraspError> {
    let started = Instant::now();
    let mut lab = Lab::new(robot, person);
    lab.go_home(taught.poses.get("home")?, params.timing)?;
    lab.person.order(Order::Place(object.cloned()))?;
    let mut c = controller(&taught.areas_toml, &taught.map, params)?;
    c.start_grasp(taught.poses.clone())?;
    let areas = traced_areas(c.areas());
    let start = lab.time_s;
    let launch = start + LAUNCH_AT_S;
    let (mut launched, mut ended) = (false, false);
    let mut pat = ReleasePat::default();
    let mut watched = Watched::default();
    let mut peak = None;
    let mut at_release = None;
    // How high the object was through the hold phase's last REST_S.
    let mut path = VecDeque::new();
    let (mut sank_at_release_m, mut settled) = (None, None);
    let mut seen = verdict::Seen::default();
    let pain_n = Calibration::default().force(f64::from(params.levels.force[3]));
    let mut trace = Vec::new();
    let mut next_row = launch;
    let end = loop {
        let t = lab.time_s;
        let holding = c.state() == Some(State::Hold);
        let release = pat.due(holding, watched.on_support(), lab.robot.tick_s());
        if release {
            at_release = Some(watched.object);
            let sank = sank_m(&path, watched.object.as_ref());
            sank_at_release_m = Some(sank);
            // Where objects never leave their table nothing sinks.
            settled = watched.object.filter(|o| o.resting.is_some()).map(|_| verdict::settled(sank));
            let truth = watched.object.map_or(Err(verdict::Why::NoObject), |o| match o.not_held() {
                None => Ok(()),
                Some(why) => Err(verdict::Why::NotHeld(why)),
            });
            seen.at_release = Some((t - launch, truth));
        }
        // The person took the object back into their hands and carries it
        // away: the grasp has failed, and the arms, losing it, give up.
        // Arms still grasping once it is gone are ended with a pat.
        let end = !pat.released
            && seen.taken_back.is_some_and(|at| t - launch - at >= CARRIED_AWAY_S)
            && c.state().is_some_and(State::is_grasping)
            && !std::mem::replace(&mut ended, true);
        if (t >= launch && !std::mem::replace(&mut launched, true)) || release || end {
            lab.person.order(Order::Pat)?;
        }
        lab.period(&mut c, &taught.map)?;
        let max_before_n = watched.max_force_n;
        for note in lab.notes.drain(..) {
            watched.hear(&note);
        }
        let t = lab.time_s;
        watch_for_failure(&mut seen, &watched, &c, (t - launch, pain_n), pat.released);
        if watched.max_force_n > max_before_n {
            peak = c.state().map(|state| Peak { time_s: t - launch, state });
        }
        follow(&mut path, &watched, c.state() == Some(State::Hold), t);
        if t >= next_row {
            next_row += 1.0 / TRACE_HZ;
            trace.push(row(&c, &areas, lab.robot.positions(), t - launch, watched.object));
        }
        let state = c.state().expect("grasp mode");
        if launched && matches!(state, State::Done | State::Cancelled) {
            break state;
        }
        if t - launch > GRASP_LIMIT_S {
            seen.timed_out = Some(t - launch);
            break state;
        }
    };
    lab.person.order(Order::Place(None))?;
    if !watched.heard {
        return Err(GraspError::Person("said nothing of what they saw during the grasp".into()));
    }
    let state_log: Vec<Logged> =
        c.transitions().iter().map(|tr| Logged { state: tr.to, time_s: tr.time_s - launch, cause: tr.cause }).collect();
    let pain_events = state_log.iter().filter(|l| l.cause == Cause::Pain).count();
    seen.cancelled_by = state_log.iter().find(|l| l.state == State::Cancel).map(|l| (l.time_s, l.cause));
    seen.ever_gripped = watched.ever_gripped;
    seen.end_s = lab.time_s - launch;
    let verdict = verdict::judge(&seen);
    let run = GraspRun {
        object: object.map_or("none", |o| &o.object.name).to_owned(),
        placement: object
            .map(|o| PlacementJson { offset_m: o.placement.offset_m.into(), yaw_rad: o.placement.yaw_rad }),
        succeeded: verdict.is_ok(),
        reason: verdict.err().map(|(reason, _)| reason),
        failed: verdict.err().map(|(_, failed)| failed),
        at_release: at_release.flatten(),
        sank_at_release_m,
        settled,
        controller_state: end,
        time_s: state_log.last().map_or(0.0, |l| l.time_s),
        grip_force_max_n: watched.grip_force_max_n,
        hand_force_max_n: watched.hand_force_max_n,
        max_cell_force_n: watched.max_force_n,
        max_cell_force_at: peak,
        bare_force_max_n: watched.bare_force_max_n,
        pain_events,
        wall_s: started.elapsed().as_secs_f64(),
        state_log,
        trace,
        dof_names: lab.robot.dof_names(),
    };
    info!(object = run.object, succeeded = run.succeeded, reason = ?run.reason, controller_state = ?run.controller_state, "grasp");
    Ok(run)
}

/// Notes in `seen` the first pain, the first moment on the floor and the
/// first moment of the hold phase the truth does not call the object held,
/// at `t` (s after the launching pat), pain at `pain_n`. The hold phase is
/// the controller's last stay in Hold before the pat that releases
/// (`released`): an arm that slips makes it pull again, and what the truth
/// saw in a stay that ended so is the grasp settling, not the hold (an
/// object that falls meanwhile is dropped all the same).
fn watch_for_failure(
    seen: &mut verdict::Seen,
    watched: &Watched,
    c: &Controller,
    (t, pain_n): (f64, f64),
    released: bool,
) {
    let state = c.state();
    if seen.pain.is_none() {
        seen.pain = if state == Some(State::Evade) {
            Some((t, verdict::Why::Controller(Cause::Pain)))
        } else if watched.max_force_n >= pain_n {
            Some((t, verdict::Why::CellPain))
        } else if watched.bare_force_max_n.is_some_and(|f| f > BARE_PAIN_N) {
            Some((t, verdict::Why::BarePain))
        } else {
            None
        };
    }
    if seen.dropped.is_none() && watched.object.is_some_and(|o| o.fallen) {
        seen.dropped = Some(t);
    }
    if seen.taken_back.is_none() && watched.object.is_some_and(|o| o.taken_back) {
        seen.taken_back = Some(t);
    }
    let holding = state == Some(State::Hold);
    seen.reached_hold |= holding;
    if !released {
        // The hold phase: the last stay in Hold, from when the person let go.
        if !watched.in_hold_phase(holding) {
            seen.lost_in_hold = None;
        } else if seen.lost_in_hold.is_none() {
            seen.lost_in_hold = watched.object.and_then(|o| o.not_held()).map(|why| (t, why));
        }
    }
}

/// Keeps in `path` how high the object was (robot time `t`, s) over the
/// hold phase's last [`verdict::REST_S`]: the phase as
/// [`watch_for_failure`] has it, while the controller is `holding` and the
/// person has let go.
fn follow(path: &mut VecDeque<(f64, f64)>, watched: &Watched, holding: bool, t: f64) {
    match watched.object {
        Some(o) if watched.in_hold_phase(holding) => path.push_back((t, o.centre_m[2])),
        _ => path.clear(),
    }
    while path.front().is_some_and(|(t0, _)| t - t0 > verdict::REST_S) {
        path.pop_front();
    }
}

/// How far the object is `now` below where it was at the start of `path`,
/// m (0 with no object or no path, or when it rose: arms pressing it
/// about are not its weight pulling it down).
fn sank_m(path: &VecDeque<(f64, f64)>, now: Option<&ObjectTruth>) -> f64 {
    match (path.front(), now) {
        (Some((_, then)), Some(o)) => (then - o.centre_m[2]).max(0.0),
        _ => 0.0,
    }
}

/// The traced areas: right arm, left arm and chest (by kind and order).
fn traced_areas(areas: &Areas) -> [Option<AreaId>; 3] {
    let mut contact = areas.of_kind(AreaKind::Contact);
    [contact.next(), contact.next(), areas.of_kind(AreaKind::Chest).next()]
}

fn row(
    c: &Controller,
    areas: &[Option<AreaId>; 3],
    joints_rad: Vec<f64>,
    time_s: f64,
    object: Option<ObjectTruth>,
) -> TraceRow {
    let mut force = [0.0; 3];
    let mut proximity = [0.0f64; 3];
    for (k, area) in areas.iter().enumerate() {
        for r in area.iter().flat_map(|a| c.areas().rows(*a)) {
            let s = c.reactions().stimulus(r);
            force[k] += s.force.iter().sum::<f64>();
            proximity[k] = proximity[k].max(s.proximity);
        }
    }
    TraceRow { time_s, state: c.state().expect("grasp mode"), joints_rad, force, proximity, object }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_release_pat_waits_for_the_hold_and_gives_each_grip_its_time() {
        let tick = 0.004;
        let run = |pat: &mut ReleasePat, holding: bool, on_support: bool, s: f64| {
            let ticks = (s / tick).round() as u32;
            (0..ticks).filter(|_| pat.due(holding, on_support, tick)).count()
        };
        let mut pat = ReleasePat::default();
        assert_eq!(run(&mut pat, true, false, HOLD_S - 0.1), 0, "held, not long enough");
        assert_eq!(run(&mut pat, false, false, 1.0), 0, "pulling again: no pat");
        assert_eq!(run(&mut pat, true, false, 1.0), 1, "held HOLD_S in all, once");
        assert_eq!(run(&mut pat, true, false, 5.0), 0, "one pat");
        // Still on the person's hands: they wait LET_GO_LIMIT_S of one hold.
        let mut pat = ReleasePat::default();
        assert_eq!(run(&mut pat, true, true, LET_GO_LIMIT_S - 3.0), 0);
        assert_eq!(run(&mut pat, false, true, 0.5), 0, "a grip taken again");
        assert_eq!(run(&mut pat, true, true, LET_GO_LIMIT_S - 0.1), 0, "its wait starts over");
        assert_eq!(run(&mut pat, true, true, 0.2), 1);
    }

    #[test]
    fn how_far_the_object_sank_is_measured_over_the_hold_s_last_second() {
        let at = |z: f64| ObjectTruth {
            gap_m: 0.0,
            centre_m: [0.3, 0.0, z],
            arm_force_n: [1.0, 1.0],
            body_force_n: 2.0,
            between_arms: true,
            from_front: false,
            resting: Some(false),
            support_n: Some(0.0),
            fallen: false,
            taken_back: false,
        };
        let (mut path, mut watched) = (VecDeque::new(), Watched::default());
        // Sinking 3 mm/s through a 3 s hold, sampled every control period.
        let sink = |t: f64| 0.2 - 0.003 * t;
        for k in 0..=750 {
            let t = f64::from(k) * 0.004;
            watched.object = Some(at(sink(t)));
            follow(&mut path, &watched, true, t);
        }
        let now = at(sink(3.004));
        assert!((sank_m(&path, Some(&now)) - 0.003).abs() < 2e-5, "the last second's 3 mm");
        assert!(!verdict::settled(sank_m(&path, Some(&now))));
        assert_eq!(sank_m(&path, Some(&at(0.3))), 0.0, "pushed up, not sinking");
        assert!(path.len() <= 251, "a second's samples kept, no more: {}", path.len());
        // Standing on the person's hands again, or out of Hold: the phase starts over.
        watched.object = Some(ObjectTruth { resting: Some(true), ..now });
        follow(&mut path, &watched, true, 3.008);
        assert_eq!(sank_m(&path, Some(&now)), 0.0);
        watched.object = Some(now);
        follow(&mut path, &watched, true, 3.012);
        follow(&mut path, &watched, false, 3.016);
        assert!(path.is_empty());
        assert_eq!(sank_m(&path, None), 0.0);
    }
}
