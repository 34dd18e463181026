//! The MJCF skin_model writes, as MuJoCo itself compiles it: the same joints
//! (names, kinds, axes, ranges) and, at several poses, the same pose of every
//! body as skin_model's forward kinematics, within 1e-9 m and 1e-9 rad; mimic
//! joints follow their master in simulation. Checked on the built-in robot
//! and on the URDF fixtures (arms, mimics, prismatic fingers, mesh-only links).

mod common;

use std::path::{Path, PathBuf};

use nalgebra::{Isometry3, Quaternion, UnitQuaternion, Vector3};
use serde_json::{json, Value};
use skin_model::robot::kinematics::{forward, BodyState, DofMotion};
use skin_model::robot::{hrp2, DofKind, Drive, Robot};

const TOLERANCE: f64 = 1e-9;

/// The robots to write: the built-in one and every URDF fixture.
fn robots() -> Vec<Robot> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../model/tests/fixtures/robots");
    let mut robots = vec![hrp2::robot()];
    for name in ["ur5_robot", "panda", "baxter", "pr2"] {
        robots.push(Robot::from_urdf_file(&dir.join(format!("{name}.urdf"))).unwrap());
    }
    robots
}

/// The home pose and three more spread over every DoF's range (a
/// continuous joint over one turn), deterministic.
fn poses(robot: &Robot) -> Vec<Vec<f64>> {
    let mut poses = vec![robot.home().to_vec()];
    for k in 1..4 {
        poses.push(
            robot
                .dofs()
                .iter()
                .enumerate()
                .map(|(d, dof)| {
                    let f = (0.618_034 * d as f64 + 0.29 * k as f64).fract();
                    if dof.lower.is_finite() && dof.upper.is_finite() {
                        dof.lower + f * (dof.upper - dof.lower)
                    } else {
                        std::f64::consts::PI * (2.0 * f - 1.0)
                    }
                })
                .collect(),
        );
    }
    poses
}

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("skin-mjcf-model-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn numbers(v: &Value) -> Vec<f64> {
    v.as_array().unwrap().iter().map(|x| x.as_f64().unwrap()).collect()
}

#[test]
fn mujoco_compiles_the_written_models_to_the_same_joints_and_kinematics() {
    let Some(python) = common::python() else { return };
    for robot in robots() {
        let dir = scratch(robot.name());
        let model = dir.join("robot.xml");
        std::fs::write(&model, robot.to_mjcf()).unwrap();
        let poses = poses(&robot);
        let named: Vec<Value> = poses
            .iter()
            .map(|q| {
                let angles = robot.joint_angles(q);
                Value::Object(robot.joints().iter().zip(angles).map(|(j, a)| (j.name.clone(), json!(a))).collect())
            })
            .collect();
        let follow: Vec<[&str; 2]> = robot
            .joints()
            .iter()
            .filter_map(|j| match j.drive {
                Drive::Mimic { dof, .. } => {
                    Some([j.name.as_str(), robot.joints()[robot.dofs()[dof].joint].name.as_str()])
                }
                Drive::Dof(_) => None,
            })
            .collect();
        let request = dir.join("poses.json");
        std::fs::write(&request, json!({ "poses": named, "follow": follow }).to_string()).unwrap();
        let out = common::run_json(&python, "mjcf_kinematics.py", &[&model, &request]);
        let name = robot.name();

        assert_eq!(out["timestep"].as_f64(), Some(0.002), "{name}");
        // mjINT_IMPLICITFAST
        assert_eq!(out["integrator"].as_i64(), Some(3), "{name}");
        let joints = out["joints"].as_array().unwrap();
        assert_eq!(joints.len(), robot.joints().len(), "{name}");
        for j in robot.joints() {
            let mj =
                joints.iter().find(|m| m["name"] == j.name.as_str()).unwrap_or_else(|| panic!("{name}: {}", j.name));
            let kind = match j.kind {
                DofKind::Revolute => "hinge",
                DofKind::Prismatic => "slide",
            };
            assert_eq!(mj["type"], kind, "{name} {}", j.name);
            let axis = Vector3::from_vec(numbers(&mj["axis"]));
            assert!((axis - j.axis.into_inner()).norm() < TOLERANCE, "{name} {}: axis {axis} vs {}", j.name, *j.axis);
            if let Drive::Dof(d) = j.drive {
                let dof = &robot.dofs()[d];
                let limited = dof.lower.is_finite();
                assert_eq!(mj["limited"].as_bool(), Some(limited), "{name} {}", j.name);
                if limited {
                    assert_eq!(numbers(&mj["range"]), vec![dof.lower, dof.upper], "{name} {}", j.name);
                }
            }
        }
        let actuators = out["actuators"].as_array().unwrap();
        let names: Vec<&str> = actuators.iter().map(|a| a["name"].as_str().unwrap()).collect();
        assert_eq!(names, robot.dofs().iter().map(|d| d.name.as_str()).collect::<Vec<_>>(), "{name}");
        for (a, dof) in actuators.iter().zip(robot.dofs()) {
            let range = numbers(&a["forcerange"]);
            assert!(range[1] > 0.0 && range[0] == -range[1], "{name} {}: {range:?}", dof.name);
            if dof.max_effort.is_finite() {
                assert_eq!(range[1], dof.max_effort, "{name} {}", dof.name);
            }
        }

        let zero = vec![0.0; robot.dofs().len()];
        let mut states = Vec::new();
        for (q, mj) in poses.iter().zip(out["poses"].as_array().unwrap()) {
            let motion = DofMotion { q, qd: &zero, qdd: &zero };
            forward(&robot, &BodyState::at_rest(Isometry3::identity()), motion, &mut states);
            for (body, state) in robot.bodies().iter().zip(&states) {
                let p = numbers(&mj[body.name.as_str()]);
                assert_eq!(p.len(), 7, "{name}: MuJoCo has no body {}", body.name);
                let position = Vector3::new(p[0], p[1], p[2]);
                let rotation = UnitQuaternion::from_quaternion(Quaternion::new(p[3], p[4], p[5], p[6]));
                let error = (position - state.pose.translation.vector).norm();
                assert!(error < TOLERANCE, "{name} {} at {q:?}: {error} m apart", body.name);
                let turned = rotation.angle_to(&state.pose.rotation);
                assert!(turned < TOLERANCE, "{name} {} at {q:?}: {turned} rad apart", body.name);
            }
        }

        // Mimics: the equality constraint keeps q = multiplier * master + offset,
        // softly (MuJoCo's default 20 ms constraint time constant gives way
        // by about a milliradian under PR2's gripper linkage).
        let mimics = robot.joints().iter().filter_map(|j| match j.drive {
            Drive::Mimic { multiplier, offset, .. } => Some((j, multiplier, offset)),
            Drive::Dof(_) => None,
        });
        for ((j, multiplier, offset), pair) in mimics.zip(out["follow"].as_array().unwrap()) {
            let [q, master] = numbers(pair)[..] else { panic!("{name}: {pair}") };
            let error = (q - (multiplier * master + offset)).abs();
            assert!(error < 5e-3, "{name} {}: {q} follows {master} with {error} off", j.name);
        }
        let hold = out["hold_error"].as_object().unwrap();
        let (worst, error) =
            hold.iter().map(|(j, e)| (j.as_str(), e.as_f64().unwrap())).max_by(|a, b| a.1.total_cmp(&b.1)).unwrap();
        println!("{name}: after 2 s at home, the servos hold within {error:.4} ({worst})");
        if name == hrp2::robot().name() {
            // Its torque limits carry its arms: no servo saturates at home.
            assert!(error < 2e-3, "{worst} sags by {error} rad");
        }
        std::fs::remove_dir_all(&dir).unwrap();
    }
}

/// `skin model` writes the built-in robot's MJCF (and converts a URDF),
/// refusing to overwrite a file unless told to.
#[test]
fn skin_model_writes_the_mjcf_and_keeps_existing_files() {
    let dir = scratch("cli");
    let out = dir.join("hrp2.xml");
    let skin =
        |args: &[&std::ffi::OsStr]| std::process::Command::new(env!("CARGO_BIN_EXE_skin")).args(args).output().unwrap();
    let first = skin(&["model".as_ref(), "--output".as_ref(), out.as_os_str()]);
    assert!(first.status.success(), "{}", String::from_utf8_lossy(&first.stderr));
    assert_eq!(std::fs::read_to_string(&out).unwrap(), hrp2::robot().to_mjcf());
    let again = skin(&["model".as_ref(), "--output".as_ref(), out.as_os_str()]);
    assert!(!again.status.success());
    assert!(String::from_utf8_lossy(&again.stderr).contains("pass --force"));
    let urdf = Path::new(env!("CARGO_MANIFEST_DIR")).join("../model/tests/fixtures/robots/panda.urdf");
    let converted = skin(&["model".as_ref(), "--urdf".as_ref(), urdf.as_os_str()]);
    assert!(converted.status.success(), "{}", String::from_utf8_lossy(&converted.stderr));
    assert_eq!(String::from_utf8(converted.stdout).unwrap(), Robot::from_urdf_file(&urdf).unwrap().to_mjcf());
    std::fs::remove_dir_all(&dir).unwrap();
}
