//! Any text as a robot description: a robot or a typed error.
#![no_main]

libfuzzer_sys::fuzz_target!(|bytes: &[u8]| {
    skin_fuzz_targets::urdf(bytes);
});
