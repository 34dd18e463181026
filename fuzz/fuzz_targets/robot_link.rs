//! Any bytes as a robot-link datagram, either way: a message or a typed error.
#![no_main]

libfuzzer_sys::fuzz_target!(|bytes: &[u8]| {
    skin_fuzz_targets::robot_link(bytes);
});
