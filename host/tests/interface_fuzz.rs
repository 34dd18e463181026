//! Arbitrary datagrams fed to the interface: it never panics, and its
//! counters account for every datagram (received = accepted + each
//! rejection reason) and every frame of the accepted ones. In memory through
//! `Ingest` for many cases, and through a real socket for a few, where
//! oversized datagrams and the batch path are exercised too.

use std::net::{SocketAddr, UdpSocket};
use std::time::{Duration, Instant};

use proptest::prelude::*;
use skin_host::config::{InterfaceConfig, PortConfig};
use skin_host::interface::{Ingest, Interface};
use skin_protocol::interface::{encode, DatagramHeader, HEADER_LEN, MAX_DATAGRAM};
use skin_protocol::message::{Channel, ConfigAck, IdRequest, Neighbour, NeighbourReport, Port, Probe, TactileEvent};
use skin_protocol::{Address, Frame, Message, Sample, FRAME_LEN};

fn source(i: u8) -> SocketAddr {
    SocketAddr::from(([127, 0, 0, 1], 30_000 + u16::from(i)))
}

/// Ports 0 and 1 bound to sources 0 and 1, port 2 bound on first contact.
fn ports() -> Vec<PortConfig> {
    vec![
        PortConfig { number: 0, address: Some(source(0)) },
        PortConfig { number: 1, address: Some(source(1)) },
        PortConfig { number: 2, address: None },
    ]
}

fn any_port() -> impl Strategy<Value = Port> {
    (0usize..4).prop_map(|i| Port::from_index(i).unwrap())
}

fn any_address() -> impl Strategy<Value = Address> {
    prop_oneof![
        (1u16..50).prop_map(Address),
        Just(Address::UNASSIGNED),
        Just(Address::HOST),
        Just(Address::BROADCAST),
        any::<u16>().prop_map(Address),
    ]
}

/// Messages of every kind, the skin's and others.
fn any_message() -> impl Strategy<Value = Message> {
    prop_oneof![
        (any::<u16>(), any::<[u16; 3]>(), any::<[i16; 3]>(), any::<i16>(), any::<u8>())
            .prop_map(|(p, f, a, t, s)| Message::Sample(Sample::saturating(p, f, a, t, s))),
        (0usize..4, 0u8..6, any::<u16>()).prop_map(|(c, level, value)| {
            let channel = [Channel::Proximity, Channel::Force0, Channel::Force1, Channel::Force2][c];
            Message::Event(TactileEvent { channel, level, value })
        }),
        proptest::array::uniform4(proptest::option::of((any_address(), any_port()))).prop_map(|n| {
            Message::NeighbourReport(NeighbourReport {
                neighbours: n
                    .map(|x| x.filter(|(id, _)| *id != Address::UNASSIGNED).map(|(id, port)| Neighbour { id, port })),
                master: None,
            })
        }),
        (any::<u8>(), any::<bool>()).prop_map(|(tag, accepted)| Message::ConfigAck(ConfigAck { tag, accepted })),
        (any_address(), any_port()).prop_map(|(parent, port)| Message::IdRequest(IdRequest { parent, port })),
        (any_port(), any_address(), any::<bool>(), any::<bool>(), any::<bool>())
            .prop_map(|(port, id, master, known, lost)| Message::Probe(Probe { port, id, master, known, lost })),
    ]
}

/// A datagram as a skin would send it, then perhaps damaged.
fn mostly_valid() -> impl Strategy<Value = Vec<u8>> {
    let frames = proptest::collection::vec((any_address(), any_address(), any_message()), 1..8);
    (0u8..4, 0u32..40, frames, proptest::collection::vec((any::<usize>(), any::<u8>()), 0..3), any::<u8>()).prop_map(
        |(port, seq, frames, flips, cut)| {
            let frames: Vec<Frame> = frames.iter().map(|(src, dst, m)| Frame::new(*src, *dst, m)).collect();
            let mut buf = [0u8; MAX_DATAGRAM];
            let n = encode(DatagramHeader { interface: port, seq, timestamp_us: 0 }, &frames, &mut buf).unwrap();
            let mut bytes = buf[..n].to_vec();
            for (at, mask) in flips {
                let len = bytes.len();
                bytes[at % len] ^= mask;
            }
            // Now and then cut short or lengthened.
            match cut {
                0..=9 => bytes.truncate(usize::from(cut) * 7),
                10..=14 => bytes.extend(std::iter::repeat_n(cut, usize::from(cut))),
                _ => {}
            }
            bytes
        },
    )
}

fn any_datagram() -> impl Strategy<Value = Vec<u8>> {
    prop_oneof![
        3 => mostly_valid(),
        1 => proptest::collection::vec(any::<u8>(), 0..1600),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 512, ..ProptestConfig::default() })]

    #[test]
    fn any_datagrams_are_counted_never_panic(input in proptest::collection::vec((0u8..4, any_datagram()), 1..40)) {
        let mut ingest = Ingest::new(&ports());
        let mut events = Vec::new();
        let mut frames_in_accepted = 0u64;
        for (i, (from, bytes)) in input.iter().enumerate() {
            let before = events.len();
            if ingest.datagram(source(*from), bytes, i as u64 * 1000, &mut events) {
                let frames = (bytes.len() - HEADER_LEN) / FRAME_LEN;
                frames_in_accepted += frames as u64;
                // At most a first-sight event and the frame's own per frame.
                prop_assert!(events.len() - before <= 2 * frames);
            } else {
                prop_assert_eq!(events.len(), before);
            }
        }
        let c = *ingest.counters();
        prop_assert_eq!(c.datagrams.received, input.len() as u64);
        prop_assert!(c.balanced(), "{:?}", c);
        prop_assert_eq!(c.frames.received, frames_in_accepted);
        let replies = ingest.take_replies();
        prop_assert_eq!(replies.len() as u64, c.id_replies);
        prop_assert!(replies.iter().all(|(port, _)| ingest.ports().get(*port).address().is_some()));
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 16, ..ProptestConfig::default() })]

    #[test]
    fn any_datagrams_through_a_socket_are_counted(
        input in proptest::collection::vec(prop_oneof![any_datagram(), proptest::collection::vec(any::<u8>(), 1400..2100)], 1..60),
        batched in any::<bool>(),
    ) {
        let sender = UdpSocket::bind("127.0.0.1:0").unwrap();
        let config = InterfaceConfig {
            listen: SocketAddr::from(([127, 0, 0, 1], 0)),
            ports: vec![PortConfig { number: 0, address: Some(sender.local_addr().unwrap()) }, PortConfig { number: 1, address: None }],
            batch: 8,
            ..InterfaceConfig::default()
        };
        let mut interface = Interface::bind_with(&config, batched).unwrap();
        for bytes in &input {
            sender.send_to(bytes, interface.local_addr()).unwrap();
        }
        let start = Instant::now();
        let mut events = Vec::new();
        while interface.counters().datagrams.received < input.len() as u64 && start.elapsed() < Duration::from_secs(10) {
            interface.poll(Duration::from_millis(20), &mut events).unwrap();
        }
        let c = interface.counters();
        prop_assert_eq!(c.datagrams.received, input.len() as u64);
        prop_assert!(c.balanced(), "{:?}", c);
        let too_long = input.iter().filter(|b| b.len() > MAX_DATAGRAM).count() as u64;
        prop_assert!(c.datagrams.rejected(skin_host::interface::DatagramReject::BadLength) >= too_long);
    }
}
