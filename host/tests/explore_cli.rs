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
        (&["explore", "--cells-per-link", "0"][..], "the skin has no cells"),
        (&["explore", "--noise-scale", "-1"][..], "--noise-scale must be a finite number >= 0"),
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
