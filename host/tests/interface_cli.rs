//! The `skin` program's interface commands, run as a person would: the
//! default configuration round-trips, bad files are refused naming the key,
//! and `skin monitor` sees a simulated skin sending to it.

use std::io::{BufRead, BufReader};
use std::process::{Command, Stdio};
use std::time::Duration;

use skin_host::config::Config;
use skin_host::interface::loadgen::{LoadGen, LoadSpec, Pace};

fn skin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_skin"))
}

/// A test's own scratch folder, removed when the test ends.
fn scratch() -> tempfile::TempDir {
    tempfile::Builder::new().prefix("skin-interface-cli-").tempdir().unwrap()
}

#[test]
fn the_default_configuration_is_written_checked_and_kept() {
    let out = skin().args(["config", "--default"]).output().unwrap();
    assert!(out.status.success());
    let text = String::from_utf8(out.stdout).unwrap();
    assert_eq!(Config::from_toml(&text, "stdout").unwrap(), Config::default());

    let dir = scratch();
    let path = dir.path().join("skin.toml");
    let write = |force: bool| {
        let mut c = skin();
        c.args(["config", "--default", "--output"]).arg(&path);
        if force {
            c.arg("--force");
        }
        c.output().unwrap()
    };
    assert!(write(false).status.success());
    let again = write(false);
    assert!(!again.status.success());
    assert!(String::from_utf8_lossy(&again.stderr).contains("--force"), "{again:?}");
    assert!(write(true).status.success());
    let check = skin().args(["config", "--check"]).arg(&path).output().unwrap();
    assert!(check.status.success(), "{check:?}");
    assert!(String::from_utf8_lossy(&check.stdout).contains("valid"));
}

#[test]
fn a_bad_configuration_is_refused_naming_the_key() {
    let dir = scratch();
    let path = dir.path().join("bad.toml");
    std::fs::write(&path, "[cells]\nhysteresis = 3.0\n").unwrap();
    for args in [&["config", "--check"][..], &["monitor", "--once", "--config"][..]] {
        let out = skin().args(args).arg(&path).output().unwrap();
        assert!(!out.status.success());
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains("cells.hysteresis") && !err.contains("panicked"), "{err}");
    }
}

#[test]
fn monitor_sees_a_simulated_skin() {
    let mut monitor = skin()
        .args(["monitor", "--interface", "127.0.0.1:0", "--ports", "2", "--duration", "3", "--json"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // The monitor says where it listens before anything else.
    let mut stderr = BufReader::new(monitor.stderr.take().unwrap());
    let mut line = String::new();
    stderr.read_line(&mut line).unwrap();
    let addr = line.trim().rsplit(' ').next().unwrap().parse().unwrap();

    let spec = LoadSpec { cells: 20, ports: 2, report_period_s: 0.2, touch: true, ..LoadSpec::default() };
    let sent = LoadGen::new(spec, addr).unwrap().run(Duration::from_secs(1), Pace::RealTime, |_| {});
    let out = monitor.wait_with_output().unwrap();
    assert!(out.status.success());
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(json["cells"]["heard"], 20);
    assert_eq!(json["cells"]["patches"], serde_json::json!([10, 10]));
    assert_eq!(json["counters"]["frames"]["accepted"], sent.frames);
    assert_eq!(json["counters"]["datagrams"]["rejected"]["spoofed_port"], 0);
    assert_eq!(
        json["ports"][0]["stats"]["frames"].as_u64().unwrap() + json["ports"][1]["stats"]["frames"].as_u64().unwrap(),
        sent.frames
    );
}
