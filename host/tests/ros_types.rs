//! Our RIHS01 type hashes equal the ones rosbags computes: from its own
//! Jazzy type store for the core types, from our definition text for
//! `skin_msgs/Datagram` (which checks the text and the hash agree).

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
