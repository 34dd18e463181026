//! How fast the MuJoCo endpoint runs the HRP-2-like upper body in
//! lockstep, and where its time goes: the built-in robot's own URDF loaded
//! by MuJoCo (the same links, DoFs and limits), four cells per body laid in
//! wired patches, explored by `skin run` over UDP. Ignored: it needs the
//! release build's speed and prints figures rather than checking them
//! (`cargo test --release -p skin-host --features mujoco --test mujoco_speed -- --ignored --nocapture`).

use std::io::{BufRead, Read};
use std::net::UdpSocket;
use std::process::{Command, Stdio};

fn free_addr() -> String {
    UdpSocket::bind("127.0.0.1:0").unwrap().local_addr().unwrap().to_string()
}

#[test]
#[ignore]
fn the_mujoco_endpoint_serves_the_hrp2_like_body_faster_than_real_time() {
    let dir = std::env::temp_dir().join(format!("skin-mujoco-speed-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let urdf = dir.join("hrp2-like.urdf");
    std::fs::write(&urdf, skin_model::robot::hrp2::urdf()).unwrap();
    let (robot, host) = (free_addr(), free_addr());
    let mut served = Command::new(env!("CARGO_BIN_EXE_skin"))
        .args(["sim-endpoint", "--mujoco", urdf.to_str().unwrap(), "--robot", &robot, "--host", &host])
        // Long enough for the exploration; it then reports where its time went.
        .args(["--duration", "40"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("the skin binary runs");
    let mut line = String::new();
    std::io::BufReader::new(served.stdout.take().unwrap()).read_line(&mut line).unwrap();
    assert!(line.starts_with("serving the MuJoCo robot"), "{line}");
    let out_dir = dir.join("report");
    let out = Command::new(env!("CARGO_BIN_EXE_skin"))
        .args(["run", "--robot", &robot, "--interface", &host, "--json", "--out", out_dir.to_str().unwrap()])
        .output()
        .expect("the skin binary runs");
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let mut err = String::new();
    served.stderr.take().unwrap().read_to_string(&mut err).unwrap();
    let _ = served.wait();
    assert!(err.contains("time: "), "{err}");
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let timing = &v["timing"];
    let robot_s = timing["organize_robot_s"].as_f64().unwrap()
        + timing["structure_robot_s"].as_f64().unwrap()
        + timing["smm_robot_s"].as_f64().unwrap();
    let wall_s = timing["total_wall_s"].as_f64().unwrap();
    println!(
        "{} cells, {} DoFs: {robot_s:.1} s of robot time in {wall_s:.2} s of wall time: {:.1}x real time",
        v["exploration"]["cells"],
        v["robot"]["dof_names"].as_array().unwrap().len(),
        robot_s / wall_s
    );
    // The endpoint's share of the run: its world and cell network times.
    println!(
        "{}",
        err.lines().filter(|l| l.starts_with("time: ") || l.starts_with("note: ")).collect::<Vec<_>>().join("\n")
    );
    let _ = std::fs::remove_dir_all(&dir);
}
