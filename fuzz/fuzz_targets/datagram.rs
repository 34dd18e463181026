//! Any bytes as an interface datagram, through the host's whole ingest
//! (header, port, sequence, every frame): counted, never a panic.
#![no_main]

use libfuzzer_sys::fuzz_target;
use skin_host::config::PortConfig;
use skin_host::interface::Ingest;
use skin_protocol::interface::Datagram;

fuzz_target!(|bytes: &[u8]| {
    if let Ok(d) = Datagram::parse(bytes) {
        for frame in d.frames().flatten() {
            let _ = frame.message();
        }
    }
    let mut ingest = Ingest::new(&[PortConfig { number: 0, address: None }]);
    let mut events = Vec::new();
    ingest.datagram(([127, 0, 0, 1], 9).into(), bytes, 0, &mut events);
    assert!(ingest.counters().balanced());
});
