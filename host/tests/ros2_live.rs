//! ROS 2 over Zenoh, checked by a subscriber we did not write: `skin demo
//! --quick --ros2 --ros2-middleware zenoh` publishes while a Python `eclipse-zenoh` peer (multicast
//! off, connecting to the endpoint the demo prints) subscribes on
//! rmw_zenoh's key expressions, decodes every topic's CDR with rosbags,
//! reads the attachments, collects the liveliness tokens, and joins late
//! to fetch the transient-local topics from the publishers' caches.

mod common;

use std::ffi::OsStr;

use serde_json::Value;
use skin_host::ros::rmw_zenoh::keys;

#[test]
fn a_zenoh_peer_sees_the_demo_as_rmw_zenoh_publishes() {
    let Some(python) = common::python() else { return };
    let dir = std::env::temp_dir().join(format!("skin-ros2-live-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let args = ["demo", "--quick", "--no-record", "--json", "--ros2", "--ros2-middleware", "zenoh", "--imu", "--out"]
        .map(OsStr::new);
    let (demo, announced, drain) =
        common::spawn_announcing(&[&args[..], &[dir.as_os_str()]].concat(), "ROS 2 over Zenoh:");
    let words: Vec<&str> = announced.split_whitespace().collect();
    let zid = words[words.iter().position(|w| *w == "peer").unwrap() + 1].to_owned();
    let endpoint = words.iter().find(|w| w.starts_with("tcp/127.0.0.1:")).expect("a loopback endpoint").to_string();

    let got = common::run_json(&python, "ros2_live.py", &[endpoint.as_ref(), "120".as_ref()]);
    let out = demo.wait_with_output().unwrap();
    let rest = drain.join().unwrap();
    assert!(out.status.success(), "the demo failed: {rest}");
    let report: Value = serde_json::from_slice(&out.stdout).unwrap();
    assert!(report["exploration"]["body_parts"].as_array().is_some_and(|p| !p.is_empty()));

    assert!(
        got["peers"].as_array().unwrap().iter().any(|p| p == zid.as_str()),
        "the subscriber's peer is our node: {got}"
    );
    // The transient-local topics are checked as the late joiner got them
    // (the live subscriber may have joined after they were sent).
    let latched = |topic: &str| topic == "/tf_static" || topic == "/robot_description";
    let one = |topic: &str| -> &Value {
        let heard = if latched(topic) { &got["late"] } else { &got["topics"] };
        let entries = heard.get(topic).and_then(Value::as_array).unwrap_or_else(|| panic!("{topic} not heard: {got}"));
        assert_eq!(entries.len(), 1, "{topic} on one key only: {entries:?}");
        &entries[0]
    };
    let types = common::TOPIC_TYPES;
    let tokens: Vec<&str> = got["tokens"].as_array().unwrap().iter().map(|t| t.as_str().unwrap()).collect();
    assert!(tokens.contains(&format!("@ros2_lv/0/{zid}/0/0/NN/%/%/skin").as_str()), "the node's token: {tokens:?}");
    let mut gids = Vec::new();
    let mut counted_by_one = false;
    for (topic, ty) in types {
        let t = one(topic);
        assert_eq!(t["type"], ty, "{t}");
        assert_eq!(t["domain"], "0");
        assert_eq!(t["hash"], t["rosbags_hash"], "our RIHS01 hash of {ty} is rosbags'");
        let dds = keys::dds_type_name_of(ty);
        assert_eq!(t["key"], format!("0{topic}/{dds}/{}", t["hash"].as_str().unwrap()));
        // The publisher's token names the topic, its type and hash, and its QoS.
        let token = tokens
            .iter()
            .find(|k| {
                k.starts_with(&format!("@ros2_lv/0/{zid}/0/"))
                    && k.contains(&format!("/MP/%/%/skin/{}/", topic.replace('/', "%")))
            })
            .unwrap_or_else(|| panic!("no publisher token for {topic}: {tokens:?}"));
        let qos = if latched(topic) { ":1:,1:,:,:,," } else { "::,10:,:,:,," };
        assert!(token.ends_with(&format!("/{dds}/{}/{qos}", t["hash"].as_str().unwrap())), "{token}");
        // Attachments: sequence numbers counting up, a recent source time,
        // and the GID rmw_zenoh derives from the token. A keep-last topic
        // drops rather than blocks under congestion (as rmw_zenoh does),
        // so a loaded machine may lose messages (one run lost 71 at the
        // start): the numbers never go back or repeat, and where two
        // arrivals in a row differ by one they count each message.
        let attachments = t["attachments"].as_array().unwrap();
        assert!(!attachments.is_empty() && attachments.iter().all(|a| !a.is_null()), "{topic}: {attachments:?}");
        let seqs: Vec<i64> = attachments.iter().map(|a| a["seq"].as_i64().unwrap()).collect();
        assert!(seqs.windows(2).all(|w| w[1] > w[0]), "{topic}: {seqs:?}");
        counted_by_one |= seqs.windows(2).any(|w| w[1] == w[0] + 1);
        let now_ns = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).unwrap().as_nanos() as i64;
        let stamp = attachments[0]["stamp_ns"].as_i64().unwrap();
        assert!((now_ns - 600_000_000_000..=now_ns).contains(&stamp), "{topic}: source time {stamp}");
        let gid: String = keys::gid(token).iter().map(|b| format!("{b:02x}")).collect();
        assert!(attachments.iter().all(|a| a["gid"] == gid.as_str()), "{topic}: {attachments:?} vs {gid}");
        gids.push(gid);
    }
    assert!(counted_by_one, "no topic's sequence numbers counted up by one: {got}");
    gids.sort();
    gids.dedup();
    assert_eq!(gids.len(), types.len(), "one GID per publisher");

    let v = |topic: &str| &one(topic)["values"];
    assert_eq!(v("/skin/cells")["points"], 74, "{}", v("/skin/cells"));
    assert_eq!(v("/joint_states")["joints"], 14);
    assert_eq!(v("/tf_static")["frames"], 74);
    assert_eq!(v("/robot_description")["start"], "<?xml version=\"1.0\"?>");
    assert!(v("/skin/events")["markers"].as_u64().unwrap() > 0);
    let g = v("/skin/imu")["g"].as_f64().unwrap();
    assert!((0.5..1.5).contains(&g), "a cell feels about 1 g, not {g} g");
    // The late joiner got exactly the one cached message of each.
    for topic in ["/tf_static", "/robot_description"] {
        assert_eq!(one(topic)["count"], 1, "late joiner on {topic}: {}", got["late"]);
    }
    let (median, p99) = common::rclpy::latency(&got, "a Python zenoh peer's callback");
    assert!(0.0 < median && median <= p99, "a message is received after it is stamped");
    std::fs::remove_dir_all(&dir).unwrap();
}
