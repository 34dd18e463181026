//! Any bytes as a skin frame: a frame and its message, or a typed error.
#![no_main]

use libfuzzer_sys::fuzz_target;
use skin_protocol::Frame;

fuzz_target!(|bytes: &[u8]| {
    let _ = skin_protocol::frame::decode(bytes);
    if let Ok(frame) = Frame::parse(bytes) {
        let _ = frame.message();
    }
});
