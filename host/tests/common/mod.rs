//! The Python readers we did not write (rosbags, mcap-ros2-support,
//! eclipse-zenoh, websockets with protobuf), as `cargo xtask install` puts them in a venv under the
//! target directory; and the programs the tests start.

use std::ffi::OsStr;
use std::io::{BufRead, BufReader, Read};
use std::net::UdpSocket;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::thread::JoinHandle;

#[allow(dead_code, reason = "the rclpy tests' helpers; the other tests share this module")]
pub mod rclpy;

/// The skin's live topics and their types, as every middleware publishes them.
#[allow(dead_code, reason = "the live tests' table; the other tests share this module")]
pub const TOPIC_TYPES: [(&str, &str); 6] = [
    ("/skin/cells", "sensor_msgs/msg/PointCloud2"),
    ("/joint_states", "sensor_msgs/msg/JointState"),
    ("/skin/imu", "sensor_msgs/msg/Imu"),
    ("/skin/events", "visualization_msgs/msg/MarkerArray"),
    ("/tf_static", "tf2_msgs/msg/TFMessage"),
    ("/robot_description", "std_msgs/msg/String"),
];

/// The cargo target directory, where `cargo xtask install` puts the venvs.
pub fn target_dir() -> PathBuf {
    std::env::var_os("CARGO_TARGET_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join("../target"))
}

#[allow(dead_code, reason = "the Python readers' helper; the rclpy tests share this module")]
/// The venv's Python, or `None` (after saying so loudly) when this
/// machine has no Python at all. A machine with Python but without the
/// venv fails: the readers are part of the test setup.
pub fn python() -> Option<PathBuf> {
    let target = target_dir();
    let venv = target.join("pyenv/bin/python");
    if venv.exists() {
        return Some(venv);
    }
    if Command::new("python3").arg("--version").output().is_err() {
        eprintln!("\n*** SKIPPED: no python3 on this machine, the ROS 2 file checks by rosbags and mcap-ros2-support did not run ***\n");
        return None;
    }
    panic!(
        "{} is missing: run `cargo xtask install` (it installs rosbags, mcap-ros2-support and eclipse-zenoh there)",
        venv.display()
    );
}

#[allow(dead_code, reason = "the Python readers' helper; the rclpy tests share this module")]
/// Runs `script` (in tests/python) with `args`; its stdout as JSON.
pub fn run_json(python: &Path, script: &str, args: &[&Path]) -> serde_json::Value {
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/python").join(script);
    let out = Command::new(python).arg(&script).args(args).output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{} failed: {stderr}", script.display());
    serde_json::from_slice(&out.stdout)
        .unwrap_or_else(|e| panic!("{} printed no JSON ({e}): {stderr}", script.display()))
}

/// `skin ARGS` with piped output, once a line of its stderr contains
/// `marker`: the child, that line, and a thread draining the rest of
/// stderr (so the run never blocks on it) that returns it.
#[allow(dead_code, reason = "the live tests' helper; the other tests share this module")]
pub fn spawn_announcing(args: &[&OsStr], marker: &str) -> (Child, String, JoinHandle<String>) {
    announcing(Command::new(env!("CARGO_BIN_EXE_skin")).args(args), marker)
}

/// [`spawn_announcing`] of any command.
#[allow(dead_code, reason = "the live tests' helper; the other tests share this module")]
pub fn announcing(command: &mut Command, marker: &str) -> (Child, String, JoinHandle<String>) {
    let mut child = command.stdout(Stdio::piped()).stderr(Stdio::piped()).spawn().unwrap();
    let mut stderr = BufReader::new(child.stderr.take().unwrap());
    let mut announced = String::new();
    while !announced.contains(marker) {
        announced.clear();
        assert!(stderr.read_line(&mut announced).unwrap() > 0, "the program ended without announcing {marker:?}");
    }
    let drain = std::thread::spawn(move || {
        let mut rest = String::new();
        let _ = stderr.read_to_string(&mut rest);
        rest
    });
    (child, announced, drain)
}

/// A loopback UDP address nobody listens on, for a program about to be
/// started to bind: a port below the kernel's ephemeral range, so that no
/// socket bound to port 0 meanwhile (by the programs started first, DDS
/// participants among them) can take it first, as one freed in that range
/// can. (The tests' ROS domains, 100 and up, put DDS's own ports above
/// 32400.)
#[allow(dead_code, reason = "the CLI tests' helper; the other tests share this module")]
pub fn free_addr() -> String {
    let low = std::fs::read_to_string("/proc/sys/net/ipv4/ip_local_port_range")
        .ok()
        .and_then(|r| r.split_whitespace().next()?.parse::<u16>().ok())
        .unwrap_or(32768);
    // Under the ephemeral range, above the well-known ports the tests'
    // middlewares use (DDS from 7400, Zenoh's 7446 and 7447).
    let (from, to) = (20_000, low.min(32_000));
    // A fresh RandomState hashes with new random keys.
    let random = || std::hash::BuildHasher::hash_one(&std::collections::hash_map::RandomState::new(), 0);
    let tries = if from < to { 1000 } else { 0 };
    for _ in 0..tries {
        let port = from + (random() % u64::from(to - from)) as u16;
        if let Ok(socket) = UdpSocket::bind(("127.0.0.1", port)) {
            return socket.local_addr().unwrap().to_string();
        }
    }
    UdpSocket::bind("127.0.0.1:0").unwrap().local_addr().unwrap().to_string()
}
