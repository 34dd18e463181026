//! The grasping experiment in MuJoCo (`skin grasp --mujoco`): the same
//! controller, person and verdict as in the built-in scene, on the
//! built-in robot as a MuJoCo model, objects as free bodies standing on
//! the person's tray, the truth from MuJoCo's state alone.

use std::process::{Command, Output};

use serde_json::Value;
use skin_sim::scene::held::BARE_PAIN_N;

fn skin(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_skin")).args(args).output().expect("the skin binary runs")
}

/// One Figure 16 object, held in MuJoCo by the truth: off the person's
/// tray (they let go once the arms hug it), between the arms and against
/// the chest at release, without pain on the skin or the bare surface.
/// Ignored until the exploration finds the built-in robot's tree in
/// MuJoCo: today it stops there, before any grasp, with a wrist or gripper
/// DoF that "moves no cell" (seeds 0-3: one to three of the four; only the
/// hand's three cells and the finger's one are behind them).
/// `cargo test -p skin-host --features mujoco --test grasp_mujoco -- --ignored`.
#[test]
#[ignore]
fn the_trash_bin_is_held_in_mujoco_without_pain() {
    let out = skin(&["grasp", "--mujoco", "--json", "--object", "trash_bin"]);
    let runs: Value =
        serde_json::from_slice(&out.stdout).unwrap_or_else(|e| panic!("{e}: {}", String::from_utf8_lossy(&out.stderr)));
    let r = &runs.as_array().expect("an array")[0];
    let path: Vec<&str> = r["state_log"].as_array().unwrap().iter().map(|l| l["state"].as_str().unwrap()).collect();
    assert_eq!(r["succeeded"], true, "{path:?} {} {}", r["reason"], r["at_release"]);
    assert!(out.status.success());
    let truth = &r["at_release"];
    assert_eq!((truth["resting"].as_bool(), truth["fallen"].as_bool()), (Some(false), Some(false)), "{truth}");
    assert_eq!(r["pain_events"], 0);
    let bare = r["bare_force_max_n"].as_f64().expect("MuJoCo measures the bare surface's force");
    assert!(bare <= BARE_PAIN_N, "{bare} N on the bare surface");
}
