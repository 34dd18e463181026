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

use nalgebra::{Isometry3, Point3, UnitQuaternion};
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
/// stopped pulling and holds it as it will. At 1 s, pulls drawing a
/// cylinder or a box in under 1 mm/s passed for still (`gen4_24`,
/// `gen3_19` of the generated objects: let go mid-pull, taken back).
const HUG_WAIT_S: f64 = 2.0;
/// The arms are still while no cell of the skin has moved this far in
/// [`HUG_WAIT_S`], m: stiller than the controller's own stall test (0.005
/// rad in 1 s, 1.5-2.5 mm at the forearm's cells), so a pull creeping
/// towards the chest is not taken for a hold (at 3 mm the person let a
/// 0.63 kg sphere go mid-pull, under a grip of 3 N).
const STILL_M: f64 = 0.001;
/// A cell this far from where the arms were still has moved while the
/// person lowers their hands, m: the arms give way under the weight, grip
/// again or open, and the person holds the object up again and waits.
/// At 1 cm fewer were held: 5 and 6 against 7 and 8 of 15 objects the
/// arms had not carried (noise seeds 0 and 1).
const MOVING_M: f64 = 0.005;
/// How fast the person lowers their hands from under the object, m/s,
/// and how far before they let go, m: they feel whether the robot carries
/// it rather than let a 40 kg box drop onto the chest.
const EASE_M_PER_S: f64 = 0.02;
const EASE_M: f64 = 0.03;
/// The object came this far down and still rests on their hands, m, or
/// still rests on them once they have lowered them [`EASE_M`] (a box
/// tipping onto them, its centre higher): the robot does not carry it, and
/// the person takes it into their hands where it is. One that sinks slower
/// than their hands lifts off them: the robot carries it, and whether it
/// holds it is the truth's to say once they let go (arms that give way
/// under its weight may let it sink on: the delivery box went down 1.6 cm
/// more in the 3 s hold). At 1 cm the person took back boxes that slid
/// 1-2 cm onto the chest and stayed there, carried (MuJoCo, 100 generated
/// objects, noise seeds 0-3: 341 held at 1 cm, 355 at 2 cm; let go of
/// at the bottom, a box tipped onto their hands fell into a forearm cell).
const FOLLOW_M: f64 = 0.02;

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

/// How far the person has handed the object over to the robot.
enum Handover {
    /// Holding up what it stands on; since when the arms have hugged it
    /// at the chest and held still, s, and where their cells were then.
    Holding { hugged_since: Option<(f64, Vec<Point3<f64>>)> },
    /// Lowering their hands since `since_s`, the object's centre then at
    /// height `z_m`, the skin's cells where they were still.
    Easing { since_s: f64, z_m: f64, cells: Vec<Point3<f64>> },
    /// Let go: the robot carries it.
    LetGo,
    /// It came down with their hands: they take it and carry it away,
    /// and the robot never carries it alone.
    Kept,
}

/// The person, the objects and what they see.
pub struct Operator {
    robot: Robot,
    setup: Setup,
    stage: Box<dyn Stage>,
    act: Act,
    /// Since the first [`Order::Place`], every period is reported.
    watching: bool,
    /// How far the person has handed the object over to the robot.
    handover: Handover,
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
            handover: Handover::Holding { hugged_since: None },
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
                self.handover = Handover::Holding { hugged_since: None };
                None
            }
            Order::Pat => {
                // Patting to release what the robot carries, the person
                // takes it back first, as from a robot that might drop it.
                if !matches!(self.handover, Handover::Holding { .. }) {
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
        if self.watching {
            self.hand_over(t, poses);
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

    /// The person hands the object over: they hold up what it stands on
    /// until the robot has hugged it at the chest and held still for a
    /// while (letting go while the arms still pull, as soon as it presses
    /// on the chest, drops it mid-pull), then lower their hands slowly and
    /// let go, unless the object comes down with them, or still rests on
    /// their hands once lowered: then the robot cannot carry it, and they
    /// take it into their hands where it is and carry it away
    /// (whether the arms can carry it is the test, not the person's nerve).
    fn hand_over(&mut self, t: f64, poses: &[Isometry3<f64>]) {
        let truth = self.truth();
        self.handover = match std::mem::replace(&mut self.handover, Handover::LetGo) {
            Handover::Holding { hugged_since } => {
                // Every cell, the hands' with them: the cells the person
                // guides (links 1-3, shoulder to forearm) moved less than
                // STILL_M in a second while a pull still drew a cylinder
                // in, its joints turning up to 7 mrad/s, the wrists among
                // them (`gen4_24`), and the person let go mid-pull.
                let hugged_since = truth.filter(ObjectTruth::hugged).map(|_| match hugged_since {
                    Some((since, at)) if moved_m(&at, poses) < STILL_M => (since, at),
                    _ => (t, poses.iter().map(|p| p * Point3::origin()).collect()),
                });
                match (hugged_since, truth) {
                    (Some((since, cells)), Some(o)) if t - since >= HUG_WAIT_S => {
                        Handover::Easing { since_s: t, z_m: o.centre_m[2], cells }
                    }
                    (hugged_since, _) => Handover::Holding { hugged_since },
                }
            }
            Handover::Easing { cells, .. } if moved_m(&cells, poses) > MOVING_M => {
                tracing::debug!(time_s = t, "the arms move again: the person holds the object up again");
                self.stage.lower_support(0.0);
                Handover::Holding { hugged_since: None }
            }
            Handover::Easing { since_s, z_m, cells } => {
                let down_m = (EASE_M_PER_S * (t - since_s)).min(EASE_M);
                let bottom = down_m >= EASE_M;
                if truth.is_some_and(|o| o.resting == Some(true) && (bottom || o.centre_m[2] < z_m - FOLLOW_M)) {
                    tracing::debug!(
                        time_s = t,
                        down_m,
                        "the object rests on the person's hands as they lower them: they keep it"
                    );
                    self.stage.carry_away();
                    Handover::Kept
                } else if bottom {
                    self.stage.let_go();
                    Handover::LetGo
                } else {
                    self.stage.lower_support(down_m);
                    Handover::Easing { since_s, z_m, cells }
                }
            }
            kept_or_let_go => kept_or_let_go,
        };
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
            support_n: look.support_n,
            fallen: look.fallen,
            taken_back: matches!(self.handover, Handover::Kept),
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

/// How far the farthest of the skin's cells at `poses` has moved from `at`, m.
fn moved_m(at: &[Point3<f64>], poses: &[Isometry3<f64>]) -> f64 {
    at.iter().zip(poses).map(|(a, p)| (p * Point3::origin() - a).norm()).fold(0.0, f64::max)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::hand::Hand;
    use crate::scene::object::Object;
    use crate::scene::placement::{Placement, OBJECT_GAP_M};
    use crate::scene::stage::Look;
    use crate::scene::{Contact, SkinModel};
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

    /// What the person did to the support, by the test's stage.
    #[derive(Default)]
    struct Handled {
        look: Look,
        lowered_m: f64,
        let_go: bool,
        taken_back: bool,
    }

    /// A stage whose look the test sets, noting what the person does to
    /// the support.
    #[derive(Clone, Default)]
    struct Support(std::rc::Rc<std::cell::RefCell<Handled>>);

    impl Stage for Support {
        fn skin(&self) -> SkinModel {
            SkinModel::default()
        }
        fn pat(&self, cell: &Isometry3<f64>, depth_m: f64) -> Hand {
            Hand::facing(cell, 0.0, -depth_m)
        }
        fn set_hands(&self, _hands: Vec<Hand>) {}
        fn put(&self, object: Option<(Object, Isometry3<f64>)>) {
            self.0.borrow_mut().look.object = object.map(|(object, pose)| Placed { object, pose });
        }
        fn lower_support(&self, down_m: f64) {
            self.0.borrow_mut().lowered_m = down_m;
        }
        fn let_go(&self) {
            self.0.borrow_mut().let_go = true;
        }
        fn take_back(&self) {
            self.0.borrow_mut().taken_back = true;
        }
        fn carry_away(&self) {
            self.take_back();
        }
        fn look(&self) -> Look {
            self.0.borrow().look.clone()
        }
    }

    /// How the object goes as the person lowers their hands.
    #[derive(Clone, Copy, PartialEq)]
    enum Goes {
        /// It stays where the arms hold it.
        Stays,
        /// It sinks 1 mm a tick, off their hands.
        Settles,
        /// It sinks 1 mm a tick, resting on their hands.
        Follows,
        /// It tips onto their hands, resting on them, its centre sinking
        /// 0.03 mm a tick (1.1 cm while they lower theirs 3 cm).
        Tips,
    }

    /// The person hands a hugged object over: they wait for the arms to
    /// hold still, lower their hands, and let go; or, when it comes down
    /// with their hands, take it back and never let go. Also whether the
    /// truth then has it in the person's hands. The right wrist turns at
    /// `wrist_rad_s` from `wrist_from_s` on (an arm still or again moving).
    fn hand_over(goes: Goes, wrist_rad_s: f64, wrist_from_s: f64) -> (f64, bool, bool, bool) {
        let robot = hrp2::robot();
        let setup = Setup::new(&robot, 4).unwrap();
        // Bolted down: a standing robot's sway moves its cells 1 mm.
        let base = crate::world::BaseConfig::rigid();
        let mut world =
            World::new(robot.clone(), setup.skin.clone(), crate::world::WorldConfig { base, ..Default::default() });
        let ids: Vec<Address> = setup.skin.cells().iter().map(|c| c.id).collect();
        let stage = Support::default();
        let mut op = Operator::new(robot, setup.clone(), Box::new(stage.clone()));
        let bin = ObjectAt { object: Object::by_name("trash_bin").unwrap(), placement: Placement::default() };
        op.order(Order::Place(Some(bin)), &world, &ids);
        {
            // Against the chest, both arms pressing it from either side.
            let look = &mut stage.0.borrow_mut().look;
            let placed = look.object.as_mut().unwrap();
            placed.pose.translation.x -= OBJECT_GAP_M;
            let centre = Point3::from(placed.pose.translation.vector);
            let cell_of =
                |arm: Arm| setup.skin.cells().iter().position(|c| Arm::of_link(&c.link) == Some(arm)).unwrap();
            look.contacts = [(Arm::Right, -0.1), (Arm::Left, 0.1)]
                .map(|(arm, y)| Contact {
                    cell: cell_of(arm),
                    point: centre + nalgebra::Vector3::new(0.05, y, 0.0),
                    force_n: 1.0,
                    felt: true,
                })
                .to_vec();
            look.resting = Some(true);
        }
        assert!(op.truth().unwrap().hugged());
        let mut samples = Vec::new();
        let start = world.time_s();
        let mut creep = vec![0.0; world.positions().len()];
        creep[WRIST] = wrist_rad_s;
        while world.time_s() - start < HUG_WAIT_S + EASE_M / EASE_M_PER_S + 0.5 {
            if world.time_s() - start >= wrist_from_s {
                world.command(&creep).unwrap();
            }
            op.act(&world);
            world.step(&mut samples);
            let lowered = stage.0.borrow().lowered_m;
            if world.time_s() - start < HUG_WAIT_S {
                assert_eq!(lowered, 0.0, "the person waits for the arms to hold still");
            }
            if lowered > 0.0 {
                let look = &mut stage.0.borrow_mut().look;
                look.object.as_mut().unwrap().pose.translation.z -= match goes {
                    Goes::Stays => 0.0,
                    Goes::Tips => 0.000_03,
                    Goes::Settles | Goes::Follows => 0.001,
                };
                look.resting = Some(matches!(goes, Goes::Follows | Goes::Tips));
            }
        }
        let in_hands = op.truth().unwrap().taken_back;
        let handled = stage.0.borrow();
        (handled.lowered_m, handled.let_go, handled.taken_back, in_hands)
    }

    #[test]
    fn the_person_lowers_their_hands_and_lets_go_of_what_the_robot_carries() {
        for goes in [Goes::Stays, Goes::Settles] {
            let (lowered, let_go, taken_back, in_hands) = hand_over(goes, 0.0, 0.0);
            assert!(lowered > EASE_M * 0.9, "lowered by {lowered} m before letting go");
            assert!(let_go && !taken_back && !in_hands);
        }
    }

    #[test]
    fn the_person_keeps_what_comes_down_with_their_hands() {
        let (lowered, let_go, taken_back, in_hands) = hand_over(Goes::Follows, 0.0, 0.0);
        assert!(lowered > 0.0 && lowered < EASE_M / 2.0, "stopped lowering at {lowered} m");
        assert!(!let_go && taken_back && in_hands, "the truth has it in their hands");
    }

    #[test]
    fn the_person_keeps_what_still_rests_on_their_hands_once_lowered() {
        let (lowered, let_go, taken_back, in_hands) = hand_over(Goes::Tips, 0.0, 0.0);
        assert!(lowered > EASE_M * 0.9, "lowered only {lowered} m");
        assert!(!let_go && taken_back && in_hands, "let go of a box tipping onto their hands");
    }

    /// The right wrist's pitch (`RARM_JOINT5`), which moves the hand's
    /// cells and none of those the person guides.
    const WRIST: usize = 5;

    #[test]
    fn the_person_waits_while_a_hand_still_moves() {
        let (lowered, let_go, ..) = hand_over(Goes::Stays, 0.05, 0.0);
        assert_eq!((lowered, let_go), (0.0, false), "the person let go while the hand moved");
        let (lowered, let_go, ..) = hand_over(Goes::Stays, 0.0002, 0.0);
        assert!(lowered > EASE_M * 0.9 && let_go, "0.2 mrad/s is still: lowered {lowered} m");
    }

    #[test]
    fn the_person_holds_the_object_up_again_when_the_arms_move_again() {
        let easing = HUG_WAIT_S + 0.5;
        let (lowered, let_go, ..) = hand_over(Goes::Stays, 0.2, easing);
        assert_eq!((lowered, let_go), (0.0, false), "the person lowered {lowered} m and let go of moving arms");
        let (lowered, let_go, ..) = hand_over(Goes::Stays, 0.0002, easing);
        assert!(lowered > EASE_M * 0.9 && let_go, "0.2 mrad/s is still: lowered {lowered} m");
    }
}
