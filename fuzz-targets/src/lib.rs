//! The bodies of the fuzz targets, one per parser that takes bytes or text
//! from outside, where hostile input arrives. `fuzz/` runs them
//! coverage-guided under libFuzzer (nightly); this crate's `short_run` test runs them on the
//! stable toolchain in CI, over valid seeds, their mutations and random
//! bytes. One body, two drivers: the check is the same in both.
//!
//! Each body takes any bytes (text targets skip what is not UTF-8, as
//! `fuzz_target!(|text: &str|)` does) and returns whether the input was
//! accepted; a parser's typed error is a normal outcome, and a panic or a
//! broken invariant is the finding.

use skin_host::config::{Config, PortConfig};
use skin_host::control::params::Params;
use skin_host::interface::Ingest;
use skin_model::robot::{hrp2, Robot};
use skin_model::skin::Skin;
use skin_protocol::interface::Datagram;
use skin_protocol::robot_link::{self, FromRobot, ToRobot};
use skin_protocol::Frame;
use skin_sim::network::Topology;

/// A target: its name (the `fuzz/` binary's) and its body.
pub type Target = (&'static str, fn(&[u8]) -> bool);

/// Every target, by the name of its `fuzz/` binary.
pub const TARGETS: [Target; 5] =
    [("frame", frame), ("datagram", datagram), ("robot_link", robot_link), ("urdf", urdf), ("config", config)];

/// Any bytes as a skin frame: a frame and its message, or a typed error.
pub fn frame(bytes: &[u8]) -> bool {
    let decoded = skin_protocol::frame::decode(bytes).is_ok();
    match Frame::parse(bytes) {
        Ok(frame) => frame.message().is_ok() || decoded,
        Err(_) => decoded,
    }
}

/// Any bytes as an interface datagram, through the host's whole ingest
/// (header, port, sequence, every frame): every datagram and frame is
/// counted as accepted or rejected for one reason.
pub fn datagram(bytes: &[u8]) -> bool {
    if let Ok(d) = Datagram::parse(bytes) {
        for frame in d.frames().flatten() {
            let _ = frame.message();
        }
    }
    let mut ingest = Ingest::new(&[PortConfig { number: 0, address: None }]);
    let mut events = Vec::new();
    let accepted = ingest.datagram(([127, 0, 0, 1], 9).into(), bytes, 0, &mut events);
    assert!(ingest.counters().balanced(), "{:?}", ingest.counters());
    accepted
}

/// Any bytes as a robot-link datagram, either way: a message or a typed
/// error; a message read is written back within the link's datagram size.
pub fn robot_link(bytes: &[u8]) -> bool {
    let mut out = [0u8; robot_link::MAX_DATAGRAM];
    let to = robot_link::decode::<ToRobot>(bytes).map(|m| robot_link::encode(&m, &mut out).map(|_| ()));
    let from = robot_link::decode::<FromRobot>(bytes).map(|m| robot_link::encode(&m, &mut out).map(|_| ()));
    for written in [to.as_ref().ok(), from.as_ref().ok()].into_iter().flatten() {
        assert!(written.is_ok(), "a message read from {} bytes does not fit the link: {written:?}", bytes.len());
    }
    to.is_ok() || from.is_ok()
}

/// Any text as a robot description: a robot or a typed error.
pub fn urdf(bytes: &[u8]) -> bool {
    std::str::from_utf8(bytes).is_ok_and(|text| Robot::from_urdf_str(text).is_ok())
}

/// Any text as each file a user writes: the host configuration, the grasp
/// parameters, a skin file (TOML and JSON) and a topology file or spec.
pub fn config(bytes: &[u8]) -> bool {
    let Ok(text) = std::str::from_utf8(bytes) else { return false };
    let robot = hrp2::robot();
    let results = [
        Config::from_toml(text, "fuzz").is_ok(),
        Params::from_toml_str(text).is_ok(),
        Skin::from_toml_str(&robot, text).is_ok(),
        Skin::from_json_str(&robot, text).is_ok(),
        Topology::from_text(text, false).is_ok(),
        Topology::from_text(text, true).is_ok(),
        Topology::parse(text).is_ok(),
    ];
    results.contains(&true)
}
