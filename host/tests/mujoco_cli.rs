//! The MuJoCo world as a user drives it (a build with the `mujoco`
//! feature), on models in `sim/tests/models`: explore finds the true tree
//! and reports it in the model's names, a floating base is reported
//! welded, and `skin sim-endpoint --mujoco` serves the robot link and the
//! skin's interface on UDP to `skin run`, as a real robot would.

mod common;

use std::io::BufRead;
use std::path::PathBuf;
use std::process::{Command, Output, Stdio};

use common::free_addr;
use serde_json::Value;

fn skin(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_skin")).args(args).output().expect("the skin binary runs")
}

/// A model the MuJoCo world's tests share.
fn model(name: &str) -> String {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../sim/tests/models").join(name);
    path.to_str().expect("a UTF-8 path").to_owned()
}

fn json(out: &Output) -> Value {
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    serde_json::from_slice(&out.stdout).expect("one JSON object")
}

/// `skin ARGS` started, and the first line it printed (an endpoint says
/// where it serves).
fn serve(args: &[&str]) -> (std::process::Child, String) {
    let mut served = Command::new(env!("CARGO_BIN_EXE_skin"))
        .args(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .expect("the skin binary runs");
    let mut line = String::new();
    std::io::BufReader::new(served.stdout.take().unwrap()).read_line(&mut line).unwrap();
    (served, line)
}

#[test]
fn explore_finds_the_true_tree_of_an_mjcf_arm_in_its_own_names() {
    let v = json(&skin(&["explore", "--mujoco", &model("arm.xml"), "--json", "--seed", "1"]));
    assert_eq!(v["robot"], "arm");
    assert_eq!(v["dofs"], serde_json::json!(["yaw", "shoulder", "elbow"]));
    assert_eq!(v["truth"]["tree_correct"], true, "{v:#}");
    let links: Vec<&str> =
        v["truth"]["cell_links"].as_object().unwrap().values().map(|l| l.as_str().unwrap()).collect();
    for body in ["base", "turret", "upper", "fore"] {
        assert!(links.contains(&body), "no cell named on body {body}: {links:?}");
    }
    assert_eq!(v["body_parts"].as_array().unwrap().len(), 4);
    let notes = v["mujoco"]["notes"].as_array().unwrap();
    assert!(notes.iter().any(|n| n.as_str().unwrap().contains("got one")), "the added servos are said: {notes:?}");
}

#[test]
fn a_floating_base_is_reported_welded() {
    let out = skin(&["explore", "--mujoco", &model("floater.xml"), "--json", "--axis-clearance", "0.001"]);
    let v = json(&out);
    assert_eq!(v["mujoco"]["welded"], serde_json::json!(["pelvis"]));
    assert!(String::from_utf8_lossy(&out.stderr).contains("note: floating base \"pelvis\" held by a weld"));
}

#[test]
fn a_model_mujoco_cannot_load_is_a_plain_error() {
    let out = skin(&["explore", "--mujoco", "/nonexistent/robot.xml"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert_eq!(err.trim_end(), "error: MuJoCo cannot load /nonexistent/robot.xml: no such file");
}

#[test]
fn skin_run_explores_the_mujoco_endpoint_over_udp() {
    let (robot, host) = (free_addr(), free_addr());
    let arm = model("arm.xml");
    let (mut served, line) = serve(&[
        "sim-endpoint",
        "--mujoco",
        &arm,
        "--robot",
        &robot,
        "--host",
        &host,
        "--duration",
        "300",
        "--seed",
        "2",
    ]);
    assert!(line.starts_with("serving the MuJoCo robot on"), "{line}");
    let dir = std::env::temp_dir().join(format!("skin-mujoco-run-{}", std::process::id()));
    let out_dir = dir.to_str().expect("a UTF-8 path");
    let out = skin(&["run", "--robot", &robot, "--interface", &host, "--cells", "16", "--json", "--out", out_dir]);
    let _ = (served.kill(), served.wait());
    let _ = std::fs::remove_dir_all(&dir);
    let v = json(&out);
    let explored = &v["exploration"];
    assert_eq!(explored["dofs"], serde_json::json!(["yaw", "shoulder", "elbow"]), "{v:#}");
    assert_eq!(explored["cells"].as_array().unwrap().len(), 16, "every cell organized and explored");
    assert_eq!(explored["body_parts"].as_array().unwrap().len(), 4, "{v:#}");
}

#[test]
fn the_endpoint_without_a_model_serves_the_built_in_robot_and_its_own_skin() {
    let robot = free_addr();
    let (mut served, line) =
        serve(&["sim-endpoint", "--mujoco", "--robot", &robot, "--host", &free_addr(), "--duration", "60"]);
    let _ = (served.kill(), served.wait());
    assert!(line.starts_with(&format!("serving the MuJoCo robot on {robot}")), "{line}");
    let ports = line.split("interface ports ").nth(1).unwrap().split(" send to").next().unwrap().split(", ").count();
    assert_eq!(ports, 5, "the paper's five interface ports: {line}");
    // Its skin is its own: a cell count is for a model's.
    let out = skin(&["sim-endpoint", "--mujoco", "--cells-per-link", "3", "--robot", &free_addr()]);
    assert_eq!(out.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&out.stderr).contains("--cells-per-link lays a skin on a --mujoco FILE"));
}
