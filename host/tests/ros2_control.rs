//! `skin run --robot ros2` against a ros2_control robot as rclpy sees
//! one: `joint_state_broadcaster` and a forward velocity controller with a
//! `joints` parameter at 500 Hz (tests/python/ros2_robot.py), whose
//! hardware is `skin sim-endpoint`'s simulated robot, so its motion moves
//! the simulated skin. The faults where a forward controller's habit of
//! holding its last command forever matters: SIGTERM mid-motion, a
//! `/joint_states` that falls silent, a controller with the wrong joints.

mod common;

use std::io::{BufRead, BufReader};
use std::net::UdpSocket;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::sync::mpsc::{channel, Receiver, RecvTimeoutError};
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use common::rclpy::{self, Domain};
use serde_json::Value;

fn now_s() -> f64 {
    SystemTime::now().duration_since(UNIX_EPOCH).unwrap().as_secs_f64()
}

/// The simulated robot and skin (lockstep: the robot node's loop is its
/// clock), the robot node on it, and where the skin sends.
struct Rig {
    endpoint: Child,
    robot: Child,
    /// The robot node's stderr, line by line (read on a thread of its own).
    robot_lines: Receiver<String>,
    host: String,
    domain: Domain,
    out: PathBuf,
}

impl Rig {
    fn start(python: &Path, name: &str, robot_args: &[&str]) -> Rig {
        let (host, endpoint, link) = endpoint();
        let domain = Domain::unique();
        let mut args = vec![link.as_str(), "forward_velocity_controller", "240"];
        args.extend(robot_args);
        let mut robot = domain
            .python(python, "ros2_robot.py", &args)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        let (tx, robot_lines) = channel();
        let stderr = BufReader::new(robot.stderr.take().unwrap());
        std::thread::spawn(move || stderr.lines().map_while(Result::ok).try_for_each(|l| tx.send(l)));
        let mut rig = Rig {
            robot_lines,
            endpoint,
            robot,
            host,
            domain,
            out: std::env::temp_dir().join(format!("skin-ros2-control-{}-{name}", std::process::id())),
        };
        rig.robot_says("ready", None);
        rig
    }

    /// Waits for the robot node to print `word` on stderr; fails when it
    /// ends first, or `run` (skin run) does, or a minute passes.
    fn robot_says(&mut self, word: &str, mut run: Option<&mut Child>) {
        let start = Instant::now();
        loop {
            match self.robot_lines.recv_timeout(Duration::from_millis(50)) {
                Ok(line) if line.trim() == word => return,
                Ok(_) | Err(RecvTimeoutError::Timeout) => {}
                Err(RecvTimeoutError::Disconnected) => panic!("the robot node ended before {word:?}"),
            }
            if let Some(status) = run.as_mut().and_then(|r| r.try_wait().unwrap()) {
                panic!("skin run ended ({status}) before the robot node said {word:?}");
            }
            assert!(start.elapsed() < Duration::from_secs(60), "the robot node did not say {word:?} within a minute");
        }
    }

    /// `skin run --robot ros2` on this rig, once it has the robot.
    fn run(&self) -> (Child, std::thread::JoinHandle<String>) {
        let id = self.domain.0.to_string();
        let args = ["run", "--robot", "ros2", "--cells", "74", "--json", "--interface", &self.host];
        let mut command = Command::new(env!("CARGO_BIN_EXE_skin"));
        command.args(args).arg("--out").arg(&self.out).envs(self.domain.env()).env("ROS_DOMAIN_ID", &id);
        // No line awaited (an empty marker): the run's stderr drained.
        let (child, _, drain) = common::announcing(&mut command, "");
        (child, drain)
    }

    /// Stops the robot node: every command it received, with wall times.
    fn finish(mut self) -> Value {
        let _ = Command::new("kill").args(["-TERM", &self.robot.id().to_string()]).status();
        let out = self.robot.wait_with_output().unwrap();
        let rest: Vec<String> = self.robot_lines.try_iter().collect();
        let _ = self.endpoint.kill();
        let _ = self.endpoint.wait();
        let _ = std::fs::remove_dir_all(&self.out);
        rclpy::json_of("ros2_robot.py", &Output { stderr: rest.join("\n").into_bytes(), ..out })
    }
}

/// `skin sim-endpoint` in lockstep, sending the skin to a free loopback
/// port: that port, the child, and its robot-link address.
fn endpoint() -> (String, Child, String) {
    let host = UdpSocket::bind("127.0.0.1:0").unwrap().local_addr().unwrap().to_string();
    let mut endpoint = Command::new(env!("CARGO_BIN_EXE_skin"))
        .args(["sim-endpoint", "--pace", "lockstep", "--robot", "127.0.0.1:0", "--host", &host])
        .args(["--duration", "300"])
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let mut line = String::new();
    BufReader::new(endpoint.stdout.take().unwrap()).read_line(&mut line).unwrap();
    let link = line
        .split_whitespace()
        .find(|w| w.starts_with("127.0.0.1:") && !w.contains(host.as_str()))
        .unwrap_or_else(|| panic!("no robot-link address in {line:?}"))
        .to_owned();
    (host, endpoint, link)
}

/// The commands the controller got: (wall time, velocities).
fn commands(got: &Value) -> Vec<(f64, Vec<f64>)> {
    got["commands"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| (c[0].as_f64().unwrap(), c[1].as_array().unwrap().iter().map(|v| v.as_f64().unwrap()).collect()))
        .collect()
}

/// Waits for `child` to end, polling: its status and when it ended (s since the epoch).
fn ended(child: &mut Child, within: Duration) -> (std::process::ExitStatus, f64) {
    let start = Instant::now();
    loop {
        if let Some(status) = child.try_wait().unwrap() {
            return (status, now_s());
        }
        assert!(start.elapsed() < within, "skin run did not end within {within:?}");
        std::thread::sleep(Duration::from_millis(2));
    }
}

#[test]
fn sigterm_mid_motion_leaves_a_zero_command_as_the_controllers_last() {
    let Some(python) = rclpy::python() else { return };
    let mut rig = Rig::start(&python, "sigterm", &[]);
    let (mut run, drain) = rig.run();
    rig.robot_says("moving", Some(&mut run));
    std::thread::sleep(Duration::from_millis(300));
    let signalled = now_s();
    assert!(Command::new("kill").args(["-TERM", &run.id().to_string()]).status().unwrap().success());
    let (status, _) = ended(&mut run, Duration::from_secs(5));
    let stderr = drain.join().unwrap();
    assert_eq!(status.code(), Some(128 + 15), "{stderr}");
    assert!(stderr.contains("zero command"), "{stderr}");
    let got = rig.finish();
    let commands = commands(&got);
    let moving = commands.iter().filter(|(_, v)| v.iter().any(|x| *x != 0.0)).count();
    assert!(moving > 10, "the robot moved before the signal: {moving} commands");
    let (at, last) = commands.last().unwrap();
    assert!(last.iter().all(|v| *v == 0.0), "the last command stops every joint: {last:?}");
    assert_eq!(last.len(), 14);
    // The zero may already stand when the signal comes (the bridge stops a
    // host that fell silent for 50 ms, as a loaded machine's may): what
    // matters is that the controller holds zero within 100 ms of it.
    assert!(at - signalled < 0.1, "the zero command {:.1} ms after SIGTERM", (at - signalled) * 1e3);
}

#[test]
fn joint_states_falling_silent_end_the_run_within_200_ms_with_a_zero_command() {
    let Some(python) = rclpy::python() else { return };
    let mut rig = Rig::start(&python, "silent", &["--states-for", "0.5"]);
    let (mut run, drain) = rig.run();
    rig.robot_says("moving", Some(&mut run));
    let (status, at) = ended(&mut run, Duration::from_secs(30));
    let stderr = drain.join().unwrap();
    assert_eq!(status.code(), Some(1), "{stderr}");
    assert!(stderr.contains("/joint_states fell silent"), "{stderr}");
    let got = rig.finish();
    let silent = got["silent_since"].as_f64().expect("the broadcaster fell silent");
    assert!(at - silent < 0.2, "skin run ended {:.1} ms after /joint_states fell silent", (at - silent) * 1e3);
    let commands = commands(&got);
    let (last_at, last) = commands.last().unwrap();
    assert!(last.iter().all(|v| *v == 0.0) && *last_at >= silent, "the last command stops every joint: {last:?}");
}

#[test]
fn a_controller_with_other_joints_is_refused_before_any_command() {
    let Some(python) = rclpy::python() else { return };
    let rig = Rig::start(&python, "wrong", &["--joints", "shoulder_pan_joint,elbow_joint"]);
    let (mut run, drain) = rig.run();
    let (status, _) = ended(&mut run, Duration::from_secs(30));
    let stderr = drain.join().unwrap();
    assert_eq!(status.code(), Some(1), "{stderr}");
    assert!(
        stderr.contains("commands \"shoulder_pan_joint\", which /joint_states does not report")
            && stderr.contains("refused before any command"),
        "{stderr}"
    );
    let got = rig.finish();
    assert_eq!(got["joints"], serde_json::json!(["shoulder_pan_joint", "elbow_joint"]), "the parameter as declared");
    assert_eq!(commands(&got), vec![], "no command at all");
}

/// Ignored: the robot moves on the wall clock here, and on a loaded
/// machine (2 cores shared with other builds) the exploration's samples
/// suffer: of three runs there, one differed in the joints, one in a
/// cell's part. Run it on a quiet machine:
/// `cargo test -p skin-host --features ros2 --test ros2_control -- --ignored`.
#[test]
#[ignore]
fn a_ros2_control_robot_is_explored_to_the_same_tree_as_over_the_robot_link() {
    let Some(python) = rclpy::python() else { return };
    let rig = Rig::start(&python, "tree", &[]);
    let (run, drain) = rig.run();
    let out = run.wait_with_output().unwrap();
    let stderr = drain.join().unwrap();
    assert!(out.status.success(), "skin run --robot ros2 failed: {stderr}");
    let over_ros: Value = serde_json::from_slice(&out.stdout).unwrap();
    // The command latency the bridge measured, the figure of the results.
    let latency = stderr.lines().find(|l| l.starts_with("ros2_control:")).unwrap_or_else(|| panic!("{stderr}"));
    eprintln!("{latency}");
    let commands = commands(&rig.finish());
    assert!(commands.iter().filter(|(_, v)| v.iter().any(|x| *x != 0.0)).count() > 100, "the robot moved");
    let (_, last) = commands.last().unwrap();
    assert!(last.iter().all(|v| *v == 0.0), "a zero command when the run ends: {last:?}");

    // The same simulated robot and skin, driven over the robot link.
    let (host, mut endpoint, link) = endpoint();
    let dir = std::env::temp_dir().join(format!("skin-ros2-control-{}-link", std::process::id()));
    let out = Command::new(env!("CARGO_BIN_EXE_skin"))
        .args(["run", "--robot", &link, "--cells", "74", "--json", "--interface", &host, "--out"])
        .arg(&dir)
        .output()
        .unwrap();
    let _ = endpoint.kill();
    let _ = endpoint.wait();
    let _ = std::fs::remove_dir_all(&dir);
    assert!(out.status.success(), "skin run over the robot link failed: {}", String::from_utf8_lossy(&out.stderr));
    let over_link: Value = serde_json::from_slice(&out.stdout).unwrap();
    // The tree: the same joints between the same parts, limbs and leaves.
    for key in ["cells", "dofs", "joints", "leaves", "limbs"] {
        let (ros, link) = (&over_ros["exploration"][key], &over_link["exploration"][key]);
        assert!(!ros.is_null(), "{key} explored");
        assert_eq!(ros, link, "{key}: over ros2_control against over the robot link");
    }
    // The parts' cells, counted: the cells' IDs come from the skin's own
    // organization in each run, and the robot moves on the wall clock over
    // ros2_control but in lockstep over the link, so a cell the activity
    // leaves near a threshold may fall to the neighbouring part.
    let sizes = |report: &Value| -> Vec<i64> {
        report["exploration"]["body_parts"]
            .as_array()
            .unwrap()
            .iter()
            .map(|c| c.as_array().unwrap().len() as i64)
            .collect()
    };
    let (ros, link) = (sizes(&over_ros), sizes(&over_link));
    eprintln!("cells per body part over ros2_control {ros:?}, over the robot link {link:?}");
    assert_eq!(ros.len(), link.len());
    let moved: i64 = ros.iter().zip(&link).map(|(a, b)| (a - b).abs()).sum::<i64>() / 2;
    assert!(moved <= 2, "{moved} cells on another part");
}
