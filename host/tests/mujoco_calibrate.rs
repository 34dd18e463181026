//! `skin calibrate --mujoco MODEL --out DIR` writes `robot_with_skin.xml`:
//! the user's model wearing every calibrated cell, which MuJoCo (its Python
//! package, a reader we did not write) loads and reads each cell's
//! accelerometer, rangefinder and touch sensors from, at the calibrated
//! pose on the calibrated body. And an excitation that runs into another
//! part of the robot (a finger into its neighbour) is left out and made
//! the other way, so the cells are still placed.

mod common;

use std::path::Path;

use nalgebra::{Quaternion, UnitQuaternion, Vector3};

/// A yaw, a shoulder and an elbow with the model's own position servos.
const ARM: &str = r#"<mujoco model="arm">
  <option timestep="0.002" integrator="implicitfast"/>
  <worldbody>
    <body name="base" pos="0 0 0.5">
      <geom type="box" size="0.08 0.08 0.08" mass="3"/>
      <body name="turret" pos="0 0 0.12">
        <joint name="yaw" axis="0 0 1" range="-2 2" armature="0.05"/>
        <geom type="cylinder" size="0.06 0.04" mass="1"/>
        <body name="upper" pos="0 0 0.08">
          <joint name="shoulder" axis="0 1 0" range="-1.5 1.5" armature="0.05"/>
          <geom type="box" size="0.15 0.04 0.04" pos="0.15 0 0" mass="1.5"/>
          <body name="fore" pos="0.3 0 0">
            <joint name="elbow" axis="0 1 0" range="-2 2" armature="0.02"/>
            <geom type="box" size="0.12 0.035 0.035" pos="0.12 0 0" mass="0.8"/>
          </body>
        </body>
      </body>
    </body>
  </worldbody>
  <actuator>
    <position joint="yaw" kp="400" dampratio="1" forcerange="-40 40"/>
    <position joint="shoulder" kp="1000" dampratio="1" forcerange="-60 60"/>
    <position joint="elbow" kp="400" dampratio="1" forcerange="-30 30"/>
  </actuator>
</mujoco>
"#;

#[test]
fn calibrating_on_a_mujoco_model_writes_it_wearing_the_skin_and_mujoco_reads_the_cells() {
    let Some(python) = common::python() else { return };
    let dir = std::env::temp_dir().join(format!("skin-mujoco-calibrate-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let model = dir.join("arm.xml");
    std::fs::write(&model, ARM).unwrap();
    let out = dir.join("calibrated");
    let run = std::process::Command::new(env!("CARGO_BIN_EXE_skin"))
        .args(["calibrate", "--cells-per-link", "3", "--json", "--mujoco"])
        .arg(&model)
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    let report: serde_json::Value = serde_json::from_slice(&run.stdout).unwrap();
    assert!(!out.join("robot_with_skin.urdf").exists(), "a MuJoCo model gets no URDF");

    let cells = common::run_json(&python, "mujoco_skin_sensors.py", &[Path::new(&out.join("robot_with_skin.xml"))]);
    let calibrated = report["cells"].as_array().unwrap();
    assert_eq!(cells.as_object().unwrap().len(), calibrated.len());
    for c in calibrated {
        let name = format!("skin_cell_{}", c["id"]);
        let cell = &cells[&name];
        assert_eq!(cell["body"], c["link"], "{name}");
        let numbers =
            |v: &serde_json::Value| -> Vec<f64> { v.as_array().unwrap().iter().map(|x| x.as_f64().unwrap()).collect() };
        // Where the calibration put it (the links are the model's bodies).
        let xyz = Vector3::from_vec(numbers(&c["xyz"]));
        assert!((Vector3::from_vec(numbers(&cell["pos"])) - xyz).norm() < 1e-6, "{name}: {} vs {xyz}", cell["pos"]);
        let [r, p, y] = numbers(&c["rpy"])[..] else { panic!("{name}: rpy") };
        let q = numbers(&cell["quat"]);
        let site = UnitQuaternion::from_quaternion(Quaternion::new(q[0], q[1], q[2], q[3]));
        let turned = site.angle_to(&UnitQuaternion::from_euler_angles(r, p, y));
        assert!(turned < 1e-5, "{name}: {turned} rad from the calibrated frame");
        // At rest, a cell on a moving body feels 1 g (the base's cells sit
        // on the root, MuJoCo's world body, whose sensors read zero);
        // nothing touches the arm.
        let g = Vector3::from_vec(numbers(&cell["acc"])).norm();
        if c["link"] != "world" {
            assert!((g - 9.81).abs() < 0.1, "{name}: {g} m/s^2");
        }
        assert!(numbers(&cell["touch"]).iter().all(|f| *f == 0.0), "{name}: {}", cell["touch"]);
        assert!(cell["range"].as_f64().unwrap() >= -1.0);
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Two fingers hanging side by side from a fixed palm, each spreading
/// (about x) and flexing (about y), with LEAP-hand-like weak servos and
/// stiff contacts: spreading towards the other finger, one hits it.
const FINGERS: &str = r#"<mujoco model="fingers">
  <compiler angle="radian"/>
  <option timestep="0.002" integrator="implicitfast"/>
  <default>
    <geom solimp="0.999 0.999 0.001 0.0001 1" solref="0.0001 1" friction="0.2"/>
    <joint damping="0.03" range="-1 1"/>
    <position kp="3" kv="0.01" ctrlrange="-1 1"/>
  </default>
  <worldbody>
    <body name="palm" pos="0 0 0.3">
      <geom type="box" size="0.03 0.03 0.01" mass="0.3"/>
      <body name="a_base" pos="0 0.011 -0.015">
        <joint name="a_spread" axis="1 0 0"/>
        <geom type="box" size="0.01 0.009 0.025" pos="0 0 -0.025" mass="0.04"/>
        <body name="a_tip" pos="0 0 -0.05">
          <joint name="a_flex" axis="0 1 0"/>
          <geom type="box" size="0.01 0.009 0.02" pos="0 0 -0.02" mass="0.02"/>
        </body>
      </body>
      <body name="b_base" pos="0 -0.011 -0.015">
        <joint name="b_spread" axis="1 0 0"/>
        <geom type="box" size="0.01 0.009 0.025" pos="0 0 -0.025" mass="0.04"/>
        <body name="b_tip" pos="0 0 -0.05">
          <joint name="b_flex" axis="0 1 0"/>
          <geom type="box" size="0.01 0.009 0.02" pos="0 0 -0.02" mass="0.02"/>
        </body>
      </body>
    </body>
  </worldbody>
  <contact>
    <exclude body1="palm" body2="a_base"/>
    <exclude body1="palm" body2="b_base"/>
  </contact>
  <actuator>
    <position joint="a_spread"/>
    <position joint="a_flex"/>
    <position joint="b_spread"/>
    <position joint="b_flex"/>
  </actuator>
</mujoco>
"#;

#[test]
fn an_excitation_that_runs_into_another_finger_is_left_out_and_made_the_other_way() {
    let dir = std::env::temp_dir().join(format!("skin-mujoco-fingers-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let model = dir.join("fingers.xml");
    std::fs::write(&model, FINGERS).unwrap();
    let run = std::process::Command::new(env!("CARGO_BIN_EXE_skin"))
        .args(["calibrate", "--seed", "2", "--json", "--mujoco"])
        .arg(&model)
        .output()
        .unwrap();
    std::fs::remove_dir_all(&dir).unwrap();
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    let report: serde_json::Value = serde_json::from_slice(&run.stdout).unwrap();
    assert_eq!(report["exploration_truth"]["tree_correct"], true, "{report:#}");
    let warnings = report["warnings"].to_string();
    assert!(warnings.contains("ran into something") && warnings.contains("made the other way"), "{warnings}");
    assert_eq!(report["skipped"].as_array().unwrap().len(), 0, "every DoF is excited: {}", report["skipped"]);
    // Through the impact every finger cell moved as no joint feedback
    // explains: all 16 were left unknown. Without it they are placed.
    let truth = &report["truth"];
    let mm = |what: &str| truth["position_m"][what].as_f64().unwrap() * 1e3;
    assert_eq!(truth["position_m"]["cells"], 16, "the fingers' cells are placed: {warnings}");
    assert!(mm("mean") < 5.0 && mm("p95") < 10.0, "{truth:#}");
    assert_eq!(truth["overconfident"], 0, "{truth:#}");
    assert_eq!(truth["wrong_link"], 0, "{truth:#}");
}
