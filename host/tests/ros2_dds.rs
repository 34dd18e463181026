//! ROS 2 over DDS, checked by the real ROS 2 client library on the real
//! default middleware: while `skin demo --quick --ros2` publishes, an
//! rclpy node on Fast DDS (rmw_fastrtps_cpp) subscribes to every topic,
//! reads the graph, and a second node joins late to get the
//! transient-local `/robot_description`. All in a domain of the test's own,
//! on loopback.

mod common;

use std::ffi::OsStr;

use common::rclpy::{self, Domain};
use serde_json::Value;

/// The streams (the cloud, joint states, IMU), and how many messages of
/// each the checker waits for.
const STREAMS: [&str; 3] = ["/skin/cells", "/joint_states", "/skin/imu"];
const PER_STREAM: u64 = 10;

#[test]
fn rclpy_on_fast_dds_sees_the_demo_as_a_ros_2_node() {
    let Some(python) = rclpy::python() else { return };
    let domain = Domain::unique();
    let dir = std::env::temp_dir().join(format!("skin-ros2-dds-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    // rclpy first, the demo once its subscriptions exist (rclpy says
    // "ready"): started side by side, a cold start once brought rclpy up
    // after the demo's first announcements, and it did not hear the
    // whole quick demo in time.
    let count = PER_STREAM.to_string();
    let checker_args: Vec<&str> = ["120", &count].into_iter().chain(STREAMS).collect();
    let (checker, _, checker_log) =
        common::announcing(&mut domain.python(&python, "ros2_dds.py", &checker_args), "ready");
    let id = domain.0.to_string();
    let args =
        ["demo", "--quick", "--no-record", "--json", "--ros2", "--imu", "--ros-domain", &id, "--out"].map(OsStr::new);
    let (demo, announced, drain) = domain.spawn_skin(&[&args[..], &[dir.as_os_str()]].concat(), "ROS 2 over DDS:");
    assert!(announced.contains(&format!("node /skin in domain {id}, on this host only")), "{announced}");
    let out = demo.wait_with_output().unwrap();
    let rest = drain.join().unwrap();
    assert!(out.status.success(), "the demo failed: {rest}");
    let mut finished = checker.wait_with_output().unwrap();
    finished.stderr = checker_log.join().unwrap().into_bytes();
    let got = rclpy::json_of("ros2_dds.py", &finished);
    // /skin/imu is subscribed best effort (REP 2003's sensor data): a
    // reliable subscription stalled for good after a handful of messages
    // in 1 of 24 runs, its writer's window full (the log: WouldBlock).
    assert_eq!(
        got["missing"],
        serde_json::json!([]),
        "rclpy did not hear it all before the demo ended: {}\nthe graph: {}\nthe demo's log: {rest}",
        got["live"],
        got["graph"]
    );

    assert_eq!(got["rmw"], "rmw_fastrtps_cpp", "the checker runs on Fast DDS");
    // The graph: the node, its publishers with their types, and their QoS.
    let graph = &got["graph"];
    assert!(graph["nodes"].as_array().unwrap().iter().any(|n| n == "/skin"), "{graph}");
    let types = common::TOPIC_TYPES;
    for (topic, ty) in types {
        let listed = graph["skin_publishers"].as_array().unwrap();
        assert!(
            listed.iter().any(|p| p[0] == topic && p[1] == serde_json::json!([ty])),
            "/skin publishes {topic}: {listed:?}"
        );
        let qos = graph["qos"][topic].as_array().unwrap();
        assert_eq!(qos.len(), 1, "one publisher of /skin on {topic}: {qos:?}");
        assert_eq!(qos[0]["node"], "/skin");
        assert_eq!(qos[0]["type"], ty);
        assert_eq!(qos[0]["reliability"], "RELIABLE", "{topic}");
        let durability =
            if matches!(topic, "/tf_static" | "/robot_description") { "TRANSIENT_LOCAL" } else { "VOLATILE" };
        assert_eq!(qos[0]["durability"], durability, "{topic}");
    }

    // The messages, decoded by rclpy's own type support.
    let live = |topic: &str| -> &Value {
        got["live"].get(topic).unwrap_or_else(|| panic!("rclpy heard nothing on {topic}: {}", got["live"]))
    };
    let cells = &live("/skin/cells")["last"];
    assert_eq!(cells["points"], 74, "{cells}");
    assert_eq!(cells["bytes"], 74 * 40);
    assert_eq!(
        cells["fields"],
        serde_json::json!(["x", "y", "z", "proximity", "force", "temperature", "ax", "ay", "az", "id"])
    );
    assert_eq!(cells["frame"], "skin_part_0");
    let joints = &live("/joint_states")["last"];
    assert_eq!((joints["joints"].as_u64(), joints["positions"].as_u64()), (Some(14), Some(14)), "{joints}");
    assert_eq!(joints["finite"], true);
    // The first, heard while the skin organizes and the robot stands
    // still: the checker stops listening at any moment, and a cell on an
    // arm the exploration moves felt 1.77 g when it stopped.
    let g = live("/skin/imu")["first"]["g"].as_f64().unwrap();
    assert!((0.5..1.5).contains(&g), "a still cell feels about 1 g, not {g} g");
    assert!(live("/skin/imu")["last"]["frame"].as_str().unwrap().starts_with("skin_cell_"));
    assert!(live("/skin/events")["first"]["markers"].as_u64().unwrap() > 0);
    // A stream, not one message: the cloud and joint states many times.
    for topic in STREAMS {
        assert!(live(topic)["count"].as_u64().unwrap() >= PER_STREAM, "{topic}: {}", live(topic));
    }

    // The late joiner got the one cached description, exactly once.
    let late = &got["late"]["/robot_description"];
    assert_eq!(late["count"], 1, "late joiner: {}", got["late"]);
    assert_eq!(late["first"]["start"], "<?xml version=\"1.0\"?>");
    assert_eq!(late["first"]["end"], "</robot>\n");
    let (median, p99) = rclpy::latency(&got, "rclpy's callback over DDS");
    assert!(0.0 < median && median <= p99, "a message is received after it is stamped");
    let _ = std::fs::remove_dir_all(&dir);
}
