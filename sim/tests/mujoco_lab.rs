//! The grasping experiment's lab in MuJoCo: an object put down stands on
//! the person's tray (a box with rounded edges too), falls to the floor
//! when they let go and stays in their hands when they take it back, a pat is felt by the patted cell
//! alone (through MuJoCo's contacts on its cover plate), as a light touch,
//! not pain, and the cells see the person and objects, not the robot.

use nalgebra::Isometry3;
use skin_model::robot::hrp2;
use skin_protocol::Sample;
use skin_sim::mujoco::experiment_world;
use skin_sim::scene::experiment::{object_pose, Setup};
use skin_sim::scene::force::Calibration;
use skin_sim::scene::object::Object;
use skin_sim::scene::placement::Placement;
use skin_sim::scene::stage::{Stage, TAKE_AWAY_M, TAKE_AWAY_M_PER_S};
use skin_sim::world::World;

/// Steps `ticks` control periods; the samples of the last.
fn run(world: &mut World, ticks: usize) -> Vec<(skin_protocol::Address, Sample)> {
    let mut out = Vec::new();
    for _ in 0..ticks {
        out.clear();
        world.step(&mut out);
    }
    out
}

/// Drives the joints towards `target` for `ticks` control periods, no
/// faster than `max` rad/s each; the samples of the last.
fn drive(world: &mut World, target: &[f64], max: f64, ticks: usize) -> Vec<(skin_protocol::Address, Sample)> {
    let mut out = Vec::new();
    for _ in 0..ticks {
        let command: Vec<f64> =
            world.positions().iter().zip(target).map(|(q, p)| (2.0 * (p - q)).clamp(-max, max)).collect();
        world.command(&command).unwrap();
        out = run(world, 1);
    }
    out
}

/// Asserts that the object `name` of `weight_n` stands on the tray where
/// and as turned as `pose` put it, the tray bearing its weight; its pose.
fn stands_on_the_tray(stage: &dyn Stage, name: &str, pose: &Isometry3<f64>, weight_n: f64) -> Isometry3<f64> {
    let look = stage.look();
    let stood = look.object.expect("the object is there").pose;
    assert!((stood.translation.vector - pose.translation.vector).norm() < 0.002, "{name} stands where put: {stood}");
    assert!(stood.rotation.angle_to(&pose.rotation) < 0.01, "{name} upright, as turned: {stood}");
    assert_eq!((look.resting, look.fallen), (Some(true), false), "{name} on the tray");
    let carried = look.support_n.expect("MuJoCo tells the support's force");
    assert!((carried - weight_n).abs() < 0.05 * weight_n, "the tray bears {name}: {carried} N of {weight_n} N");
    stood
}

#[test]
fn an_object_stands_on_the_tray_and_falls_when_the_person_lets_go() {
    let setup = Setup::new(&hrp2::robot(), 1).unwrap();
    let (mut world, stage) = experiment_world(None, &setup, 1).unwrap();
    run(&mut world, 25);
    assert_eq!(stage.look().object, None, "nothing put down yet");
    let bin = Object::by_name("trash_bin").unwrap();
    let weight = bin.mass_kg * 9.81;
    let pose = object_pose(&bin, &Placement { yaw_rad: 0.2, ..Placement::default() }, stage.skin().surface_offset_m);
    stage.put(Some((bin, pose)));
    run(&mut world, 250);
    let stood = stands_on_the_tray(&stage, "the bin", &pose, weight);
    let look = stage.look();
    assert!(look.contacts.is_empty(), "the robot at home does not touch it");
    assert_eq!(look.bare_force_max_n, Some(0.0));

    // Lowered, the tray takes the object down with it.
    stage.lower_support(0.02);
    run(&mut world, 250);
    let look = stage.look();
    let lowered = look.object.expect("the object is there").pose.translation;
    assert!((lowered.z - (stood.translation.z - 0.02)).abs() < 0.002, "2 cm lower: {lowered}");
    assert_eq!((look.resting, look.fallen), (Some(true), false), "still on the tray");

    stage.let_go();
    run(&mut world, 250);
    let look = stage.look();
    let fell = look.object.expect("the object is there").pose;
    assert!(fell.translation.z < -0.5, "on the floor 1 m below the chest: {fell}");
    assert_eq!((look.resting, look.fallen), (Some(true), true));
    let carried = look.support_n.expect("MuJoCo tells the support's force");
    assert!((carried - weight).abs() < 0.05 * weight, "the floor bears its weight: {carried} N of {weight} N");
    stage.put(None);
    run(&mut world, 1);
    assert_eq!(stage.look().object, None, "taken away");
}

/// A box with rounded edges is built rounded (a convex mesh): it stands
/// flat and still on the tray as a sharp box does, its weight borne, and
/// the next box put down replaces it and its mesh.
#[test]
fn rounded_boxes_stand_flat_on_the_tray_one_after_another() {
    let setup = Setup::new(&hrp2::robot(), 2).unwrap();
    let (mut world, stage) = experiment_world(None, &setup, 2).unwrap();
    for (name, yaw_rad) in [("moving_box", 0.3), ("delivery_box", -0.2)] {
        let bx = Object::by_name(name).unwrap();
        let weight = bx.mass_kg * 9.81;
        let pose = object_pose(&bx, &Placement { yaw_rad, ..Placement::default() }, stage.skin().surface_offset_m);
        stage.put(Some((bx, pose)));
        run(&mut world, 500);
        stands_on_the_tray(&stage, name, &pose, weight);
    }
}

/// A trash bin put down, then let go of: falling, 0.1 s later. The stage
/// and its world, and the bin's height then, m.
fn falling_bin() -> (World, impl Stage, f64) {
    let setup = Setup::new(&hrp2::robot(), 3).unwrap();
    let (mut world, stage) = experiment_world(None, &setup, 3).unwrap();
    let bin = Object::by_name("trash_bin").unwrap();
    let pose = object_pose(&bin, &Placement::default(), stage.skin().surface_offset_m);
    stage.put(Some((bin, pose)));
    run(&mut world, 50);
    stage.let_go();
    run(&mut world, 25);
    let falling = height(&stage);
    assert!(falling < pose.translation.z - 0.01, "it falls once let go: {falling}");
    (world, stage, falling)
}

/// The height of the object on `stage`, m.
fn height(stage: &impl Stage) -> f64 {
    stage.look().object.expect("the object is there").pose.translation.z
}

/// Patting to release what the robot carries, the person first takes it
/// into their hands: a falling object stops where they took it.
#[test]
fn an_object_taken_back_stays_where_the_person_took_it() {
    let (mut world, stage, falling) = falling_bin();
    stage.take_back();
    run(&mut world, 250);
    let look = stage.look();
    let held = height(&stage);
    assert!((held - falling).abs() < 0.02, "in the person's hands near where taken: {held} (taken at {falling})");
    assert_eq!((look.resting, look.fallen), (Some(false), false), "on nothing but the person's hands");
}

/// An object the robot does not carry, the person takes and carries away,
/// down out of the arms.
#[test]
fn an_object_taken_back_is_carried_away_down_and_held_there() {
    let (mut world, stage, falling) = falling_bin();
    stage.carry_away();
    let period_s = world.config().tick_s;
    let periods = |s: f64| (s / period_s).round() as usize;
    run(&mut world, periods(1.0));
    let carried = falling - height(&stage);
    assert!((carried - TAKE_AWAY_M_PER_S).abs() < 0.02, "carried down at their pace: {carried} m in 1 s");
    run(&mut world, periods(TAKE_AWAY_M / TAKE_AWAY_M_PER_S));
    let look = stage.look();
    let carried = falling - height(&stage);
    assert!((carried - TAKE_AWAY_M).abs() < 0.02, "held {TAKE_AWAY_M} m below where taken: {carried} m");
    assert_eq!((look.resting, look.fallen), (Some(false), false), "on nothing but the person's hands");
}

#[test]
fn a_pat_is_felt_by_the_patted_cell_alone() {
    let setup = Setup::new(&hrp2::robot(), 2).unwrap();
    let (mut world, stage) = experiment_world(None, &setup, 2).unwrap();
    let quiet = run(&mut world, 25);
    assert!(quiet.iter().all(|(_, s)| s.force().iter().all(|f| *f < 20)), "nothing touches the skin");
    stage.put(None);
    let pat = stage.pat(&world.cell_poses()[setup.pat_cell], 0.0015);
    stage.set_hands(vec![pat]);
    let out = run(&mut world, 50);
    let id = setup.skin.cells()[setup.pat_cell].id;
    let felt = out.iter().find(|(a, _)| *a == id).unwrap().1.force_norm();
    let pain = Calibration::default().force(0.45);
    assert!(felt[0] > 0.04 && felt[0] < 0.45, "a light touch on the first force cell: {felt:?}");
    let others = out.iter().filter(|(a, s)| *a != id && s.force().iter().any(|f| *f > 20)).count();
    assert_eq!(others, 0, "no other cell is pressed");
    let look = stage.look();
    assert!(look.hand_force_max_n > 0.1 && look.max_force_n < pain, "{look:?}");
    assert_eq!(look.grip_force_max_n, 0.0, "a pat is no grip");
    stage.set_hands(Vec::new());
    let after = run(&mut world, 25);
    let left = after.iter().find(|(a, _)| *a == id).unwrap().1.force_norm();
    assert!(left.iter().all(|f| *f < 0.02), "the hand is gone: {left:?}");
}

/// The exploration's step (0.2 rad in 0.2 s, a raised-cosine velocity)
/// on the shoulder, which carries the whole arm: the joint controller
/// feeds the inertia forward, so the arm stops where commanded instead of
/// running 13 mrad past it and ringing through the still window the
/// exploration reads next (measured without the inertia term: 13.3 mrad;
/// with it: 2.7 mrad).
#[test]
fn the_shoulder_stops_where_the_step_ends() {
    let setup = Setup::new(&hrp2::robot(), 0).unwrap();
    let (mut world, _stage) = experiment_world(None, &setup, 0).unwrap();
    run(&mut world, 50);
    let shoulder = hrp2::robot().dofs().iter().position(|d| d.name == "LARM_JOINT0").unwrap();
    let (tick, step, move_s) = (0.004, 0.2, 0.2);
    let start = world.positions()[shoulder];
    let ticks = (move_s / tick) as usize;
    let mut out = Vec::new();
    let mut past: f64 = 0.0;
    for k in 0..ticks + 100 {
        let t = (k as f64 + 0.5) * tick;
        let mut command = vec![0.0; world.positions().len()];
        if k < ticks {
            command[shoulder] = step / move_s * (1.0 - (std::f64::consts::TAU * t / move_s).cos());
        }
        world.command(&command).unwrap();
        out.clear();
        world.step(&mut out);
        if k + 1 >= ticks {
            past = past.max((world.positions()[shoulder] - start - step).abs());
        }
    }
    assert!(past < 0.005, "{:.1} mrad off the step's end", past * 1e3);
}

/// In the pulled pose the forearms' cells face the chest a few centimetres
/// off; in the lab they see the person and objects, not the robot's own
/// body (as in the built-in world): seeing it, they evaded it, and the
/// person could not teach that pose (the arms ended 41 cm from it).
#[test]
fn in_the_pulled_pose_no_cell_sees_the_robot_s_own_body() {
    let robot = hrp2::robot();
    let setup = Setup::new(&robot, 5).unwrap();
    let (mut world, _stage) = experiment_world(None, &setup, 5).unwrap();
    let pulled = skin_sim::scene::experiment::intended_pose(&robot, "pulled").unwrap();
    let out = drive(&mut world, &pulled, 1.0, 1000);
    let off = world.positions().iter().zip(&pulled).map(|(q, p)| (q - p).abs()).fold(0.0, f64::max);
    assert!(off < 0.02, "the arms reach the pulled pose: {off} rad off");
    let seeing: Vec<_> = out.iter().filter(|(_, s)| s.proximity_norm() > 0.01).collect();
    assert!(seeing.is_empty(), "cells reading proximity with nothing but the robot near: {seeing:?}");
}

/// A cell's cover is one plate over its three force cells: a press at its
/// centre, between them, is felt by all three alike (with a pad per force
/// cell it fell between the pads, felt by none).
#[test]
fn a_press_between_the_force_cells_is_shared_by_all_three() {
    let setup = Setup::new(&hrp2::robot(), 2).unwrap();
    let (mut world, stage) = experiment_world(None, &setup, 2).unwrap();
    run(&mut world, 25);
    let cell = world.cell_poses()[setup.pat_cell];
    stage.set_hands(vec![skin_sim::scene::hand::Hand::facing(&cell, stage.skin().surface_offset_m, -0.004)]);
    let out = run(&mut world, 50);
    let id = setup.skin.cells()[setup.pat_cell].id;
    let felt = out.iter().find(|(a, _)| *a == id).unwrap().1.force_norm();
    let (low, high) = felt.iter().fold((f32::MAX, 0.0f32), |(l, h), f| (l.min(*f), h.max(*f)));
    assert!(low > 0.04 && high < 1.3 * low, "the three force cells alike: {felt:?}");
}

/// The arms drag an object put down between them back over the person's
/// hands, past where the hands first held it: the hands go along under it
/// (as the built-in scene's support is under an object wherever it
/// slides), so it still stands on them, upright, at the chest. A tray left
/// where the object was put down let it tip off its back edge and fall
/// between the arms (this ball fell to the floor).
#[test]
fn an_object_the_arms_drag_back_stays_on_the_person_s_hands() {
    let robot = hrp2::robot();
    let setup = Setup::new(&robot, 4).unwrap();
    let (mut world, stage) = experiment_world(None, &setup, 4).unwrap();
    let closed = skin_sim::scene::experiment::intended_pose(&robot, "closed").unwrap();
    let pulled = skin_sim::scene::experiment::intended_pose(&robot, "pulled").unwrap();
    drive(&mut world, &closed, 0.3, 2000);
    let ball = skin_sim::scene::object_file::parse(
        "name = \"ball\"\nshape = { sphere = { radius = 0.07 } }\nmass_kg = 0.2\n\
         stiffness_n_per_m = 1500\nreflectance = 0.7\nfriction = 0.4\n",
    )
    .unwrap()
    .object;
    let forward = Placement { offset_m: nalgebra::Vector3::new(0.10, 0.0, 0.0), yaw_rad: 0.0 };
    let pose = object_pose(&ball, &forward, stage.skin().surface_offset_m);
    stage.put(Some((ball, pose)));
    // 40% of the way to the pulled pose (further, the forearms wedge the
    // ball against the chest and lift it).
    let part_way: Vec<f64> = closed.iter().zip(&pulled).map(|(c, p)| c + 0.4 * (p - c)).collect();
    drive(&mut world, &part_way, 0.3, 2000);
    let look = stage.look();
    let now = look.object.expect("the object is there").pose.translation.vector;
    let start = pose.translation.vector;
    assert!(start.x - now.x > 0.7 * 0.07, "dragged back past the hands' first back edge: {start} to {now}");
    assert_eq!((look.resting, look.fallen), (Some(true), false), "on the person's hands at {now}");
    assert!((now.z - start.z).abs() < 0.02, "upright on them: {start} to {now}");
}

/// A small box resting on the cover plate of the cell that faces most
/// nearly up (on top of a shoulder) presses it with its weight, and the
/// plate's foam feels that weight. Its contact points' depth times the
/// foam's stiffness read 1.42 N of its 2.84 N: MuJoCo weighs a contact's
/// depth by the contact's own mass and impedance, not the object's.
#[test]
fn a_weight_on_a_cell_is_felt_as_its_weight() {
    let setup = Setup::new(&hrp2::robot(), 4).unwrap();
    let (mut world, stage) = experiment_world(None, &setup, 4).unwrap();
    run(&mut world, 25);
    let weight = Object {
        name: "weight".into(),
        shape: skin_sim::scene::shape::Shape::Box { half: nalgebra::Vector3::new(0.008, 0.008, 0.01), round_m: 0.001 },
        mass_kg: 0.3,
        stiffness_n_per_m: 3000.0,
        reflectance: 0.7,
        friction: 0.5,
    };
    let facing_up = |u: &usize| (world.cell_poses()[*u].rotation * nalgebra::Vector3::z()).z;
    let top = (0..setup.skin.cells().len()).max_by(|a, b| facing_up(a).total_cmp(&facing_up(b))).unwrap();
    let cell = world.cell_poses()[top];
    let tilt = facing_up(&top);
    assert!(tilt > 0.9, "a cell faces up: {tilt}");
    let above = stage.skin().surface_offset_m + 0.0105;
    let pose = nalgebra::Isometry3::from_parts((cell * nalgebra::Point3::new(0.0, 0.0, above)).into(), cell.rotation);
    stage.put(Some((weight, pose)));
    run(&mut world, 1);
    stage.let_go();
    run(&mut world, 250);
    let look = stage.look();
    assert_eq!((look.resting, look.fallen), (Some(false), false), "on the robot alone: {look:?}");
    let on_plate: f64 = look.contacts.iter().filter(|c| c.felt && c.cell == top).map(|c| c.force_n).sum();
    // Its weight along the plate's normal (the plate is tilted a little).
    let g = 0.3 * 9.81 * tilt;
    assert!((on_plate - g).abs() < 0.1 * g, "the plate feels {on_plate} N of the box's {g} N");
}
