//! Real ROS 2 on this machine: rclpy on Fast DDS (rmw_fastrtps_cpp) from
//! the PyPI wheels `cargo xtask install` puts in the venv `target/rosenv`,
//! and a test-unique ROS domain on loopback for the skin and rclpy alike.

use std::ffi::OsStr;
use std::path::{Path, PathBuf};
use std::process::{Child, Command};
use std::sync::atomic::{AtomicU16, Ordering};
use std::thread::JoinHandle;

/// The ROS venv's Python, or `None` after saying loudly that the test did
/// not run (the only reason to skip: no venv on this machine).
pub fn python() -> Option<PathBuf> {
    let target = super::target_dir();
    let venv = target.join("rosenv/bin/python");
    if venv.exists() {
        return Some(venv);
    }
    eprintln!(
        "\n*** SKIPPED: {} is missing, so rclpy on Fast DDS did not check the skin: run `cargo xtask install` ***\n",
        venv.display()
    );
    None
}

/// A ROS domain of its own for one test, on this host only.
pub struct Domain(pub u16);

impl Domain {
    /// A domain no other test of this run uses (tests of one binary count
    /// up; binaries differ by process ID), within ROS 2's 0-232.
    pub fn unique() -> Domain {
        static NEXT: AtomicU16 = AtomicU16::new(0);
        let n = NEXT.fetch_add(1, Ordering::Relaxed);
        Domain(100 + ((std::process::id() as u16).wrapping_mul(7).wrapping_add(n * 31)) % 130)
    }

    /// The environment of every process in the domain: the domain ID, and
    /// discovery on loopback only (RustDDS and Fast DDS both read it).
    pub fn env(&self) -> [(&'static str, String); 3] {
        [
            ("ROS_DOMAIN_ID", self.0.to_string()),
            ("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST".to_owned()),
            ("RMW_IMPLEMENTATION", "rmw_fastrtps_cpp".to_owned()),
        ]
    }

    /// `skin ARGS` in this domain, as [`super::spawn_announcing`].
    pub fn spawn_skin(&self, args: &[&OsStr], marker: &str) -> (Child, String, JoinHandle<String>) {
        super::announcing(Command::new(env!("CARGO_BIN_EXE_skin")).args(args).envs(self.env()), marker)
    }

    /// A Python script of tests/python in this domain, not yet waited for.
    pub fn python(&self, python: &Path, script: &str, args: &[&str]) -> Command {
        let mut c = Command::new(python);
        c.arg(Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/python").join(script)).args(args).envs(self.env());
        c
    }
}

/// The output of a finished script as JSON, after checking it succeeded.
pub fn json_of(script: &str, out: &std::process::Output) -> serde_json::Value {
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{script} failed: {stderr}");
    serde_json::from_slice(&out.stdout).unwrap_or_else(|e| panic!("{script} printed no JSON ({e}): {stderr}"))
}

/// The median and 99th percentile of the sorted `/skin/cells` latencies, printed
/// (the figure of the results) and returned; none is a failure.
pub fn latency(got: &serde_json::Value, what: &str) -> (f64, f64) {
    let l: Vec<f64> = got["cells_latency_ms"].as_array().unwrap().iter().map(|v| v.as_f64().unwrap()).collect();
    assert!(!l.is_empty(), "no /skin/cells latency measured");
    let at = |q: f64| l[((l.len() - 1) as f64 * q).round() as usize];
    eprintln!(
        "/skin/cells from its stamp to {what}: median {:.2} ms, p99 {:.2} ms over {} messages",
        at(0.5),
        at(0.99),
        l.len()
    );
    (at(0.5), at(0.99))
}
