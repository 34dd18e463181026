//! Issue 15's hostile arguments, run as a tester would: every case ends
//! with a non-zero exit code and one line naming the flag and its range,
//! never a panic or a process left serving nothing.

use std::net::UdpSocket;
use std::process::{Command, Output};

fn skin(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_skin")).args(args).output().expect("the skin binary runs")
}

/// Asserts a failure whose whole stderr is the one line `error: {says}`.
fn refused(args: &[&str], says: &str) {
    let out = skin(args);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{args:?}: {err}");
    assert_eq!(err.trim_end(), format!("error: {says}"), "{args:?}");
}

/// A loopback address nobody listens on.
fn free_addr() -> String {
    UdpSocket::bind("127.0.0.1:0").unwrap().local_addr().unwrap().to_string()
}

#[test]
fn seconds_no_clock_holds_are_refused_naming_the_flag() {
    let robot = free_addr();
    for (args, flag, range, value) in [
        (vec!["monitor", "--duration", "1e300"], "--duration", "[0, 1e9]", "1e300"),
        (vec!["monitor", "--duration", "NaN"], "--duration", "[0, 1e9]", "NaN"),
        (vec!["sim-endpoint", "--duration", "1e300", "--robot", "127.0.0.1:0"], "--duration", "[0, 1e9]", "1e300"),
        (vec!["sim-endpoint", "--duration", "inf", "--robot", "127.0.0.1:0"], "--duration", "[0, 1e9]", "inf"),
        (vec!["loadgen", "--duration", "1e300"], "--duration", "[0, 1e9]", "1e300"),
        (vec!["run", "--robot", &robot, "--organize-timeout", "1e300"], "--organize-timeout", "(0, 1e9]", "1e300"),
        (vec!["run", "--robot", &robot, "--organize-timeout", "0"], "--organize-timeout", "(0, 1e9]", "0.0"),
        (vec!["explore", "--time-budget", "1e300"], "--time-budget", "(0, 1e9]", "1e300"),
        (vec!["explore", "--time-budget", "-1"], "--time-budget", "(0, 1e9]", "-1.0"),
    ] {
        refused(&args, &format!("{flag} must be a number of seconds in {range}, not {value}"));
    }
}

#[test]
fn sim_endpoint_stops_after_its_duration_and_says_what_it_served() {
    let out = skin(&["sim-endpoint", "--duration", "0.2", "--robot", "127.0.0.1:0", "--host", &free_addr()]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert!(String::from_utf8_lossy(&out.stdout).starts_with("serving the simulated robot on 127.0.0.1:"));
    assert!(err.starts_with("served "), "{err}");
}
