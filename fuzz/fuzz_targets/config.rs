//! Any text as each file a user writes: the host configuration, the
//! grasp parameters, a skin file and a topology file or spec.
#![no_main]

libfuzzer_sys::fuzz_target!(|bytes: &[u8]| {
    skin_fuzz_targets::config(bytes);
});
