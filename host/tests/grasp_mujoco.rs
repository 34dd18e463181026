//! The grasping experiment in MuJoCo (`skin grasp --mujoco`): the same
//! controller, person and verdict as in the built-in scene, on the
//! built-in robot as a MuJoCo model, objects as free bodies standing on
//! the person's tray, the truth from MuJoCo's state alone.

use std::process::{Command, Output};

use serde_json::Value;

fn skin(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_skin")).args(args).output().expect("the skin binary runs")
}

/// The runs `skin grasp --mujoco --json` printed for `args`, and whether it succeeded.
fn runs(args: &[&str]) -> (bool, Vec<Value>) {
    let out = skin(&[&["grasp", "--mujoco", "--json"][..], args].concat());
    let v: Value = serde_json::from_slice(&out.stdout)
        .unwrap_or_else(|e| panic!("{args:?}: {e}: {}", String::from_utf8_lossy(&out.stderr)));
    (out.status.success(), v.as_array().expect("an array").clone())
}

#[test]
fn probe() {
    let (ok, runs) = runs(&["--object", "trash_bin"]);
    for r in &runs {
        let mut r = r.clone();
        eprintln!("{ok} {}", serde_json::to_string_pretty(&r).unwrap());
        r["state_log"] = Value::Null;
    }
}
