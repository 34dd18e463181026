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
    let target = std::env::var_os("CARGO_TARGET_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join("../target"));
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
