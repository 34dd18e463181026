//! The person in the lab during the grasping experiment (sections 5.3
//! and 6.5), as the simulated robot's endpoint hosts them.
//!
//! The experimenter tells the person what to do ([`Order`]); the person
//! acts once per control period, looking at the robot as it is (only the
//! simulator knows where every cell is): guides the arms into a key pose
//! with their hands, puts an object in front of the robot or takes it
//! away, pats the shoulder. They also tell the experimenter what only they
//! can see ([`Note`]): how hard the skin was pressed, where the object is,
//! how close the arms came to the pictured pose, and which cells make up
//! each touch area, named by the IDs the network gave them. None of this
//! is robot or skin data: on a real robot a real person stands there, and
//! the experimenter writes the areas into the host's configuration after
//! touching each area's cells in `skin monitor`.

use std::cell::Cell;

use nalgebra::{Point3, UnitQuaternion};
use skin_protocol::Address;

use super::experiment::{back_extent, intended_pose, object_pose, Setup};
use super::held::{Arm, ObjectTruth};
use super::person::{Guiding, Teacher};
use super::placement::ObjectAt;
use super::stage::Stage;
use super::Placed;
use crate::world::World;
use skin_model::robot::Robot;

/// Longest a person tries to teach one key pose, s.
const TEACH_LIMIT_S: f64 = 60.0;
/// Control periods the person waits, hands away, for the robot to come to
/// rest before judging a taught pose.
const REST_TICKS: u32 = 25;
/// How often teaching is logged, s.
const LOG_EVERY_S: f64 = 2.0;
/// How long a pat lasts, s.
const PAT_S: f64 = 0.3;
/// How deep a pat presses, m.
const PAT_DEPTH_M: f64 = 0.0015;
/// How long the person waits, the object hugged at the chest and the arms
/// still, before letting go of what it stands on, s: the robot has
/// stopped pulling and holds it as it will.
const HUG_WAIT_S: f64 = 1.0;
/// The arms are still while none of their cells has moved this far in
/// [`HUG_WAIT_S`], m: stiller than the controller's own stall test (0.005
/// rad in 1 s, 1.5-2.5 mm at the forearm's cells), so a pull creeping
/// towards the chest is not taken for a hold (at 3 mm the person let a
/// 0.63 kg sphere go mid-pull, under a grip of 3 N).
const STILL_M: f64 = 0.001;

/// What the experimenter asks of the person.
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
pub enum Order {
    /// Teach the key pose of this name by proximity guidance, until the
    /// arms look like the picture or a minute has passed; answered by
    /// [`Note::Taught`] once the robot has come to rest.
    Teach(String),
    /// Put this object in front of the robot where it says, or take the
    /// object away; from then on every period is answered by [`Note::Seen`].
    Place(Option<ObjectAt>),
    /// Pat the top of the right shoulder once.
    Pat,
    /// Name the cells of each touch area; answered by [`Note::Areas`].
    Areas,
}

/// What the person tells the experimenter.
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
pub enum Note {
    /// A key pose was taught.
    Taught {
        /// The key pose.
        pose: String,
        /// Robot time from the order until the robot came to rest, s.
        time_s: f64,
        /// How far each arm's guided cells are from where the person
        /// pictured them (root mean square; right, left), m.
        error_m: [f64; 2],
    },
    /// What the person sees after a control period.
    Seen {
        /// Robot time, s.
        time_s: f64,
        /// The largest force on any one force cell since the object was
        /// placed (or taken away), N.
        max_force_n: f64,
        /// The same of the object's contacts alone: the grip, N.
        grip_force_max_n: f64,
        /// The same of the person's hands alone: pats and guidance, N.
        hand_force_max_n: f64,
        /// The largest force of the object on the robot's bare surface,
        /// N; none where the world has no honest measure of it.
        bare_force_max_n: Option<f64>,
        /// Where the object is and what holds it.
        object: Option<ObjectTruth>,
    },
    /// The host's area file (TOML `[[area]]` tables), cells by network ID.
    Areas(String),
    /// An order the person cannot carry out, and why.
    Refused(String),
}

/// What the person is doing.
enum Act {
    Idle,
    /// Hands guiding the arms towards the picture of `pose`.
    Teaching {
        pose: String,
        teacher: Teacher,
        start_s: f64,
    },
    /// Hands away, waiting `ticks_left` more periods before judging.
    Resting {
        pose: String,
        teacher: Teacher,
        start_s: f64,
        ticks_left: u32,
    },
    /// A hand on the shoulder until `until_s`.
    Patting {
        until_s: f64,
    },
}

/// The person, the objects and what they see.
pub struct Operator {
    robot: Robot,
    setup: Setup,
    stage: Box<dyn Stage>,
    act: Act,
    /// Since the first [`Order::Place`], every period is reported.
    watching: bool,
    /// The person has let go of what the object stands on.
    let_go: bool,
    /// Since when the arms have hugged the object at the chest and held
    /// still, s, and where their cells were then.
    hugged_since: Option<(f64, Vec<Point3<f64>>)>,
    /// The arm of each skin cell.
    arms: Vec<Option<Arm>>,
    /// How far the object reaches behind its centre, m, for the turn it
    /// had when last asked (a blob's extent is a search: asked again only
    /// when the object has turned).
    back: Cell<Option<(UnitQuaternion<f64>, f64)>>,
}

impl Operator {
    /// A person at `robot` (its model, to picture poses) wearing the skin
    /// of `setup`, acting on `stage`: the world's tactile scene, or
    /// MuJoCo's bodies.
    pub fn new(robot: Robot, setup: Setup, stage: Box<dyn Stage>) -> Operator {
        let arms = setup.skin.cells().iter().map(|c| Arm::of_link(&c.link)).collect();
        Operator {
            robot,
            setup,
            stage,
            act: Act::Idle,
            watching: false,
            let_go: false,
            hugged_since: None,
            arms,
            back: Cell::new(None),
        }
    }

    /// Takes an order at a period boundary; `ids` are the cells' network
    /// IDs by skin index. A new order ends what the person was doing.
    pub fn order(&mut self, order: Order, world: &World, ids: &[Address]) -> Option<Note> {
        self.stage.set_hands(Vec::new());
        self.act = Act::Idle;
        match order {
            Order::Teach(pose) => {
                let Some(picture) = intended_pose(&self.robot, &pose) else {
                    return Some(Note::Refused(format!("no key pose \"{pose}\": open, closed or pulled")));
                };
                let arms = self.setup.guided_cells.clone();
                let teacher = Teacher::new(&self.robot, &self.setup.skin, &picture, arms, Guiding::default());
                self.act = Act::Teaching { pose, teacher, start_s: world.time_s() };
                None
            }
            Order::Place(object) => {
                self.back.set(None);
                let offset = self.stage.skin().surface_offset_m;
                self.stage.put(object.map(|ObjectAt { object, placement }| {
                    let pose = object_pose(&object, &placement, offset);
                    (object, pose)
                }));
                self.watching = true;
                self.let_go = false;
                self.hugged_since = None;
                None
            }
            Order::Pat => {
                // Patting to release what the robot carries, the person
                // takes it back first, as from a robot that might drop it.
                if self.let_go {
                    self.stage.take_back();
                }
                self.act = Act::Patting { until_s: world.time_s() + PAT_S };
                None
            }
            Order::Areas => Some(match self.setup.areas.iter().find(|a| a.cells.iter().any(|&u| !ids[u].is_cell())) {
                Some(a) => Note::Refused(format!("cells of \"{}\" have no ID yet: organize the skin first", a.name)),
                None => Note::Areas(self.setup.areas_toml(ids)),
            }),
        }
    }

    /// Acts once, before the world's next period.
    pub fn act(&mut self, world: &World) -> Option<Note> {
        let (t, poses) = (world.time_s(), world.cell_poses());
        let skin = self.stage.skin();
        let offset = skin.surface_offset_m;
        if self.watching && !self.let_go {
            // The robot has hugged it at the chest and held still for a
            // while: the person lets go of what it stood on (whether the
            // arms can carry it is the test). Letting go while the arms
            // still pull (as soon as it presses on the chest) drops it
            // mid-pull.
            self.hugged_since = if self.truth().is_some_and(|o| o.hugged()) {
                let arms: Vec<_> =
                    self.setup.guided_cells.iter().flatten().map(|&u| poses[u] * Point3::origin()).collect();
                match self.hugged_since.take() {
                    Some((since, at)) if at.iter().zip(&arms).all(|(a, b)| (a - b).norm() < STILL_M) => {
                        Some((since, at))
                    }
                    _ => Some((t, arms)),
                }
            } else {
                None
            };
            let waited = self.hugged_since.as_ref().is_some_and(|(since, _)| t - since >= HUG_WAIT_S);
            if waited {
                self.stage.let_go();
                self.let_go = true;
            }
        }
        match std::mem::replace(&mut self.act, Act::Idle) {
            Act::Idle => {}
            Act::Teaching { pose, mut teacher, start_s } => {
                if teacher.satisfied(poses) || t - start_s >= TEACH_LIMIT_S {
                    self.stage.set_hands(Vec::new());
                    self.act = Act::Resting { pose, teacher, start_s, ticks_left: REST_TICKS - 1 };
                } else {
                    let ticks = ((t - start_s) / world.config().tick_s).round() as u64;
                    if ticks.is_multiple_of((LOG_EVERY_S / world.config().tick_s).round() as u64) {
                        tracing::debug!(pose, time_s = t - start_s, error_m = ?teacher.error_m(poses), "teaching");
                    }
                    self.stage.set_hands(teacher.hands(t, poses, offset, &skin.proximity));
                    self.act = Act::Teaching { pose, teacher, start_s };
                }
            }
            Act::Resting { pose, teacher, start_s, ticks_left: 0 } => {
                return Some(Note::Taught { pose, time_s: t - start_s, error_m: teacher.error_m(poses) });
            }
            Act::Resting { pose, teacher, start_s, ticks_left } => {
                self.act = Act::Resting { pose, teacher, start_s, ticks_left: ticks_left - 1 };
            }
            Act::Patting { until_s } if t < until_s => {
                self.stage.set_hands(vec![self.stage.pat(&poses[self.setup.pat_cell], PAT_DEPTH_M)]);
                self.act = Act::Patting { until_s };
            }
            Act::Patting { .. } => self.stage.set_hands(Vec::new()),
        }
        None
    }

    /// What the person sees after a period, once watching.
    pub fn watch(&self, world: &World) -> Option<Note> {
        self.watching.then(|| {
            let look = self.stage.look();
            Note::Seen {
                time_s: world.time_s(),
                max_force_n: look.max_force_n,
                grip_force_max_n: look.grip_force_max_n,
                hand_force_max_n: look.hand_force_max_n,
                bare_force_max_n: look.bare_force_max_n,
                object: self.judge(&look),
            }
        })
    }

    /// The truth about the object now, if there is one.
    fn truth(&self) -> Option<ObjectTruth> {
        self.judge(&self.stage.look())
    }

    fn judge(&self, look: &super::stage::Look) -> Option<ObjectTruth> {
        let offset = self.stage.skin().surface_offset_m;
        look.object.as_ref().map(|p| ObjectTruth {
            resting: look.resting,
            fallen: look.fallen,
            ..ObjectTruth::observe(p, self.back_m(p), offset, &self.arms, &look.contacts)
        })
    }

    fn back_m(&self, placed: &Placed) -> f64 {
        match self.back.get() {
            Some((turn, back_m)) if turn == placed.pose.rotation => back_m,
            _ => {
                let back_m = back_extent(placed);
                self.back.set(Some((placed.pose.rotation, back_m)));
                back_m
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::object::Object;
    use crate::scene::placement::{Placement, OBJECT_GAP_M};
    use skin_model::robot::hrp2;

    #[test]
    fn orders_are_carried_out_at_period_boundaries_and_answered() {
        let robot = hrp2::robot();
        let setup = Setup::new(&robot, 4).unwrap();
        let (mut world, scene) = setup.world(robot.clone(), 4);
        let ids: Vec<Address> = setup.skin.cells().iter().map(|c| c.id).collect();
        let mut op = Operator::new(robot, setup.clone(), Box::new(scene.clone()));
        let mut samples = Vec::new();
        let mut period = |op: &mut Operator, world: &mut World| {
            let note = op.act(world);
            world.step(&mut samples);
            (note, op.watch(world))
        };
        assert_eq!(period(&mut op, &mut world), (None, None), "nothing to report before an object is placed");

        // The areas by the IDs given; cells without one are refused.
        assert_eq!(op.order(Order::Areas, &world, &ids), Some(Note::Areas(setup.areas_toml(&ids))));
        let unassigned = vec![Address::UNASSIGNED; ids.len()];
        assert!(matches!(op.order(Order::Areas, &world, &unassigned), Some(Note::Refused(_))));
        assert!(matches!(op.order(Order::Teach("wave".into()), &world, &ids), Some(Note::Refused(_))));

        // A placed object is seen where it was put; a pat presses for a while.
        let bin = ObjectAt { object: Object::by_name("trash_bin").unwrap(), placement: Placement::default() };
        assert_eq!(op.order(Order::Place(Some(bin)), &world, &ids), None);
        let Some(Note::Seen { object: Some(truth), max_force_n, .. }) = period(&mut op, &mut world).1 else {
            panic!("seen after every period once an object is placed")
        };
        let gap = truth.gap_m;
        assert!((gap - OBJECT_GAP_M).abs() < 1e-9 && max_force_n == 0.0, "{gap} m, {max_force_n} N");
        assert!(!truth.gripped() && !truth.held(), "put down, not held: {truth:?}");
        assert_eq!(op.order(Order::Pat, &world, &ids), None);
        let start = world.time_s();
        while world.time_s() - start < PAT_S {
            period(&mut op, &mut world);
            assert_eq!(scene.get().hands().len(), 1);
        }
        period(&mut op, &mut world);
        assert!(scene.get().hands().is_empty(), "the hand is taken away");
        let Some(Note::Seen { max_force_n, grip_force_max_n, hand_force_max_n, .. }) = period(&mut op, &mut world).1
        else {
            panic!("seen")
        };
        assert!(max_force_n > 0.1, "the pat pressed the shoulder: {max_force_n} N");
        assert_eq!((grip_force_max_n, hand_force_max_n), (0.0, max_force_n), "a pat is no grip");
        assert_eq!(op.order(Order::Place(None), &world, &ids), None);
        assert!(matches!(period(&mut op, &mut world).1, Some(Note::Seen { object: None, .. })));

        // Home is where the robot is: taught once it has rested.
        assert_eq!(op.order(Order::Teach("home".into()), &world, &ids), None);
        let start = world.time_s();
        let taught = loop {
            if let (Some(note), _) = period(&mut op, &mut world) {
                break note;
            }
        };
        let Note::Taught { pose, time_s, error_m } = taught else { panic!("{taught:?}") };
        let rest_s = f64::from(REST_TICKS) * world.config().tick_s;
        assert_eq!(pose, "home");
        assert!((time_s - rest_s).abs() < 1e-9 && (world.time_s() - start - rest_s - 0.004).abs() < 1e-9);
        assert!(error_m.iter().all(|e| *e < 0.01), "{error_m:?}");
    }
}
