//! The grasping experiment of section 6.5 end to end, as a user runs it
//! (`skin grasp`): the experiment's robot and skin served on loopback UDP
//! organize and explore themselves, a simulated person teaches the key
//! poses by proximity guidance, and the robot grasps objects of Figure 16
//! with one parameter set, going home between grasps.

use std::path::Path;
use std::process::{Command, Output};

use serde_json::Value;
use skin_host::control::params::Params;
use skin_sim::scene::force::Calibration;
use skin_sim::scene::held::BARE_PAIN_N;

fn skin(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_skin")).args(args).output().expect("the skin binary runs")
}

/// The runs `skin grasp --json` printed for `args`.
fn runs(args: &[&str]) -> Vec<Value> {
    let out = skin(&[&["grasp", "--json"][..], args].concat());
    assert!(out.status.success(), "{args:?}: {}", String::from_utf8_lossy(&out.stderr));
    let v: Value = serde_json::from_slice(&out.stdout).expect("JSON");
    v.as_array().expect("an array").clone()
}

/// Held by the truth and released along the paper's states, without pain,
/// gripped by the object's own force (not the person's pats).
fn check_held(r: &Value) {
    let pain_n = Calibration::default().force(f64::from(Params::default().levels.force[3]));
    let path: Vec<&str> = r["state_log"].as_array().unwrap().iter().map(|l| l["state"].as_str().unwrap()).collect();
    assert_eq!(r["succeeded"], true, "{}: {path:?} {}", r["object"], r["at_release"]);
    assert_eq!(r["reason"], Value::Null);
    assert_eq!(r["controller_state"], "done", "{}: released after the hold", r["object"]);
    assert_eq!(path[..6], ["open", "approach", "contact", "load", "pull", "squeeze"], "{}", r["object"]);
    // An arm that lost the object while squeezing pulls it in again; the
    // last state before the release is Hold.
    let regrip = &path[6..path.len() - 2];
    assert!(regrip.iter().all(|s| ["pull", "squeeze", "hold"].contains(s)), "{}: {path:?}", r["object"]);
    assert_eq!(regrip.last(), Some(&"hold"), "{}: {path:?}", r["object"]);
    assert_eq!(path[path.len() - 2..], ["release", "done"], "{}", r["object"]);
    assert_eq!(r["pain_events"], 0, "{}", r["object"]);
    // The truth measures what no cell feels too: a pinch on the bare surface.
    let bare_n = r["bare_force_max_n"].as_f64().expect("the bare surface's force is measured");
    assert!(bare_n <= BARE_PAIN_N, "{}: {bare_n} N on the bare surface", r["object"]);
    let truth = &r["at_release"];
    assert_eq!(truth["between_arms"], true, "{truth}");
    assert!(truth["gap_m"].as_f64().unwrap() <= 0.01, "against the chest: {truth}");
    assert!(truth["arm_force_n"].as_array().unwrap().iter().all(|f| f.as_f64().unwrap() >= 0.05), "{truth}");
    let (grip_n, pats_n) = (r["grip_force_max_n"].as_f64().unwrap(), r["hand_force_max_n"].as_f64().unwrap());
    assert!(grip_n > 0.1, "{}: the skin felt the object: {grip_n} N", r["object"]);
    assert!(pats_n > 0.1, "{}: the person patted: {pats_n} N", r["object"]);
    let max_n = r["max_cell_force_n"].as_f64().unwrap();
    assert!(max_n >= grip_n.max(pats_n) && max_n < pain_n, "{}: {max_n} N, pain at {pain_n} N", r["object"]);
    // Reached in a state the grasp went through, or at rest before the launching pat.
    let at = &r["max_cell_force_at"];
    let state = at["state"].as_str().unwrap();
    assert!(path.contains(&state) || state == "home", "{}: {at}", r["object"]);
    assert!(at["time_s"].as_f64().unwrap() <= r["time_s"].as_f64().unwrap(), "{}: {at}", r["object"]);
}

/// The paper's claim: all five objects with one parameter set, no pain.
/// About a minute at the test profile's opt-level:
/// `cargo test -p skin-host --test grasp -- --ignored`.
#[test]
#[ignore]
fn five_objects_grasped_with_one_parameter_set() {
    let runs = runs(&["--object", "all"]);
    assert_eq!(runs.len(), 5);
    runs.iter().for_each(check_held);
}

/// One object, soft and irregular, and the traces of Figure 18.
#[test]
fn the_sponge_rock_is_grasped_and_traced() {
    let dir = std::env::temp_dir().join(format!("skin-grasp-test-{}", std::process::id()));
    let runs = runs(&["--object", "sponge_rock", "--seed", "1", "--traces", dir.to_str().unwrap()]);
    assert_eq!(runs.len(), 1);
    check_held(&runs[0]);
    let file = |ext: &str| std::fs::read_to_string(Path::new(&dir).join(format!("grasp_sponge_rock.{ext}"))).unwrap();
    let csv = file("csv");
    assert!(csv.starts_with("time_s,state,q0_rad"), "{}", &csv[..80]);
    assert!(csv.lines().count() > 100);
    assert!(csv.contains(",hold,"));
    let column = csv.lines().next().unwrap().split(',').position(|c| c == "object_gap_m").unwrap();
    let gaps: Vec<f64> = csv.lines().skip(1).filter_map(|l| l.split(',').nth(column)?.parse().ok()).collect();
    assert!(gaps.first().unwrap() > gaps.last().unwrap(), "the object was pulled towards the chest");
    let svg = file("svg");
    assert!(svg.contains("<svg") && svg.contains("pre-contact"));
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn grasp_prints_one_json_object_per_grasp() {
    let runs = runs(&["--object", "none", "--seed", "3"]);
    assert_eq!(runs.len(), 1);
    let r = &runs[0];
    assert_eq!(r["object"], "none");
    assert_eq!(r["placement"], Value::Null);
    assert_eq!(r["succeeded"], false);
    assert_eq!(r["reason"], "missed", "nothing to hold");
    assert_eq!(r["controller_state"], "cancelled");
    assert_eq!(r["at_release"], Value::Null);
    assert_eq!(r["pain_events"], 0);
    assert!(r["time_s"].as_f64().unwrap() > 0.0);
    assert_eq!(r["grip_force_max_n"], 0.0, "nothing gripped");
    assert!(r["hand_force_max_n"].as_f64().unwrap() > 0.1, "the launching pat");
    let log = r["state_log"].as_array().unwrap();
    assert_eq!(log[0]["state"], "open");
    assert_eq!(log[0]["cause"], "pat");
    assert!(log[0]["time_s"].as_f64().is_some());
    let cancel = log.iter().find(|l| l["state"] == "cancel").expect("cancelled");
    assert_eq!(cancel["cause"], "reached", "closed on nothing");
}

/// An object nobody tuned for, from a file, put off-centre and turned.
#[test]
fn an_object_file_is_grasped_where_it_says() {
    let file = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/fixtures/objects/paint_bucket.toml");
    let runs = runs(&["--object-file", file, "--seed", "2"]);
    assert_eq!(runs.len(), 1, "the file alone, not the five as well");
    check_held(&runs[0]);
    assert_eq!(runs[0]["object"], "paint_bucket");
    assert_eq!(runs[0]["placement"]["offset_m"], serde_json::json!([0.0, 0.03, 0.0]));
    assert_eq!(runs[0]["placement"]["yaw_rad"], 0.3);
}

#[test]
fn mistakes_get_a_message_not_a_panic() {
    let dir = std::env::temp_dir().join(format!("skin-grasp-mistakes-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let heavy = dir.join("heavy.toml");
    let bucket =
        std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/tests/fixtures/objects/paint_bucket.toml"));
    std::fs::write(&heavy, bucket.unwrap().replace("mass_kg = 0.6", "mass_kg = -2")).unwrap();
    let heavy = heavy.to_str().unwrap();
    let empty = dir.join("empty");
    std::fs::create_dir_all(&empty).unwrap();
    for (args, expected) in [
        (&["grasp", "--object", "piano"][..], "no object \"piano\": choose trash_bin"),
        (&["grasp", "--config", "/nonexistent/grasp.toml"][..], "cannot read /nonexistent/grasp.toml"),
        (&["grasp", "--object-file", heavy][..], "heavy.toml: `mass_kg` = -2: expected a mass in (0, 1000] kg"),
        (&["grasp", "--object-file", empty.to_str().unwrap()][..], "no object files (*.toml) in"),
        (&["grasp", "--object-file", "/nonexistent/o.toml"][..], "cannot read object file /nonexistent/o.toml"),
        (&["grasp", "--offset", "0,0.03"][..], "expected forward,left,up in m"),
        (&["grasp", "--offset", "-0.1,0,0"][..], "--offset/--yaw: `offset_m[0]` = -0.1"),
        (&["grasp", "--yaw", "NaN"][..], "`yaw_rad` = NaN"),
        (&["grasp", "--jitter", "1", "--yaw", "0.1"][..], "cannot be used with"),
    ] {
        let out = skin(args);
        assert!(!out.status.success());
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains(expected), "{args:?}: {err}");
        assert!(!err.contains("panicked"), "{err}");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// The five objects held 3 cm to either side of the default spot (the
/// spot itself is `five_objects_grasped_with_one_parameter_set`). About
/// 1.5 min in release:
/// `cargo test --release -p skin-host --test grasp -- --ignored placed`.
#[test]
#[ignore]
fn five_objects_held_placed_3_cm_to_either_side() {
    five_held_at(&[["--offset", "0,0.03,0"], ["--offset", "0,-0.03,0"]]);
}

/// The five objects held turned 0.3 rad either way (from `9238bb5` until
/// the arms pulled together the delivery box at +0.3 rad slipped, its
/// right arm off it for a moment 0.37 s into the hold). About 1.5 min in release:
/// `cargo test --release -p skin-host --test grasp -- --ignored turned`.
#[test]
#[ignore]
fn five_objects_held_turned_0_3_rad_either_way() {
    five_held_at(&[["--yaw", "0.3"], ["--yaw", "-0.3"]]);
}

/// Every Figure 16 object held at each placement.
fn five_held_at(placements: &[[&str; 2]]) {
    for placement in placements {
        let out = skin(&[&["grasp", "--json", "--object", "all"][..], &placement[..]].concat());
        let v: Value = serde_json::from_slice(&out.stdout).expect("JSON");
        let runs = v.as_array().expect("an array");
        assert_eq!(runs.len(), 5);
        for r in runs {
            check_held(r);
            let p = &r["placement"];
            let moved = p["offset_m"][1].as_f64().unwrap().abs() == 0.03 || p["yaw_rad"].as_f64().unwrap().abs() == 0.3;
            assert!(moved, "{placement:?}: {p}");
        }
    }
}
