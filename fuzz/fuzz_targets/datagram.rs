//! Any bytes as an interface datagram, through the host's whole ingest
//! (header, port, sequence, every frame): counted, never a panic.
#![no_main]

libfuzzer_sys::fuzz_target!(|bytes: &[u8]| {
    skin_fuzz_targets::datagram(bytes);
});
