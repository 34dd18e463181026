//! The grasping experiment of section 6.5 end to end: exploration,
//! teaching by proximity guidance, and grasps of the five objects of
//! Figure 16 with one parameter set; and `skin grasp` as a user runs it.

use std::process::{Command, Output};

use serde_json::Value;
use skin_host::control::grasp::{Cause, State};
use skin_host::control::params::Params;
use skin_host::grasping::{grasp, learn, objects, write_traces};
use skin_sim::scene::force::Calibration;

fn skin(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_skin")).args(args).output().expect("the skin binary runs")
}

/// The paper's claim: all five objects, one parameter set, no pain, and a
/// cancelled grasp with nothing between the arms. About 25 s at the test
/// profile's opt-level: `cargo test -p skin-host --test grasp -- --ignored`.
#[test]
#[ignore]
fn five_objects_grasped_with_one_parameter_set_and_nothing_cancelled() {
    check_grasps("all", 0);
}

/// One object, soft and irregular, and the traces of Figure 18.
#[test]
fn the_sponge_rock_is_grasped_and_traced() {
    check_grasps("sponge_rock", 1);
}

fn check_grasps(choice: &str, seed: u64) {
    let params = Params::default();
    let taught = learn(seed, &params, &mut |_| ()).unwrap();
    assert_eq!(taught.lessons.len(), 3, "open, closed and pulled are taught; home is the start");
    let pain_n = Calibration::default().force(f64::from(params.levels.force[3]));
    let dir = std::env::temp_dir().join(format!("skin-grasp-test-{choice}-{}", std::process::id()));
    let mut runs = Vec::new();
    for object in objects(choice).unwrap().into_iter().chain(objects("none").unwrap()) {
        let run = grasp(&taught, object.as_ref(), &params).unwrap();
        let path: Vec<State> = run.state_log.iter().map(|l| l.state).collect();
        if object.is_some() {
            assert!(run.succeeded, "{}: {path:?}", run.object);
            assert_eq!(run.final_state, State::Done, "{}: released after the hold", run.object);
            assert_eq!(
                &path[..7],
                [State::Open, State::Approach, State::Contact, State::Load, State::Pull, State::Hold, State::Release],
                "{}",
                run.object
            );
        } else {
            assert!(!run.succeeded);
            assert_eq!(run.final_state, State::Cancelled, "{path:?}");
            assert_eq!(run.state_log.iter().find(|l| l.state == State::Cancel).unwrap().cause, Cause::Reached);
        }
        assert_eq!(run.pain_events, 0, "{}", run.object);
        assert!(run.max_cell_force_n < pain_n, "{}: {} N, pain at {pain_n} N", run.object, run.max_cell_force_n);
        runs.push(run);
    }
    // Figure 18: traces as CSV and SVG.
    let files = write_traces(&dir, &runs).unwrap();
    assert_eq!(files.len(), 2 * runs.len());
    let csv = std::fs::read_to_string(dir.join(format!("grasp_{}.csv", runs[0].object))).unwrap();
    assert!(csv.starts_with("time_s,state,q0_rad"), "{}", &csv[..80]);
    assert!(csv.lines().count() > 100);
    assert!(csv.contains(",hold,"));
    let svg = std::fs::read_to_string(dir.join(format!("grasp_{}.svg", runs[0].object))).unwrap();
    assert!(svg.contains("<svg") && svg.contains("pre-contact"));
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn grasp_prints_one_json_object_per_grasp() {
    let out = skin(&["grasp", "--object", "none", "--json", "--seed", "3"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let v: Value = serde_json::from_slice(&out.stdout).expect("JSON");
    let runs = v.as_array().expect("an array");
    assert_eq!(runs.len(), 1);
    let r = &runs[0];
    assert_eq!(r["object"], "none");
    assert_eq!(r["succeeded"], false);
    assert_eq!(r["final_state"], "cancelled");
    assert_eq!(r["pain_events"], 0);
    assert!(r["time_s"].as_f64().unwrap() > 0.0);
    assert!(r["max_cell_force_n"].as_f64().is_some());
    let log = r["state_log"].as_array().unwrap();
    assert_eq!(log[0]["state"], "open");
    assert_eq!(log[0]["cause"], "pat");
    assert!(log[0]["time_s"].as_f64().is_some());
}

#[test]
fn mistakes_get_a_message_not_a_panic() {
    for (args, expected) in [
        (&["grasp", "--object", "piano"][..], "no object \"piano\": choose trash_bin"),
        (&["grasp", "--config", "/nonexistent/grasp.toml"][..], "cannot read /nonexistent/grasp.toml"),
    ] {
        let out = skin(args);
        assert!(!out.status.success());
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains(expected), "{args:?}: {err}");
        assert!(!err.contains("panicked"), "{err}");
    }
}
