//! Property tests of everything that reads bytes from a wire: frames,
//! datagrams, and the state machines that take them.

use proptest::prelude::*;

use skin_protocol::address::Address;
use skin_protocol::cell::{Cell, Received};
use skin_protocol::frame::{self, Frame, FrameError, FRAME_LEN};
use skin_protocol::interface::{self, Datagram, DatagramHeader, MAX_FRAMES};
use skin_protocol::message::*;
use skin_protocol::organize::{Allocator, Config, Sink};
use skin_protocol::sample::{self, Sample};

fn port() -> impl Strategy<Value = Port> {
    (0..4usize).prop_map(|i| Port::from_index(i).unwrap())
}

fn address() -> impl Strategy<Value = Address> {
    any::<u16>().prop_map(Address)
}

fn neighbour() -> impl Strategy<Value = Neighbour> {
    (1..=u16::MAX, port()).prop_map(|(id, port)| Neighbour { id: Address(id), port })
}

fn sample() -> impl Strategy<Value = Sample> {
    let f = 0..=sample::FORCE_MAX;
    let a = sample::ACCEL_MIN..=sample::ACCEL_MAX;
    (
        any::<u16>(),
        [f.clone(), f.clone(), f],
        [a.clone(), a.clone(), a],
        sample::TEMPERATURE_MIN..=sample::TEMPERATURE_MAX,
        any::<u8>(),
    )
        .prop_map(|(p, f, a, t, s)| Sample::new(p, f, a, t, s).unwrap())
}

fn finite() -> impl Strategy<Value = f32> {
    prop_oneof![any::<f32>().prop_filter("finite", |f| f.is_finite()), Just(0.0), Just(1.0)]
}

fn setting() -> impl Strategy<Value = Setting> {
    prop_oneof![
        finite().prop_map(Setting::SampleRateHz),
        prop_oneof![Just(TrafficMode::Clock), Just(TrafficMode::Event)].prop_map(Setting::Traffic),
        finite().prop_map(Setting::FilterCutoffHz),
        (any::<u8>(), finite()).prop_map(|(level, value)| Setting::ForceLevel { level, value }),
        (any::<u8>(), finite()).prop_map(|(level, value)| Setting::ProximityLevel { level, value }),
        finite().prop_map(Setting::Hysteresis),
        (any::<u8>(), any::<u16>()).prop_map(|(channel, counts)| Setting::Delta { channel, counts }),
        (any::<u8>(), finite()).prop_map(|(cell, gain)| Setting::ForceGain { cell, gain }),
        prop_oneof![Just(AccelRange::G2), Just(AccelRange::G8), Just(AccelRange::G16)].prop_map(Setting::AccelRange),
        Just(Setting::Calibrate),
    ]
}

fn channel() -> impl Strategy<Value = Channel> {
    prop_oneof![Just(Channel::Proximity), Just(Channel::Force0), Just(Channel::Force1), Just(Channel::Force2)]
}

fn probe() -> impl Strategy<Value = Probe> {
    (port(), address(), any::<bool>(), any::<bool>(), any::<bool>()).prop_map(|(port, id, master, known, lost)| Probe {
        port,
        id,
        master,
        known,
        lost,
    })
}

/// Every message kind with every field over its whole range.
fn message() -> impl Strategy<Value = Message> {
    prop_oneof![
        probe().prop_map(Message::Probe),
        probe().prop_map(Message::ProbeAck),
        (any::<u8>(), any::<u16>(), any::<u16>()).prop_map(|(interface, seq, hops)| Message::Beacon(Beacon {
            interface,
            seq,
            hops
        })),
        (address(), port()).prop_map(|(parent, port)| Message::IdRequest(IdRequest { parent, port })),
        (port(), address()).prop_map(|(port, id)| Message::IdAssign(IdAssign { port, id })),
        (proptest::array::uniform4(proptest::option::of(neighbour())), proptest::option::of(port()))
            .prop_map(|(neighbours, master)| Message::NeighbourReport(NeighbourReport { neighbours, master })),
        sample().prop_map(Message::Sample),
        (channel(), 0..5u8, any::<u16>()).prop_map(|(channel, level, value)| Message::Event(TactileEvent {
            channel,
            level,
            value
        })),
        (any::<u8>(), setting()).prop_map(|(tag, setting)| Message::ConfigWrite(ConfigWrite { tag, setting })),
        (any::<u8>(), any::<bool>()).prop_map(|(tag, accepted)| Message::ConfigAck(ConfigAck { tag, accepted })),
        (any::<u32>(), any::<u16>())
            .prop_map(|(version, chunks)| Message::UpdateOffer(UpdateOffer { version, chunks })),
        (any::<u16>(), any::<[u8; CHUNK_LEN]>())
            .prop_map(|(index, data)| Message::ImageChunk(ImageChunk { index, data })),
        (any::<u32>(), update_state(), any::<u16>(), any::<u16>()).prop_map(
            |(version, state, first_missing, missing)| {
                Message::UpdateReport(UpdateReport { version, state, first_missing, missing })
            }
        ),
        (
            any::<u32>(),
            proptest::sample::select(vec![
                UpdateAction::Boot,
                UpdateAction::Confirm,
                UpdateAction::Rollback,
                UpdateAction::Status
            ])
        )
            .prop_map(|(version, action)| Message::UpdateCommand(UpdateCommand { version, action })),
    ]
}

fn update_state() -> impl Strategy<Value = UpdateState> {
    let refusal = proptest::sample::select(vec![
        Refusal::BadHeader,
        Refusal::BadSignature,
        Refusal::WrongBoard,
        Refusal::TooLong,
        Refusal::BadBody,
        Refusal::SlotFailed,
    ]);
    prop_oneof![
        proptest::sample::select(vec![
            UpdateState::Receiving,
            UpdateState::Ready,
            UpdateState::Trial,
            UpdateState::Running,
            UpdateState::RolledBack
        ]),
        refusal.prop_map(UpdateState::Refused),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 2000, ..ProptestConfig::default() })]

    #[test]
    fn every_message_round_trips(m in message(), src in address(), dst in address()) {
        let bytes = frame::encode(src, dst, &m);
        let (header, back) = frame::decode(&bytes).unwrap();
        prop_assert_eq!(header.kind, m.kind());
        prop_assert_eq!(header.src, src);
        prop_assert_eq!(header.dst, dst);
        prop_assert_eq!(back, m);
    }

    #[test]
    fn arbitrary_bytes_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..64)) {
        match frame::decode(&bytes) {
            Ok((h, m)) => {
                prop_assert_eq!(bytes.len(), FRAME_LEN);
                // What decodes re-encodes to the very same bytes.
                prop_assert_eq!(&frame::encode(h.src, h.dst, &m)[..], &bytes[..]);
            }
            Err(FrameError::WrongLength(n)) => prop_assert_ne!(n, FRAME_LEN),
            Err(_) => prop_assert_eq!(bytes.len(), FRAME_LEN),
        }
    }

    /// With a valid CRC, any kind byte and payload bytes decode or give a
    /// typed error: this reaches the payload decoders, which random bytes
    /// (failing the CRC) almost never do.
    #[test]
    fn any_payload_with_a_good_crc_never_panics(kind in any::<u8>(), body in any::<[u8; 17]>()) {
        let probe = Frame::new(Address(1), Address(2), &Message::ConfigAck(ConfigAck { tag: 0, accepted: false }));
        let mut bytes = *probe.as_bytes();
        bytes[0] = kind;
        bytes[1..18].copy_from_slice(&body);
        let crc = crc::Crc::<u16>::new(&crc::CRC_16_KERMIT).checksum(&bytes[..18]);
        bytes[18..].copy_from_slice(&crc.to_le_bytes());
        match frame::decode(&bytes) {
            Ok((h, m)) => prop_assert_eq!(frame::encode(h.src, h.dst, &m), bytes),
            Err(e) => prop_assert!(matches!(e, FrameError::UnknownKind(_) | FrameError::BadPayload)),
        }
    }

    #[test]
    fn every_single_bit_error_is_rejected(m in message(), src in address(), dst in address()) {
        let bytes = frame::encode(src, dst, &m);
        for bit in 0..FRAME_LEN * 8 {
            let mut bad = bytes;
            bad[bit / 8] ^= 1 << (bit % 8);
            prop_assert_eq!(Frame::parse(&bad), Err(FrameError::BadCrc));
        }
    }

    /// Bursts in UART bit order (bytes in turn, least significant bit first);
    /// `frame`'s unit test checks every burst pattern exhaustively.
    #[test]
    fn burst_errors_up_to_16_bits_are_rejected(
        m in message(), start in 0..FRAME_LEN * 8, len in 1..=16usize, inner in any::<u16>()
    ) {
        let bytes = frame::encode(Address(3), Address::HOST, &m);
        let mut bad = bytes;
        let end = (start + len).min(FRAME_LEN * 8);
        for (i, bit) in (start..end).enumerate() {
            let edge = i == 0 || bit == end - 1;
            if edge || inner >> (i % 16) & 1 == 1 {
                bad[bit / 8] ^= 1 << (bit % 8);
            }
        }
        prop_assert_eq!(Frame::parse(&bad), Err(FrameError::BadCrc));
    }

    #[test]
    fn datagrams_round_trip(
        messages in proptest::collection::vec(message(), 1..=MAX_FRAMES),
        interface in any::<u8>(), seq in any::<u32>(), timestamp_us in any::<u64>(),
    ) {
        let frames: Vec<Frame> = messages.iter().map(|m| Frame::new(Address(9), Address::HOST, m)).collect();
        let header = DatagramHeader { interface, seq, timestamp_us };
        let mut buf = [0u8; interface::MAX_DATAGRAM];
        let len = interface::encode(header, &frames, &mut buf).unwrap();
        let d = Datagram::parse(&buf[..len]).unwrap();
        prop_assert_eq!(d.header(), header);
        let back: Vec<Frame> = d.frames().map(Result::unwrap).collect();
        prop_assert_eq!(back, frames);
    }

    #[test]
    fn arbitrary_datagrams_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..1600)) {
        if let Ok(d) = Datagram::parse(&bytes) {
            prop_assert_eq!(d.frames().count(), (bytes.len() - interface::HEADER_LEN) / FRAME_LEN);
            for f in d.frames() {
                let _ = f.map(|f| f.message());
            }
        }
    }

    /// A cell and an interface port take any bytes on any port at any time
    /// without panicking, and their invariants hold throughout.
    #[test]
    fn state_machines_take_any_input(
        inputs in proptest::collection::vec((port(), prop_oneof![
            message().prop_map(|m| (Address(7), Address::UNASSIGNED, Some(m))),
            (address(), address(), message()).prop_map(|(s, d, m)| (s, d, Some(m))),
            Just((Address(0), Address(0), None)),
        ], 0..20_000u64), 1..200)
    ) {
        let mut store = None;
        let mut cell: Cell = Cell::new(Config::default(), &store, 0);
        let mut sink = Sink::new(0, Config::default(), 0).unwrap();
        let mut now = 0;
        for (port, (src, dst, m), dt) in inputs {
            now += dt;
            let bytes = match m {
                Some(m) => frame::encode(src, dst, &m),
                None => [0xA5; FRAME_LEN],
            };
            cell.receive(Received { port, bytes: &bytes, meta: None }, now, &mut store, &mut ());
            cell.poll(now, &mut ());
            let _ = sink.receive(&bytes, now);
            sink.poll(now);
            let org = cell.organizer();
            if let Some(m) = org.master() {
                prop_assert!(org.is_active(m));
                prop_assert!(!org.is_child(m) || org.hops().is_some());
            }
            prop_assert!(cell.router().queued() <= 5 * 16 + 4 * 8 + 4 * 4);
            for p in Port::ALL {
                while cell.transmit(p).is_some() {}
            }
            while sink.transmit().is_some() {}
            prop_assert!(cell.poll_at() > now, "poll_at {} not after now {}", cell.poll_at(), now);
        }
    }

    #[test]
    fn allocated_ids_are_unique(requests in proptest::collection::vec((1..50u16, port()), 1..300), seen in proptest::collection::vec(1..400u16, 0..50)) {
        let mut a = Allocator::new();
        for s in &seen {
            a.observe(Address(*s));
        }
        let mut given = std::collections::HashMap::new();
        for (parent, port) in requests {
            let req = IdRequest { parent: Address(parent), port };
            let f = a.request(req).unwrap();
            let Message::IdAssign(assign) = f.message().unwrap() else { unreachable!() };
            prop_assert!(!seen.contains(&assign.id.0));
            prop_assert_eq!(f.dst(), Address(parent));
            // The same request gets the same ID; different ones never share.
            let prev = given.insert(assign.id, req);
            prop_assert!(prev.is_none() || prev == Some(req));
        }
    }
}
