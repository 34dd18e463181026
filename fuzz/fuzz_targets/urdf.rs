//! Any text as a robot description: a robot or a typed error.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|text: &str| {
    let _ = skin_sim::robot::Robot::from_urdf_str(text);
});
