//! Our RIHS01 type hashes equal the ones rosbags computes: from its own
//! Jazzy type store for the core types, from our definition text for
//! `skin_msgs/Datagram` (which checks the text and the hash agree). And
//! every kind of message we encode decodes, in rosbags and in
//! mcap-ros2-support, into the values we put in.

mod common;

use std::collections::BTreeMap;

use skin_host::ros::schema::{ALL, DATAGRAM};

#[test]
fn type_hashes_equal_those_of_rosbags() {
    let Some(python) = common::python() else { return };
    let ours: BTreeMap<&str, (String, String)> =
        ALL.iter().chain([&&DATAGRAM]).map(|t| (t.name, (t.rihs01(), t.ros2msg()))).collect();
    let file = std::env::temp_dir().join(format!("skin-ros-types-{}.json", std::process::id()));
    std::fs::write(&file, serde_json::to_string(&ours).unwrap()).unwrap();
    let theirs = common::run_json(&python, "check_hashes.py", &[&file]);
    let _ = std::fs::remove_file(&file);
    for (name, (hash, _)) in &ours {
        assert_eq!(theirs[name][0].as_str(), Some(hash.as_str()), "{name} ({})", theirs[name][1]);
    }
    let from_store = ours.keys().filter(|n| theirs[**n][1] == "rosbags jazzy store").count();
    assert_eq!(from_store, ALL.len(), "every core type is in rosbags' own store");
}

/// One message of every kind the skin publishes, written by our encoder,
/// comes back from both Python readers with the values put in.
#[test]
fn every_message_kind_decodes_in_both_readers_with_its_values() {
    use skin_host::recording::McapWriter;
    use skin_host::ros::msgs::*;

    let Some(python) = common::python() else { return };
    let file = std::env::temp_dir().join(format!("skin-ros-kinds-{}.mcap", std::process::id()));
    let header = |frame: &str| Header { stamp: Stamp { sec: 12, nanosec: 345 }, frame_id: frame.into() };
    let mut w = McapWriter::create(&file).unwrap();
    let marker = Marker {
        header: header("skin_cell_7"),
        ns: "skin/force/Force0".into(),
        id: 7,
        kind: SPHERE,
        action: ADD,
        position: [0.1, 0.2, 0.3],
        scale: [0.03; 3],
        color: [1.0, 0.5, 0.25, 0.75],
        lifetime: Stamp { sec: 1, nanosec: 2 },
        text: "cell 7".into(),
    };
    w.write("/m", 1, &MarkerArray(vec![marker.clone(), Marker { id: 8, action: DELETE, ..marker }])).unwrap();
    w.write("/i", 2, &Imu { header: header("skin_cell_3"), linear_acceleration: [0.5, -9.8, 1.25] }).unwrap();
    let names = vec!["a".to_owned(), "b".to_owned()];
    w.write("/j", 3, &JointState { header: header(""), name: names, position: vec![0.5, -1.5] }).unwrap();
    let tf = TransformStamped {
        header: header("skin_part_2"),
        child_frame_id: "skin_cell_9".into(),
        translation: [1.0, 2.0, 3.0],
        rotation: [0.0, 0.0, 0.6, 0.8],
    };
    w.write("/tf", 4, &TfMessage(vec![tf])).unwrap();
    w.write("/s", 5, &StringMsg("<robot/>".into())).unwrap();
    let field = PointField { name: "force", offset: 0, datatype: FLOAT32, count: 1 };
    let cloud =
        PointCloud2 { header: header("p"), fields: vec![field], point_step: 4, data: 2.5f32.to_le_bytes().to_vec() };
    w.write("/c", 6, &cloud).unwrap();
    w.write("/d", 7, &Datagram { stamp: Stamp { sec: 0, nanosec: 9 }, source: "127.0.0.1:1", data: &[9, 8] }).unwrap();
    w.finish().unwrap();
    let out = common::run_json(&python, "dump_messages.py", &[&file]);
    let _ = std::fs::remove_file(&file);
    for reader in ["rosbags", "mcap_ros2"] {
        let got = &out[reader];
        let m = &got["/m"][0]["markers"];
        assert_eq!(m.as_array().map(Vec::len), Some(2), "{reader}: {got}");
        assert_eq!(
            (&m[0]["ns"], &m[0]["id"], &m[0]["type"], &m[0]["action"]),
            (&"skin/force/Force0".into(), &7.into(), &2.into(), &0.into()),
            "{reader}"
        );
        assert_eq!((&m[1]["id"], &m[1]["action"], &m[0]["text"]), (&8.into(), &2.into(), &"cell 7".into()), "{reader}");
        assert_eq!(m[0]["pose"]["position"]["z"], 0.3, "{reader}");
        assert_eq!(m[0]["pose"]["orientation"]["w"], 1.0, "{reader}");
        assert_eq!(m[0]["color"]["b"], 0.25, "{reader}");
        assert_eq!((&m[0]["lifetime"]["sec"], &m[0]["lifetime"]["nanosec"]), (&1.into(), &2.into()), "{reader}");
        assert_eq!(m[0]["header"]["stamp"]["nanosec"], 345, "{reader}");
        let imu = &got["/i"][0];
        assert_eq!(imu["linear_acceleration"]["y"], -9.8, "{reader}");
        assert_eq!(imu["orientation_covariance"][0], -1.0, "{reader}: orientation unknown");
        assert_eq!(imu["header"]["frame_id"], "skin_cell_3", "{reader}");
        assert_eq!(got["/j"][0]["name"], serde_json::json!(["a", "b"]), "{reader}");
        assert_eq!(got["/j"][0]["position"], serde_json::json!([0.5, -1.5]), "{reader}");
        let t = &got["/tf"][0]["transforms"][0];
        assert_eq!(
            (&t["child_frame_id"], &t["transform"]["rotation"]["z"]),
            (&"skin_cell_9".into(), &0.6.into()),
            "{reader}"
        );
        assert_eq!(t["transform"]["translation"]["y"], 2.0, "{reader}");
        assert_eq!(got["/s"][0]["data"], "<robot/>", "{reader}");
        let c = &got["/c"][0];
        assert_eq!(
            (&c["width"], &c["row_step"], &c["fields"][0]["name"]),
            (&1.into(), &4.into(), &"force".into()),
            "{reader}"
        );
        assert_eq!(c["data"], serde_json::json!(2.5f32.to_le_bytes()), "{reader}");
        assert_eq!(
            (&got["/d"][0]["source"], &got["/d"][0]["data"]),
            (&"127.0.0.1:1".into(), &serde_json::json!([9, 8])),
            "{reader}"
        );
    }
}
