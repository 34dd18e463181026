//! The MuJoCo world on small models the tests write: the robot read from
//! MuJoCo's compiled model agrees with MuJoCo's own kinematics, the servos
//! follow velocity commands and hold against gravity, the skin reads
//! gravity at rest and feels a contact, and a floating base is welded.

use std::path::PathBuf;

use nalgebra::{Isometry3, Vector3};
use skin_model::robot::kinematics::{self, BodyState, DofMotion};
use skin_model::robot::{Drive, Robot, Shape, Surface};
use skin_model::skin::Skin;
use skin_sim::mujoco::Model;
use skin_sim::world::{BaseConfig, World, WorldConfig};

/// A three-DoF arm: a yaw on a fixed base, a shoulder whose joint anchor
/// is off its body's origin, an elbow carrying a capsule and a box, a slide
/// joint, and a finger coupled to the slide by an equality (a mimic).
pub const ARM: &str = r#"
<mujoco model="arm">
  <compiler angle="radian"/>
  <option timestep="0.002" integrator="implicitfast"/>
  <worldbody>
    <geom name="floor" type="plane" size="2 2 0.1"/>
    <body name="base" pos="0 0 0.1">
      <geom type="cylinder" size="0.08 0.05"/>
      <body name="turret" pos="0 0 0.1">
        <joint name="yaw" type="hinge" axis="0 0 1" range="-2 2"/>
        <geom type="box" size="0.06 0.06 0.05" mass="2"/>
        <body name="upper" pos="0 0 0.15" euler="0 0 0.5">
          <joint name="shoulder" type="hinge" axis="0 1 0" pos="0 0 -0.05" range="-1.5 1.5"/>
          <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.04" mass="1.5"/>
          <body name="fore" pos="0.3 0 0">
            <joint name="elbow" type="hinge" axis="0 1 0" range="-2 2"/>
            <geom type="box" size="0.12 0.03 0.03" pos="0.12 0 0" mass="0.8"/>
            <body name="slider" pos="0.24 0 0">
              <joint name="reach" type="slide" axis="1 0 0" range="-0.02 0.05"/>
              <geom type="sphere" size="0.03" mass="0.2"/>
              <body name="finger" pos="0.03 0 0">
                <joint name="finger" type="slide" axis="0 1 0" range="-0.05 0.05"/>
                <geom type="box" size="0.01 0.01 0.02" mass="0.05"/>
              </body>
            </body>
          </body>
        </body>
      </body>
    </body>
  </worldbody>
  <equality>
    <joint joint1="finger" joint2="reach" polycoef="0 0.5 0 0 0"/>
  </equality>
</mujoco>
"#;

/// A scratch folder for a test's model files, removed when dropped.
fn scratch() -> tempfile::TempDir {
    tempfile::Builder::new().prefix("skin-mujoco-").tempdir().expect("the temporary folder is writable")
}

/// `text` written to a file named `name` in `dir`.
fn write_model(dir: &tempfile::TempDir, name: &str, text: &str) -> PathBuf {
    let path = dir.path().join(name);
    std::fs::write(&path, text).expect("the temporary folder is writable");
    path
}

/// The model `text` as MuJoCo loads it from a file named `name`.
fn load(name: &str, text: &str) -> Result<Model, skin_sim::mujoco::MujocoError> {
    Model::load(&write_model(&scratch(), name, text))
}

fn rigid(seed: u64) -> WorldConfig {
    WorldConfig { base: BaseConfig::rigid(), seed, ..WorldConfig::default() }
}

/// `model` wearing `cells_per_link` cells on each link (seed 1), rigidly based.
fn skinned(model: Model, cells_per_link: usize) -> World {
    let skin = Skin::per_link(model.robot(), cells_per_link, 1).expect("the model has surfaces");
    model.world(skin, rigid(1)).expect("the model takes the skin")
}

fn arm_world(cells_per_link: usize) -> World {
    let model = load("arm.xml", ARM).expect("MuJoCo loads the arm");
    let skin = Skin::per_link(model.robot(), cells_per_link, 3).expect("the arm has surfaces");
    model.world(skin, rigid(3)).expect("the arm takes the skin")
}

/// The cells' poses by the robot's own kinematics at the world's positions.
fn modelled_poses(robot: &Robot, skin: &Skin, q: &[f64]) -> Vec<Isometry3<f64>> {
    let zero = vec![0.0; q.len()];
    let mut states = Vec::new();
    let motion = DofMotion { q, qd: &zero, qdd: &zero };
    kinematics::forward(robot, &BodyState::at_rest(Isometry3::identity()), motion, &mut states);
    skin.cells().iter().map(|c| states[c.body].pose * c.pose).collect()
}

/// Commands every DoF still for `ticks` control periods; the samples of
/// the last.
fn hold_still(world: &mut World, ticks: usize) -> Vec<(skin_protocol::Address, skin_protocol::Sample)> {
    let still = vec![0.0; world.robot().dofs().len()];
    let mut out = Vec::new();
    for _ in 0..ticks {
        world.command(&still).expect("a command for every DoF");
        out.clear();
        world.step(&mut out);
    }
    out
}

#[test]
fn the_tree_read_from_mujoco_has_the_models_joints_bodies_and_coupling() {
    let model = load("arm.xml", ARM).expect("MuJoCo loads the arm");
    let robot = model.robot();
    let dofs: Vec<&str> = robot.dofs().iter().map(|d| d.name.as_str()).collect();
    assert_eq!(dofs, ["yaw", "shoulder", "elbow", "reach"], "the finger follows the slide");
    let finger = robot.joints().iter().find(|j| j.name == "finger").expect("the finger joint is there");
    assert_eq!(finger.drive, Drive::Mimic { dof: 3, multiplier: 0.5, offset: 0.0 });
    let shoulder = &robot.dofs()[1];
    assert_eq!((shoulder.lower, shoulder.upper), (-1.5, 1.5));
    // The base is welded to the world: its link is on the root body.
    assert_eq!(robot.link("base").expect("the base is a link").body, 0);
    assert_eq!(robot.link("turret").expect("the turret is a link").body, 1);
}

#[test]
fn cells_sit_where_the_robots_kinematics_puts_them_as_mujoco_moves() {
    let mut world = arm_world(3);
    let command = [0.4, -0.3, 0.5, 0.02];
    let mut out = Vec::new();
    for tick in 0..250 {
        world.command(&command).expect("a command of the right length");
        out.clear();
        world.step(&mut out);
        if tick % 50 == 49 {
            let expected = modelled_poses(world.robot(), world.skin(), world.positions());
            for (i, (got, want)) in world.cell_poses().iter().zip(&expected).enumerate() {
                let dp = (got.translation.vector - want.translation.vector).norm();
                let da = got.rotation.angle_to(&want.rotation);
                assert!(dp < 2e-3 && da < 5e-3, "tick {tick}, cell {i}: {dp} m, {da} rad apart");
            }
        }
    }
    // 1 s at the commanded rates, starting from zero.
    let q = world.positions();
    for (d, (got, want)) in q.iter().zip([0.4, -0.3, 0.5, 0.02]).enumerate() {
        assert!((got - want).abs() < 0.05 * want.abs().max(0.1), "DoF {d} at {got}, commanded to {want}");
    }
}

#[test]
fn at_rest_every_accelerometer_reads_one_g_against_gravity() {
    let mut world = arm_world(2);
    let out = hold_still(&mut world, 100);
    let up = Vector3::z();
    for ((_, sample), pose) in out.iter().zip(world.cell_poses()) {
        // Counts of the BMA250 at +-2 g: 256 per g, with its offsets and gains.
        let counts = Vector3::from(sample.accel().map(f64::from)) / 256.0;
        let expected = pose.rotation.inverse() * up;
        assert!((counts - expected).norm() < 0.12, "read {counts:?} g, expected {expected:?}");
    }
}

#[test]
fn a_floating_base_is_held_by_a_weld_and_said_so() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/models/floater.xml");
    let model = Model::load(&path).expect("MuJoCo loads the floater");
    let mut world = skinned(model, 2);
    let engine = world.mujoco_engine().expect("a MuJoCo world");
    assert_eq!(engine.welded(), ["pelvis"]);
    assert!(engine.notes().iter().any(|n| n.contains("\"pelvis\" held by a weld")), "{:?}", engine.notes());
    let start: Vec<_> = world.cell_poses().to_vec();
    hold_still(&mut world, 250);
    for (before, after) in start.iter().zip(world.cell_poses()) {
        let sag = (before.translation.vector - after.translation.vector).norm();
        assert!(sag < 0.01, "the welded base let a cell fall {sag} m in 1 s");
    }
}

/// A leg whose reference pose lies outside its knee's range, with two
/// keyframes: the one named "home" is where its makers stand it.
const LEG: &str = r#"
<mujoco model="leg">
  <compiler angle="radian"/>
  <worldbody>
    <body name="thigh" pos="0 0 1">
      <joint name="hip" axis="0 1 0" range="-1 1"/>
      <geom type="capsule" fromto="0 0 0 0 0 -0.3" size="0.03"/>
      <body name="shin" pos="0 0 -0.3">
        <joint name="knee" axis="0 1 0" range="-2.5 -0.2"/>
        <geom type="capsule" fromto="0 0 0 0 0 -0.3" size="0.025"/>
      </body>
    </body>
  </worldbody>
  <keyframe>
    <key name="crouch" qpos="0.9 -2"/>
    <key name="home" qpos="0.5 -1"/>
  </keyframe>
</mujoco>
"#;

#[test]
fn the_robot_starts_in_the_models_home_keyframe_and_says_so() {
    let model = load("leg.xml", LEG).expect("MuJoCo loads the leg");
    assert_eq!(model.robot().home(), [0.5, -1.0]);
    assert!(model.notes().iter().any(|n| n.contains("keyframe \"home\"")), "{:?}", model.notes());
    let mut world = skinned(model, 2);
    hold_still(&mut world, 250);
    for (q, home) in world.positions().iter().zip([0.5, -1.0]) {
        assert!((q - home).abs() < 1e-3, "held at {q}, not the keyframe's {home}");
    }
    // Without keyframes, the reference pose held inside the joint's range.
    let bare = LEG.replace(&LEG[LEG.find("  <keyframe>").expect("keys")..LEG.find("</mujoco>").expect("end")], "");
    let model = load("bare_leg.xml", &bare).expect("MuJoCo loads the leg");
    assert_eq!(model.robot().home(), [0.0, -0.2]);
    assert!(!model.notes().iter().any(|n| n.contains("keyframe")), "{:?}", model.notes());
}

/// A gripper finger on a slide, closed by its model's own actuator on a
/// tendon (as Menagerie's Panda drives its fingers), which the skin's world
/// does not drive: its home keyframe opens the finger with that actuator's
/// control.
const GRIPPER: &str = r#"
<mujoco model="gripper">
  <worldbody>
    <body name="palm" pos="0 0 1">
      <geom type="box" size="0.04 0.04 0.02"/>
      <body name="finger" pos="0 0 -0.03">
        <joint name="finger" type="slide" axis="1 0 0" range="0 0.04"/>
        <geom type="box" size="0.01 0.01 0.02" mass="0.02"/>
      </body>
    </body>
  </worldbody>
  <tendon>
    <fixed name="grip"><joint joint="finger" coef="1"/></fixed>
  </tendon>
  <actuator>
    <position name="grip" tendon="grip" kp="100" ctrlrange="0 0.04" forcerange="-20 20"/>
  </actuator>
  <keyframe>
    <key name="home" qpos="0.03" ctrl="0.03"/>
  </keyframe>
</mujoco>
"#;

#[test]
fn the_start_keyframe_s_controls_hold_what_the_world_does_not_drive() {
    let model = load("gripper.xml", GRIPPER).expect("MuJoCo loads the gripper");
    assert_eq!(model.robot().home(), [0.03]);
    let mut world = skinned(model, 2);
    hold_still(&mut world, 250);
    // Closed by its own actuator at control 0, the finger would be pulled
    // to 0 against the world's servo.
    let q = world.positions()[0];
    assert!((q - 0.03).abs() < 1e-3, "the finger is at {q} m, not the keyframe's 0.03 m");
}

/// A knee whose servo's control range stops 0.1 rad inside the joint's
/// ends, and no keyframe: the reference pose (0) is no pose the servo
/// can hold, as on Menagerie's Barkour.
const KNEE: &str = r#"
<mujoco model="knee">
  <compiler angle="radian"/>
  <worldbody>
    <body name="thigh" pos="0 0 1">
      <geom type="capsule" fromto="0 0 0 0 0 -0.3" size="0.03"/>
      <body name="shin" pos="0 0 -0.3">
        <joint name="knee" axis="0 1 0" range="0 2.4"/>
        <geom type="capsule" fromto="0 0 0 0 0 -0.3" size="0.025" mass="0.5"/>
      </body>
    </body>
  </worldbody>
  <actuator>
    <position joint="knee" kp="50" ctrlrange="0.1 2.3"/>
  </actuator>
</mujoco>
"#;

#[test]
fn a_joint_moves_within_its_servo_s_control_range_and_starts_inside_it() {
    let model = load("knee.xml", KNEE).expect("MuJoCo loads the knee");
    let knee = &model.robot().dofs()[0];
    assert_eq!((knee.lower, knee.upper), (0.1, 2.3), "the servo's control range, not the joint's");
    assert_eq!(model.robot().home(), [0.1], "the start clamped into it");
    let mut world = skinned(model, 2);
    let notes = world.mujoco_engine().expect("a MuJoCo world").notes().to_vec();
    assert!(notes.iter().any(|n| n.contains("control range") && n.contains("knee [0.100, 2.300]")), "{notes:?}");
    hold_still(&mut world, 250);
    let q = world.positions()[0];
    assert!((q - 0.1).abs() < 2e-3, "the knee holds at {q} rad, not at its start 0.1 rad");
}

/// A knee whose servo (1 N m/rad) is as stiff as its dry friction (1 N m)
/// is strong, as Menagerie's Berkeley Humanoid's knees are: it overcomes
/// the friction only 1 rad from its set point.
const STICKY: &str = r#"
<mujoco model="sticky">
  <compiler angle="radian"/>
  <worldbody>
    <body name="thigh" pos="0 0 0.5">
      <geom type="capsule" fromto="0 0 0 0 0 -0.2" size="0.03"/>
      <body name="shin" pos="0 0 -0.2">
        <joint name="knee" axis="0 1 0" range="0 2" frictionloss="1" armature="0.005"/>
        <geom type="capsule" fromto="0 0 0 0 0 -0.2" size="0.025" mass="0.5"/>
      </body>
    </body>
  </worldbody>
  <actuator>
    <position joint="knee" kp="1" kv="0.1" ctrlrange="0 2"/>
  </actuator>
  <keyframe>
    <key qpos="1" ctrl="1"/>
  </keyframe>
</mujoco>
"#;

#[test]
fn a_servo_weaker_than_its_joint_s_friction_is_named_and_a_step_leaves_the_joint() {
    let model = load("sticky.xml", STICKY).expect("MuJoCo loads the knee");
    let mut world = skinned(model, 2);
    let notes = world.mujoco_engine().expect("a MuJoCo world").notes().to_vec();
    assert!(notes.iter().any(|n| n.contains("dry friction") && n.contains("knee 1.000")), "{notes:?}");
    // The exploration's 0.1 rad step, and time to settle: the knee stays.
    let start = world.positions()[0];
    ticks_until(&mut world, 0.5, 50, |_| false);
    ticks_until(&mut world, 0.0, 250, |_| false);
    let moved = world.positions()[0] - start;
    assert!(moved.abs() < 0.01, "the knee moved {moved} rad under a servo weaker than its friction");
}

#[test]
fn a_servo_stronger_than_its_joint_s_friction_is_not_named() {
    let stiff = STICKY.replace(r#"kp="1" kv="0.1""#, r#"kp="200" kv="4""#);
    let model = load("stiff.xml", &stiff).expect("MuJoCo loads the knee");
    let world = skinned(model, 2);
    let notes = world.mujoco_engine().expect("a MuJoCo world").notes().to_vec();
    assert!(!notes.iter().any(|n| n.contains("dry friction")), "{notes:?}");
}

/// An arm swinging about a vertical axis into a post, its servo force
/// limited (5 N m at 50 N m/rad: 0.1 rad of deflection at full force).
const POST: &str = r#"
<mujoco model="post">
  <compiler angle="radian"/>
  <worldbody>
    <geom name="post" type="box" pos="0.25 0.15 0.3" size="0.03 0.02 0.05"/>
    <body name="base" pos="0 0 0.3">
      <geom type="cylinder" size="0.04 0.02"/>
      <body name="arm">
        <joint name="swing" axis="0 0 1" range="-3 3"/>
        <geom type="capsule" fromto="0.05 0 0 0.3 0 0" size="0.02" mass="1"/>
      </body>
    </body>
  </worldbody>
  <actuator>
    <position joint="swing" kp="50" dampratio="1" forcerange="-5 5"/>
  </actuator>
</mujoco>
"#;

/// Ticks until the swing's position passes `until`, under the velocity
/// `command`, at most `limit`.
fn ticks_until(world: &mut World, command: f64, limit: usize, until: impl Fn(f64) -> bool) -> usize {
    let mut out = Vec::new();
    for k in 0..limit {
        if until(world.positions()[0]) {
            return k;
        }
        world.command(&[command]).expect("a command for the DoF");
        out.clear();
        world.step(&mut out);
    }
    limit
}

#[test]
fn a_joint_held_against_an_obstacle_comes_away_as_soon_as_commanded() {
    let model = load("post.xml", POST).expect("MuJoCo loads the post");
    let mut world = skinned(model, 1);
    // Swung at 1 rad/s into the post (about 0.45 rad) and pressed there
    // for 3 s, as a move that a limb blocks does until it gives up.
    ticks_until(&mut world, 1.0, 750, |_| false);
    let stopped = world.positions()[0];
    assert!((0.3..0.6).contains(&stopped), "the post stops the arm, not at {stopped} rad");
    // Sent back at 0.5 rad/s it leaves the post at once: the servo's goal
    // did not run on past what its force can use (with the 3 s of
    // command wound up it would press on for 4 s).
    let ticks = ticks_until(&mut world, -0.5, 1000, |q| q < stopped - 0.05);
    let seconds = ticks as f64 * world.config().tick_s;
    assert!(seconds < 0.6, "the arm left the post {seconds} s after it was sent back");
}

/// An arm swinging freely about a vertical axis, heavy and its servo
/// stiff with its force limited as a Panda's first joint is (87 N m at
/// 4500 N m/rad: 19 mrad of deflection at full force, less than the set
/// point trails a goal moving at 1.5 rad/s).
const SWING: &str = r#"
<mujoco model="swing">
  <compiler angle="radian"/>
  <worldbody>
    <body name="base" pos="0 0 0.3">
      <geom type="cylinder" size="0.04 0.02"/>
      <body name="arm">
        <joint name="swing" axis="0 0 1" range="-3 3" damping="1" armature="1"/>
        <geom type="capsule" fromto="0.05 0 0 0.3 0 0" size="0.02" mass="1"/>
      </body>
    </body>
  </worldbody>
  <actuator>
    <general joint="swing" gainprm="4500" biasprm="0 -4500 -450" biastype="affine" forcerange="-87 87"/>
  </actuator>
</mujoco>
"#;

#[test]
fn a_stiff_servo_with_little_force_follows_the_commanded_speed() {
    let model = load("swing.xml", SWING).expect("MuJoCo loads the swing");
    let mut world = skinned(model, 1);
    // 1.5 rad/s for 0.5 s, then held: the goal's lead limit must not hold
    // the joint back while the set point trails the goal.
    let start = world.positions()[0];
    ticks_until(&mut world, 1.5, 125, |_| false);
    ticks_until(&mut world, 0.0, 250, |_| false);
    let moved = world.positions()[0] - start;
    assert!((moved - 0.75).abs() < 0.02, "the arm moved {moved} rad of the 0.75 rad commanded");
}

/// The accelerometers under an excitation of the elbow, against the
/// kinematics of the positions MuJoCo reports (differentiated), as the
/// calibration reads them: the dynamic parts agree to the sensor's
/// quantization (MuJoCo's own `accelerometer` reads 1.2 to 1.6 times the
/// motion here, under the servos' implicit damping).
#[test]
fn excited_accelerometers_agree_with_the_kinematics_of_the_reported_positions() {
    use skin_sim::accel::{Bma250Config, G0};
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/models/arm.xml");
    let model = Model::load(&path).expect("MuJoCo loads the arm");
    let skin = Skin::per_link(model.robot(), 3, 5).expect("the arm has surfaces");
    let mut world = model.world(skin, WorldConfig { accel: Bma250Config::ideal(), ..rigid(5) }).expect("the skin fits");
    let tick = world.config().tick_s;
    let (mut qs, mut reads, mut out) = (Vec::new(), Vec::new(), Vec::new());
    for k in 0..500 {
        let w = 0.5 * (std::f64::consts::TAU * k as f64 * tick).sin();
        world.command(&[0.0, 0.0, w]).expect("three DoFs");
        out.clear();
        world.step(&mut out);
        qs.push(world.positions().to_vec());
        // The BMA250 at +-2 g: 256 counts per g.
        reads.push(
            out.iter().map(|(_, s)| Vector3::from(s.accel().map(|c| f64::from(c) / 256.0 * G0))).collect::<Vec<_>>(),
        );
    }
    let (robot, skin) = (world.robot(), world.skin());
    let (mut error, mut dynamic, mut n) = (0.0, 0.0, 0.0);
    let up = Vector3::new(0.0, 0.0, G0);
    for k in 1..qs.len() - 1 {
        let rate = |j: usize| (qs[k + 1][j] - qs[k - 1][j]) / (2.0 * tick);
        let accel = |j: usize| (qs[k + 1][j] - 2.0 * qs[k][j] + qs[k - 1][j]) / (tick * tick);
        let (qd, qdd): (Vec<f64>, Vec<f64>) = (0..3).map(|j| (rate(j), accel(j))).unzip();
        let mut states = Vec::new();
        let motion = DofMotion { q: &qs[k], qd: &qd, qdd: &qdd };
        kinematics::forward(robot, &BodyState::at_rest(Isometry3::identity()), motion, &mut states);
        for (c, read) in skin.cells().iter().zip(&reads[k]) {
            let rotation = (states[c.body].pose * c.pose).rotation.inverse();
            let at = nalgebra::Point3::from(c.pose.translation.vector);
            let expected = rotation * (states[c.body].point_accel(&at) + up);
            error += (expected - read).norm_squared();
            dynamic += (expected - rotation * up).norm_squared();
            n += 1.0;
        }
    }
    let (error, dynamic) = ((error / n).sqrt(), (dynamic / n).sqrt());
    assert!(dynamic > 0.1, "the excitation shows: {dynamic} m/s^2 RMS");
    assert!(error < 0.15 * dynamic, "{error} m/s^2 RMS off a dynamic part of {dynamic} m/s^2 RMS");
}

/// A capsule link (radius 5 cm, straight part 20 cm along z, 1 m up) and a
/// wedge-shaped mesh link half a metre beside it, whose slanted face a box
/// around it would miss by centimetres.
const SURFACES: &str = r#"
<mujoco>
  <asset>
    <mesh name="wedge" vertex="0 0 0  0.2 0 0  0 0.1 0  0 0 0.1  0.2 0 0.1  0 0.1 0.1"/>
  </asset>
  <worldbody>
    <body name="capsule_link" pos="0 0 1">
      <joint name="turn" type="hinge" axis="0 0 1"/>
      <geom type="capsule" size="0.05 0.1"/>
      <body name="mesh_link" pos="0.5 0 0">
        <joint name="tilt" type="hinge" axis="0 1 0"/>
        <geom type="mesh" mesh="wedge"/>
      </body>
    </body>
  </worldbody>
</mujoco>"#;

#[test]
fn cells_lie_on_capsule_caps_and_on_a_meshs_faces_as_mujoco_sees_them() {
    use mujoco_rs::prelude::*;
    let dir = scratch();
    let path = write_model(&dir, "surfaces.xml", SURFACES);
    let model = Model::load(&path).expect("MuJoCo loads the model");
    // The robot written as MJCF (skin model) keeps the capsule and the mesh.
    let again = load("surfaces_again.xml", &model.robot().to_mjcf()).expect("MuJoCo loads it");
    for link in ["capsule_link", "mesh_link"] {
        let shapes = |m: &Model| match &m.robot().link(link).expect("the link").surface {
            Surface::Shapes(shapes) => shapes.iter().map(|(_, s)| s.clone()).collect::<Vec<_>>(),
            other => panic!("{link}: {other:?}"),
        };
        match (&shapes(&model)[..], &shapes(&again)[..]) {
            ([Shape::Capsule { radius, length }], [Shape::Capsule { radius: r, length: l }]) => {
                assert!((radius - 0.05).abs() < 1e-12 && (length - 0.2).abs() < 1e-12, "{radius} {length}");
                assert!((radius - r).abs() < 1e-12 && (length - l).abs() < 1e-12, "{r} {l}");
            }
            ([Shape::Mesh(mesh)], [Shape::Mesh(written)]) => {
                // The wedge: two 0.01 m^2 triangles, sides of 0.02 and
                // 0.01 m^2 and a slanted one of 0.1 x sqrt(0.05) m.
                let area = 2.0 * 0.01 + 0.02 + 0.01 + 0.1 * 0.05f64.sqrt();
                assert!((mesh.area() - area).abs() < 1e-6 && (written.area() - area).abs() < 1e-6, "{}", mesh.area());
            }
            (ours, theirs) => panic!("{link}: {ours:?} written as {theirs:?}"),
        }
    }
    let skin = Skin::per_link(model.robot(), 40, 9).expect("both links have surfaces");
    let world = model.world(skin, rigid(9)).expect("the model takes the skin");
    // MuJoCo's own ray, from 2 cm out along each cell's normal back towards
    // it, on the model as the file has it.
    let mut data = MjData::new(Box::new(MjModel::from_xml(&path).expect("MuJoCo loads the model")));
    data.forward();
    let mut on_caps = 0;
    for (cell, pose) in world.skin().cells().iter().zip(world.cell_poses()) {
        let (p, n) = (pose.translation.vector, pose.rotation * Vector3::z());
        let (_, distance) = data.ray(&(p + n * 0.02).into(), &(-n).into(), None, true, None, None);
        assert!(
            (distance - 0.02).abs() < 1e-3,
            "cell {} on {} lies {:.2} mm off the surface",
            cell.id.0,
            cell.link,
            (0.02 - distance) * 1e3
        );
        if cell.link == "capsule_link" && (p.z - 1.0).abs() > 0.1 {
            on_caps += 1;
        }
    }
    // A third of a capsule's area is its caps: about 13 of 40 cells.
    assert!(on_caps >= 5, "{on_caps} cells on the capsule's caps");
}
