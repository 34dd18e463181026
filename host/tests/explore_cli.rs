//! `skin explore` as a user runs it: the issue's JSON, the drawn tree, and
//! plain messages (never a panic) for mistakes.

use std::process::{Command, Output};

use serde_json::Value;

fn skin(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_skin")).args(args).output().expect("the skin binary runs")
}

fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

#[test]
fn explore_prints_the_issues_json() {
    let out = skin(&["explore", "--json", "--seed", "2"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let v: Value = serde_json::from_slice(&out.stdout).expect("one JSON object");
    assert_eq!(v["robot"], "hrp2-like");
    assert_eq!(v["dofs"].as_array().unwrap().len(), 14);
    assert_eq!(v["dofs"][0], "RARM_JOINT0");
    assert_eq!(v["cells"], 74);
    let robot_s = v["exploration_time_s"].as_f64().unwrap();
    assert!(robot_s > 0.0 && robot_s < 70.0, "{robot_s}");
    assert!(v["wall_time_s"].as_f64().unwrap() > 0.0);
    let parts = v["body_parts"].as_array().unwrap();
    assert_eq!(parts.len(), 15);
    let cells: usize = parts.iter().map(|p| p["cells"].as_array().unwrap().len()).sum();
    assert_eq!(cells, 74);
    assert_eq!(v["root_body_part"], 0);
    let joints = v["joints"].as_array().unwrap();
    assert_eq!(joints.len(), 14);
    assert_eq!(joints[0]["dofs"][0], "RARM_JOINT0");
    assert_eq!(joints[0]["parent_body_part"], 0);
    assert_eq!(joints[0]["child_body_part"], 1);
    assert_eq!(v["truth"]["cell_links"].as_object().unwrap().len(), 74);
    assert_eq!(v["truth"]["tree_correct"], true);
    assert!(v["truth"]["smm_mean_abs_error"].as_f64().unwrap() < 0.1);
    // Every posture measured in, the start first, one position per DoF.
    let postures = v["postures"].as_array().unwrap();
    assert!(!postures.is_empty());
    assert!(postures.iter().all(|p| p.as_array().unwrap().len() == 14));
    let evidence = &v["evidence"];
    let decided: u64 = ["static", "dynamic", "tree", "clearance"].iter().map(|k| evidence[k].as_u64().unwrap()).sum();
    assert_eq!(decided, 74 * 14);
    assert_eq!(v["assumed"].as_array().unwrap().len() as u64, evidence["clearance"].as_u64().unwrap());
    // What decided by gravity needs no lever: 0 there.
    let seen = v["levers"]["seen_m"].as_array().unwrap();
    assert_eq!(seen.len(), 74);
    let zeros = seen.iter().flat_map(|row| row.as_array().unwrap()).filter(|x| x.as_f64() == Some(0.0)).count();
    assert!(zeros as u64 >= evidence["static"].as_u64().unwrap(), "{zeros}");
}

#[test]
fn a_strict_exploration_names_each_undecided_entry_and_why_and_the_default_states_its_assumption() {
    // A level UR5-like arm: nothing tilts its vertical first axis.
    let urdf = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../model/tests/fixtures/robots/ur5_robot.urdf");
    let urdf = urdf.to_str().unwrap();
    let out = skin(&["explore", "--urdf", urdf, "--seed", "1", "--json", "--strict"]);
    assert!(!out.status.success());
    let v: Value = serde_json::from_slice(&out.stdout).expect("one JSON object");
    let undecided = v["undecided"].as_array().unwrap();
    assert!(!undecided.is_empty());
    for e in undecided {
        assert_eq!(e["dof"], "shoulder_pan_joint", "{e}");
        assert!(e["cell"].as_u64().is_some());
        assert!(e["reason"].as_str().unwrap().contains("--axis-clearance"), "{e}");
    }
    // By default they rest on the default clearance, each named with its lever bound.
    let out = skin(&["explore", "--urdf", urdf, "--seed", "1", "--json"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let v: Value = serde_json::from_slice(&out.stdout).expect("one JSON object");
    assert_eq!(v["truth"]["tree_correct"], true);
    let assumed = v["assumed"].as_array().unwrap();
    assert_eq!(assumed.len(), undecided.len());
    for a in assumed {
        assert_eq!(a["dof"], "shoulder_pan_joint", "{a}");
        assert!(a["assumption"].as_str().unwrap().contains("default mounting clearance of 1.00 mm"), "{a}");
        assert!(a["lever_bound_m"].as_f64().unwrap() < 0.001, "{a}");
    }
    // Every entry says the smallest lever its evidence would have decided
    // as a movement; near the first axis, the evidence reached 1 mm before
    // the clearance settled what showed less.
    let seen = v["levers"]["seen_m"].as_array().unwrap();
    assert_eq!(seen.len() as u64, v["cells"].as_u64().unwrap());
    assert!(seen.iter().all(|row| row.as_array().unwrap().len() == 6));
    assert_eq!(v["levers"]["near_axis_entries"].as_u64().unwrap(), assumed.len() as u64);
    let smallest = v["levers"]["smallest_decided_m"].as_f64().unwrap();
    assert!(smallest > 0.0 && smallest <= 0.001, "{smallest} m");
    let warnings = v["warnings"].as_array().unwrap();
    assert!(warnings.iter().any(|w| w.as_str().unwrap().contains("--strict refuses instead")), "{warnings:?}");
    // Declaring the mounting clearance settles them on the declaration.
    let out = skin(&["explore", "--urdf", urdf, "--seed", "1", "--json", "--axis-clearance", "0.02"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let v: Value = serde_json::from_slice(&out.stdout).expect("one JSON object");
    assert_eq!(v["truth"]["tree_correct"], true);
    assert!(v["evidence"]["clearance"].as_u64().unwrap() > 0);
    assert!(v["assumed"][0]["assumption"].as_str().unwrap().starts_with("the declared mounting clearance of 20.00 mm"));
}

#[test]
fn explore_draws_the_tree_for_people() {
    let out = skin(&["explore", "--seed", "1"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(text.starts_with("robot hrp2-like: 14 DoFs, 74 cells"), "{text}");
    assert!(text.contains("body part 0 (root): 14 cells"), "{text}");
    assert!(text.contains("(the paper: about 70 s)"), "{text}");
    assert!(text.contains("truth: tree correct"), "{text}");
}

#[test]
fn mistakes_get_a_message_not_a_panic() {
    for (args, expected) in [
        (&["explore", "--urdf", "/nonexistent/robot.urdf"][..], "cannot read URDF file /nonexistent/robot.urdf"),
        (&["explore", "--cells-per-link", "0"][..], "'--cells-per-link <N>': 0 is not in 1..=1000"),
        (&["explore", "--noise-scale", "-1"][..], "--noise-scale must be a finite number >= 0"),
        (&["explore", "--axis-clearance", "-0.1"][..], "--axis-clearance must be a finite length > 0 m"),
        (&["explore", "--axis-clearance", "inf"][..], "--axis-clearance must be a finite length > 0 m"),
        (&["explore", "--axis-clearance", "0"][..], "(--strict assumes none)"),
        (&["explore", "--axis-clearance", "0.01", "--strict"][..], "cannot be used with"),
        (&["explore", "--time-budget", "0"][..], "--time-budget must be a number of seconds in (0, 1e9]"),
        (&["explore", "--skin", "skin.yaml"][..], "cannot read skin file skin.yaml"),
        (&["explore", "--cells-per-link", "2", "--skin", "a.toml"][..], "cannot be used with"),
    ] {
        let out = skin(args);
        let err = stderr(&out);
        assert!(!out.status.success(), "{args:?}");
        assert!(err.contains(expected), "{args:?}: {err}");
        assert!(!err.contains("panicked"), "{args:?}: {err}");
    }
}

/// A build without MuJoCo keeps `--mujoco` and says how to get it.
#[cfg(not(feature = "mujoco"))]
#[test]
fn mujoco_asked_of_a_build_without_it_says_how_to_rebuild() {
    let how = "this skin was built without MuJoCo: run `cargo xtask install` (it installs the pinned MuJoCo library), then rebuild with `cargo build --release -p skin-host --features mujoco`";
    let out = skin(&["explore", "--mujoco", "robot.xml"]);
    assert_eq!(out.status.code(), Some(1));
    assert_eq!(stderr(&out).trim_end(), format!("error: {how}"));
    // The endpoint's built-in robot in MuJoCo (no file) says the same.
    let out = skin(&["sim-endpoint", "--mujoco", "--robot", "127.0.0.1:0", "--duration", "5"]);
    assert_eq!(out.status.code(), Some(1));
    assert!(stderr(&out).trim_end().ends_with(how), "{}", stderr(&out));
}
