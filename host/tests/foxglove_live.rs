//! The live Foxglove view, checked by a client we did not write: `skin
//! demo --quick --foxglove 127.0.0.1:0` serves while a Python client (the
//! `websockets` package, speaking Foxglove's WebSocket protocol) reads
//! serverInfo and advertise, subscribes to every channel, sends malformed
//! messages, and decodes what comes with the advertised schemas (protobuf
//! through google.protobuf's descriptor pool, JSON) until the demo ends.

mod common;

use std::collections::HashSet;
use std::ffi::OsStr;

use serde_json::Value;

#[test]
fn a_foxglove_client_sees_the_demo_live() {
    let Some(python) = common::python() else { return };
    let dir = std::env::temp_dir().join(format!("skin-foxglove-live-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let args = ["demo", "--quick", "--no-record", "--json", "--foxglove", "127.0.0.1:0", "--out"].map(OsStr::new);
    let (demo, announced, drain) =
        common::spawn_announcing(&[&args[..], &[dir.as_os_str()]].concat(), "Foxglove: live view on ");
    let url = announced.split_whitespace().find(|w| w.starts_with("ws://127.0.0.1:")).expect("a loopback URL");
    assert!(!url.ends_with(":0"), "the port the OS picked is announced: {announced}");

    let got = common::run_json(&python, "foxglove_live.py", &[url.as_ref(), "900".as_ref()]);
    let out = demo.wait_with_output().unwrap();
    let rest = drain.join().unwrap();
    assert!(out.status.success(), "the demo failed: {rest}");
    let report: Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(got["closed_by_server"], true, "the client listened until the demo ended: {got}");
    assert!(rest.contains("Foxglove view: ") && rest.contains(" scenes sent; dropped: "), "{rest}");

    // The handshake, the server's info and its channels, in Foxglove's schemas.
    assert_eq!(got["subprotocol"], "foxglove.sdk.v1");
    assert_eq!(got["server_info"]["name"], "skin");
    for (topic, encoding, schema) in [
        ("/skin/scene", "protobuf", "foxglove.SceneUpdate"),
        ("/skin/robot", "protobuf", "foxglove.SceneUpdate"),
        ("/tf", "protobuf", "foxglove.FrameTransforms"),
        ("/skin/log", "protobuf", "foxglove.Log"),
        ("/skin/grasp", "json", "skin.GraspState"),
    ] {
        let c = &got["channels"][topic];
        assert_eq!((c["encoding"].as_str(), c["schemaName"].as_str()), (Some(encoding), Some(schema)), "{topic}: {c}");
    }

    // The cells: every organized cell once, in world, spread over the learned tree.
    let scene = &got["scene"];
    let best = &scene["best"];
    let organized: HashSet<u64> =
        report["organization"]["cells"].as_array().unwrap().iter().map(|c| c["id"].as_u64().unwrap()).collect();
    let ids: Vec<u64> = best["ids"].as_array().unwrap().iter().map(|i| i.as_u64().unwrap()).collect();
    assert_eq!(ids.len(), 74, "{best}");
    assert_eq!(ids.iter().copied().collect::<HashSet<u64>>(), organized, "the cubes are the organized cells");
    assert!(ids.windows(2).all(|w| w[0] < w[1]), "in ID order: {ids:?}");
    assert_eq!(best["force"].as_array().unwrap().len(), 74);
    assert_eq!(best["frame"], "world");
    let cubes = best["cubes"].as_array().unwrap();
    assert_eq!(cubes.last().unwrap()["count"], 74);
    for c in &cubes[..cubes.len() - 1] {
        let rgb: Vec<f64> = c["rgb"].as_array().unwrap().iter().map(|v| v.as_f64().unwrap()).collect();
        assert!(rgb.iter().all(|v| (0.0..=1.0).contains(v)), "{c}");
        assert!(c["height"].as_f64().unwrap() > 0.0, "{c}");
    }
    assert!(best["spread_m"].as_f64().unwrap() > 0.3, "the cells sit on the learned tree's parts: {best}");
    // During the grasp the arms felt the object: cells turned red under
    // force and contacts showed; the approach turned cells blue.
    assert!(scene["red_max"].as_u64().unwrap() > 0, "{scene}");
    assert!(scene["blue_max"].as_u64().unwrap() > 0, "{scene}");
    assert!(scene["contacts_max"].as_u64().unwrap() > 0, "{scene}");

    // The robot: one frame per learned body part, a bone per joint between parts.
    let parts = report["exploration"]["body_parts"].as_array().unwrap().len() as u64;
    assert!(parts > 2);
    assert_eq!(got["robot"]["frames_max"], parts, "{}", got["robot"]);
    assert_eq!(got["robot"]["bone_points_max"], 2 * (parts - 1), "{}", got["robot"]);
    assert_eq!(got["tf"]["frames_max"], parts);
    assert_eq!(got["tf"]["parents"], serde_json::json!(["world"]));

    // Tactile events and the grasp as they happened.
    assert!(got["logs"]["count"].as_u64().unwrap() > 0, "{}", got["logs"]);
    assert!(got["logs"]["first"].as_array().unwrap().iter().all(|l| l.as_str().unwrap().contains(" level ")));
    let states: Vec<&str> = got["grasp"].as_array().unwrap().iter().map(|g| g["state"].as_str().unwrap()).collect();
    assert_eq!(got["grasp"][0]["from"], "home", "{}", got["grasp"]);
    assert_eq!(got["grasp"][0]["cause"], "pat");
    for state in ["open", "approach", "hold", "release"] {
        assert!(states.contains(&state), "{state} in {states:?}");
    }

    // A broken client was told so (one status per bad message) and kept being served.
    assert_eq!(got["status"].as_array().map(Vec::len), Some(5), "{}", got["status"]);
    assert!(got["after_junk"].as_u64().unwrap() > 0);
    std::fs::remove_dir_all(&dir).unwrap();
}
