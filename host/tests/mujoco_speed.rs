//! How fast the MuJoCo endpoint runs the HRP-2-like upper body with its
//! 74 cells in lockstep, and where its time goes (MuJoCo, sensor models,
//! cell network, sockets, the host): `skin sim-endpoint --mujoco` (the
//! built-in robot written as MJCF, wearing its own skin on its five
//! interface ports), organized and explored by `skin run` over UDP.
//! Ignored: it needs the release build's speed and prints figures
//! (`cargo test --release -p skin-host --features mujoco --test mujoco_speed -- --ignored --nocapture`).

mod common;

use std::io::{BufRead, Read};
use std::process::{Command, Stdio};

use common::free_addr;

/// The seconds after `label` in `line` ("robot time in 2.18 s").
fn seconds_after(line: &str, label: &str) -> f64 {
    let rest = &line[line.find(label).unwrap_or_else(|| panic!("no {label:?} in {line}")) + label.len()..];
    rest.trim_start().split(' ').next().and_then(|s| s.parse().ok()).unwrap_or_else(|| panic!("{line}"))
}

#[test]
#[ignore]
fn the_mujoco_endpoint_serves_the_hrp2_like_body_and_says_where_its_time_goes() {
    let dir = std::env::temp_dir().join(format!("skin-mujoco-speed-{}", std::process::id()));
    let (robot, host) = (free_addr(), free_addr());
    let mut served = Command::new(env!("CARGO_BIN_EXE_skin"))
        .args(["sim-endpoint", "--mujoco", "--robot", &robot, "--host", &host])
        // Long enough for the run; the endpoint then says where its time went.
        .args(["--duration", "30"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("the skin binary runs");
    let mut line = String::new();
    std::io::BufReader::new(served.stdout.take().unwrap()).read_line(&mut line).unwrap();
    assert!(line.starts_with("serving the MuJoCo robot"), "{line}");
    let ports = line.split("interface ports ").nth(1).unwrap().split(" send to").next().unwrap().split(", ").count();
    assert_eq!(ports, 5, "{line}");
    let out = Command::new(env!("CARGO_BIN_EXE_skin"))
        .args(["run", "--robot", &robot, "--interface", &host, "--json"])
        .args(["--out", dir.join("report").to_str().unwrap()])
        .output()
        .expect("the skin binary runs");
    let mut err = String::new();
    served.stderr.take().unwrap().read_to_string(&mut err).unwrap();
    let _ = served.wait();
    let time = err.lines().find(|l| l.starts_with("time: ")).unwrap_or_else(|| panic!("{err}"));
    let (robot_s, serving_s) = (seconds_after(time, "time:"), seconds_after(time, "robot time in"));
    assert!(robot_s > 0.0 && serving_s > 0.0, "{time}");
    println!("{time}");
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap_or_default();
    let count = |key: &str| report["exploration"][key].as_array().map_or(0, Vec::len);
    println!(
        "{:.1}x real time; skin run {}: {} cells, {} body parts, {} joints; {}",
        robot_s / serving_s,
        if out.status.success() { "explored" } else { "stopped" },
        count("cells"),
        count("body_parts"),
        count("joints"),
        String::from_utf8_lossy(&out.stderr).lines().last().unwrap_or_default()
    );
    let _ = std::fs::remove_dir_all(&dir);
}
