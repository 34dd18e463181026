//! The `skin-sim network` command: JSON fields, summaries, and clear
//! errors with a non-zero exit for bad flags and files.

use std::process::Command;

fn skin_sim(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_skin-sim")).args(args).output().unwrap()
}

#[test]
fn json_has_every_field_the_issue_asks_for() {
    let out = skin_sim(&["network", "--topology", "hex:3x3", "--interfaces", "2", "--duration", "0.2", "--json"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    for field in [
        "cells",
        "interfaces",
        "ids_unique",
        "neighbours_correct",
        "organize_time_s",
        "max_tree_depth",
        "delivered",
        "dropped",
        "corrupt_rejected",
        "latency_us",
        "max_cells_per_interface_at_rate",
        "sim_time_s",
        "wall_time_s",
    ] {
        assert!(v.get(field).is_some(), "no `{field}` in {v}");
    }
    for q in ["p50", "p99", "max"] {
        assert!(v["latency_us"][q].is_u64(), "latency_us.{q}");
    }
    assert_eq!(v["cells"], 9);
    assert_eq!(v["ids_unique"], true);
}

#[test]
fn a_summary_for_people_with_faults() {
    let out = skin_sim(&[
        "network",
        "--topology",
        "hex:3x3+hex:2x2",
        "--interfaces",
        "2",
        "--traffic",
        "event",
        "--stimulus",
        "touch",
        "--duration",
        "0.3",
        "--fault",
        "reboot:2@0.1",
        "--fault",
        "ber:1e-5",
        "--delta",
        "proximity=655",
        "--keepalive-ms",
        "50",
        "--beacon-ms",
        "20",
        "--seed",
        "7",
    ]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(
        text.starts_with(
            "13 cells, 2 interface ports, 250 Hz event traffic, touch skin, seed 7; keep-alive every 50 ms, beacons every 20 ms"
        ),
        "{text}"
    );
}

#[test]
fn bad_flags_and_files_fail_with_a_message() {
    for (args, says) in [
        (vec!["network", "--topology", "hex:3x3"], "--duration"),
        (vec!["network", "--topology", "hex:3", "--duration", "1"], "hex:ROWSxCOLS"),
        (
            vec!["network", "--topology", "chain:4294967296", "--duration", "1"],
            "4294967296 cells; a skin has 1..=60000",
        ),
        (vec!["network", "--topology", "none.toml", "--duration", "1"], "none.toml"),
        (vec!["network", "--topology", "hex:2x2", "--duration", "1", "--traffic", "burst"], "burst"),
        (vec!["network", "--topology", "hex:2x2", "--duration", "1", "--fault", "melt:1@1"], "cut:CELL.PORT"),
        (vec!["network", "--topology", "hex:2x2", "--duration", "1", "--fault", "dead:99@0"], "no such"),
        (vec!["network", "--topology", "hex:2x2", "--duration", "1", "--rate", "0"], "rate"),
        (vec!["network", "--topology", "hex:2x2", "--duration", "-1"], "duration"),
        (
            vec!["network", "--topology", "hex:2x2", "--duration", "1e300"],
            "--duration 1e300: give a number of seconds in [0, 1e9]",
        ),
        (
            vec!["network", "--topology", "hex:2x2", "--duration", "1", "--organize-timeout", "1e300"],
            "--organize-timeout 1e300: give a number of seconds in [0, 1e9]",
        ),
        (
            vec!["network", "--topology", "hex:2x2", "--duration", "1", "--fault", "dead:1@1e300"],
            "the time must be in [0, 1e9] s",
        ),
        (vec!["network", "--topology", "hex:2x2", "--duration", "1", "--keepalive-ms", "1e300"], "--keepalive-ms"),
        (vec!["network", "--topology", "hex:1x1", "--duration", "1", "--interfaces", "9"], "free ports"),
        (vec!["network", "--topology", "hex:2x2", "--duration", "1", "--udp", "10.1.2.3:9"], "127.0.0.1"),
        (vec!["network", "--topology", "hex:2x2", "--duration", "1", "--delta", "nose=3"], "CHANNEL=COUNTS"),
        (vec!["network", "--topology", "hex:2x2", "--duration", "1", "--delta", "force0=-1"], "CHANNEL=COUNTS"),
        (vec!["network", "--topology", "hex:2x2", "--duration", "1", "--keepalive-ms", "0"], "--keepalive-ms"),
        (vec!["network", "--topology", "hex:2x2", "--duration", "1", "--beacon-ms", "0.5"], "beacon period"),
        (vec!["network", "--topology", "hex:2x2", "--duration", "1", "--keepalive-ms", "NaN"], "--keepalive-ms"),
    ] {
        let out = skin_sim(&args);
        assert!(!out.status.success(), "{args:?} succeeded");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains(says), "{args:?}: {err}");
        assert!(!err.contains("panicked"), "{args:?}: {err}");
    }
}
