//! Any bytes as a skin frame: a frame and its message, or a typed error.
#![no_main]

libfuzzer_sys::fuzz_target!(|bytes: &[u8]| {
    skin_fuzz_targets::frame(bytes);
});
