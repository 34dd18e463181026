//! The models the project writes for MuJoCo: the built-in robot's MJCF is
//! the same robot in the MuJoCo world (tree, limits, its own servos, gravity
//! on its skin), and a calibrated skin written into a user's model
//! (`robot_with_skin.xml`) is read by MuJoCo from any folder.

use std::path::{Path, PathBuf};

use mujoco_rs::prelude::*;
use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};
use skin_model::robot::{hrp2, Drive};
use skin_model::skin::Skin;
use skin_sim::mujoco::{model_with_skin, CellSite, Model, MujocoError};
use skin_sim::world::{BaseConfig, WorldConfig};

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("skin-mujoco-models-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("the temporary folder is writable");
    dir
}

#[test]
fn the_built_in_robots_mjcf_is_the_same_robot_in_the_mujoco_world() {
    let dir = scratch("hrp2");
    let path = dir.join("hrp2.xml");
    let builtin = hrp2::robot();
    std::fs::write(&path, builtin.to_mjcf()).expect("the temporary folder is writable");
    let model = Model::load(&path).expect("MuJoCo loads the built-in robot's MJCF");
    let robot = model.robot();
    let names =
        |r: &skin_model::robot::Robot| r.dofs().iter().map(|d| (d.name.clone(), d.lower, d.upper)).collect::<Vec<_>>();
    assert_eq!(names(robot), names(&builtin));
    assert_eq!(robot.bodies().len(), builtin.bodies().len());
    for mine in robot.joints() {
        let theirs = builtin.joints().iter().find(|j| j.name == mine.name).expect("the same joints");
        // The same parent: carried by the same joint (or the root, which
        // MuJoCo's tree calls "world", the built-in one "CHEST").
        let carrier =
            |r: &skin_model::robot::Robot, b: usize| r.bodies()[b].parent_joint.map(|j| r.joints()[j].name.clone());
        assert_eq!(carrier(robot, mine.parent_body), carrier(&builtin, theirs.parent_body));
        let apart = (mine.origin.translation.vector - theirs.origin.translation.vector).norm()
            + mine.origin.rotation.angle_to(&theirs.origin.rotation);
        assert!(apart < 1e-9, "{}: origins {apart} apart", mine.name);
        assert!((mine.axis.into_inner() - theirs.axis.into_inner()).norm() < 1e-12, "{}", mine.name);
        assert!(matches!(mine.drive, Drive::Dof(_)));
    }
    // Its servos are its own: the world adds none. It starts in the home
    // keyframe the MJCF carries (the built-in robot's home).
    assert_eq!(model.notes().len(), 1, "{:?}", model.notes());
    assert!(model.notes()[0].contains("keyframe \"home\""), "{:?}", model.notes());
    assert_eq!(robot.home(), builtin.home());

    // The 74-cell skin, a second at rest: every accelerometer reads 1 g up.
    let skin = Skin::with_counts(robot, &hrp2::SKIN, 5).expect("the built-in skin fits");
    let cfg = WorldConfig { base: BaseConfig::rigid(), seed: 5, ..WorldConfig::default() };
    let mut world = model.world(skin, cfg).expect("the robot takes the skin");
    // Nothing added but the controllers' gravity compensation, said once.
    let notes = world.mujoco_engine().expect("a MuJoCo world").notes();
    assert_eq!(notes.len(), 2, "{notes:?}");
    assert!(notes[1].contains("compensate the links' weight"), "{notes:?}");
    let home = world.positions().to_vec();
    let mut out = Vec::new();
    for _ in 0..250 {
        world.command(&[0.0; 14]).expect("14 DoFs");
        out.clear();
        world.step(&mut out);
    }
    for (d, (q, h)) in world.positions().iter().zip(&home).enumerate() {
        assert!((q - h).abs() < 2e-3, "DoF {d} sagged from {h} to {q}");
    }
    for ((_, sample), pose) in out.iter().zip(world.cell_poses()) {
        let counts = Vector3::from(sample.accel().map(f64::from)) / 256.0;
        let expected = pose.rotation.inverse() * Vector3::z();
        assert!((counts - expected).norm() < 0.12, "read {counts:?} g, expected {expected:?}");
    }
    std::fs::remove_dir_all(&dir).expect("the scratch folder can go");
}

/// A base, and an arm on a vertical hinge (gravity holds it still) whose geometry is a mesh in the folder
/// `assets` (`meshdir`), over a floor.
const ARM: &str = r#"
<mujoco model="meshed">
  <compiler angle="radian" meshdir="assets"/>
  <asset><mesh name="wedge" file="wedge.obj"/></asset>
  <worldbody>
    <geom name="floor" type="plane" size="2 2 0.1"/>
    <body name="base" pos="0 0 0.5">
      <geom type="box" size="0.1 0.1 0.1"/>
      <body name="arm" pos="0 0 0.2">
        <joint name="swing" type="hinge" axis="0 0 1" range="-1 1"/>
        <geom type="mesh" mesh="wedge" mass="1"/>
      </body>
    </body>
  </worldbody>
</mujoco>
"#;

const WEDGE: &str = "v 0 -0.05 0\nv 0.3 -0.05 0\nv 0 0.05 0\nv 0 0 0.1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n";

fn reading<const N: usize>(model: &MjModel, data: &MjData<&MjModel>, name: &str) -> [f64; N] {
    let id = model.name_to_id(MjtObjBase::mjOBJ_SENSOR, name).unwrap_or_else(|| panic!("no sensor {name}"));
    let adr = model.sensor_adr()[id] as usize;
    std::array::from_fn(|k| data.sensordata()[adr + k])
}

#[test]
fn a_calibrated_skin_written_into_the_users_model_is_read_by_mujoco_from_another_folder() {
    let dir = scratch("with-skin");
    std::fs::create_dir_all(dir.join("assets")).expect("the temporary folder is writable");
    std::fs::write(dir.join("assets/wedge.obj"), WEDGE).expect("the temporary folder is writable");
    let path = dir.join("meshed.xml");
    std::fs::write(&path, ARM).expect("the temporary folder is writable");
    // One cell on the base's top facing up, one under the arm facing the floor.
    let cells = [
        CellSite { name: "skin_cell_7".into(), body: "base".into(), pose: Isometry3::translation(0.0, 0.0, 0.1) },
        CellSite {
            name: "skin_cell_9".into(),
            body: "arm".into(),
            pose: Isometry3::from_parts(
                Translation3::new(0.2, 0.0, 0.0),
                UnitQuaternion::from_axis_angle(&Vector3::x_axis(), std::f64::consts::PI),
            ),
        },
    ];
    let written = model_with_skin(&path, &cells).expect("MuJoCo writes the model with the skin");
    assert!(written.notes.is_empty(), "{:?}", written.notes);
    let text = written.xml;
    let elsewhere = scratch("with-skin-elsewhere").join("robot_with_skin.xml");
    std::fs::write(&elsewhere, &text).expect("the temporary folder is writable");

    let model = MjModel::from_xml(&elsewhere).expect("MuJoCo loads robot_with_skin.xml from another folder");
    let mut data = model.make_data();
    for _ in 0..5 {
        data.step();
    }
    // The arm's cell, upside down at rest: gravity reads along its -z; the
    // floor is 0.7 m below it along its +z; nothing touches it.
    let accel: [f64; 3] = reading(&model, &data, "skin_cell_9:acc");
    assert!((Vector3::from(accel) - Vector3::new(0.0, 0.0, -9.81)).norm() < 0.05, "{accel:?}");
    let [range] = reading(&model, &data, "skin_cell_9:range");
    assert!((range - 0.7).abs() < 0.01, "the floor at {range} m");
    for k in 0..3 {
        let [touch] = reading(&model, &data, &format!("skin_cell_9:touch{k}"));
        assert_eq!(touch, 0.0);
    }
    // The base's cell sees the arm 0.1 m above it.
    let [up] = reading(&model, &data, "skin_cell_7:range");
    assert!((up - 0.1).abs() < 1e-6, "the arm at {up} m");
    // The user's model is kept: its mesh, floor and joint.
    assert!(text.contains("wedge") && text.contains("floor") && text.contains("swing"));

    let unknown = [CellSite { name: "c".into(), body: "tail".into(), pose: Isometry3::identity() }];
    assert!(matches!(model_with_skin(&path, &unknown), Err(MujocoError::UnknownBody(b)) if b == "tail"));
    assert!(matches!(model_with_skin(&dir.join("none.xml"), &cells), Err(MujocoError::Load { .. })));
    std::fs::remove_dir_all(&dir).expect("the scratch folder can go");
    std::fs::remove_dir_all(elsewhere.parent().unwrap_or(Path::new("."))).expect("the scratch folder can go");
}
