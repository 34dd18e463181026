//! The fuzz targets' short run on the stable toolchain, in CI: each body
//! over valid seeds, the seeds spoiled (bytes flipped, put in, cut) and
//! random bytes. `PROPTEST_CASES=1000000` runs it longer; the
//! coverage-guided run is `cargo fuzz` in `fuzz/` (README, Reliability).

use proptest::prelude::*;
use skin_fuzz_targets::TARGETS;
use skin_host::config::Config;
use skin_host::control::params::Params;
use skin_protocol::interface::{encode, DatagramHeader, MAX_DATAGRAM};
use skin_protocol::message::{IdRequest, Port};
use skin_protocol::robot_link::{self, FromRobot, ToRobot};
use skin_protocol::{Address, Frame, Message, Sample};

/// Valid inputs of each target, in [`TARGETS`] order.
fn seeds() -> [Vec<Vec<u8>>; TARGETS.len()] {
    let sample = Sample::new(100, [1, 2, 3], [0, 0, 256], 900, 7).unwrap();
    let frames = [
        Frame::new(Address(3), Address::HOST, &Message::Sample(sample)),
        Frame::new(
            Address::UNASSIGNED,
            Address::HOST,
            &Message::IdRequest(IdRequest { parent: Address(0xFF00), port: Port::P2 }),
        ),
    ];
    let mut buf = [0u8; MAX_DATAGRAM];
    let len = encode(DatagramHeader { interface: 0, seq: 1, timestamp_us: 7 }, &frames, &mut buf).unwrap();
    let link = |m: &dyn Fn(&mut [u8]) -> usize| {
        let mut out = [0u8; robot_link::MAX_DATAGRAM];
        let n = m(&mut out);
        out[..n].to_vec()
    };
    let command = ToRobot::Command { seq: 4, velocities: [0.1, -0.2].into_iter().collect() };
    let state = FromRobot::State { seq: 4, time_us: 8000, positions: [0.3, 0.4].into_iter().collect() };
    [
        frames.iter().map(|f| f.as_bytes().to_vec()).collect(),
        vec![buf[..len].to_vec()],
        vec![
            link(&|out| robot_link::encode(&command, out).unwrap()),
            link(&|out| robot_link::encode(&state, out).unwrap()),
        ],
        vec![skin_model::robot::hrp2::urdf().into_bytes()],
        vec![
            Config::default().to_toml().into_bytes(),
            Params::default().to_toml().into_bytes(),
            b"hex:3x4+hex:2x2".to_vec(),
        ],
    ]
}

#[test]
fn every_seed_is_accepted_by_its_target() {
    for ((name, body), seeds) in TARGETS.iter().zip(seeds()) {
        for seed in seeds {
            assert!(body(&seed), "{name} refuses its seed {:?}", String::from_utf8_lossy(&seed));
        }
    }
}

/// How a seed is spoiled at a byte: flipped by a mask, a byte put in, or cut there.
#[derive(Clone, Debug)]
enum Edit {
    Flip(usize, u8),
    Insert(usize, u8),
    Cut(usize),
}

fn edit() -> impl Strategy<Value = Edit> {
    prop_oneof![
        4 => (any::<usize>(), 1..=u8::MAX).prop_map(|(at, mask)| Edit::Flip(at, mask)),
        2 => (any::<usize>(), any::<u8>()).prop_map(|(at, byte)| Edit::Insert(at, byte)),
        1 => any::<usize>().prop_map(Edit::Cut),
    ]
}

fn spoil(mut bytes: Vec<u8>, edits: &[Edit]) -> Vec<u8> {
    for e in edits {
        let at = |i: usize| i % (bytes.len() + 1);
        match *e {
            Edit::Flip(i, mask) if !bytes.is_empty() => {
                let i = i % bytes.len();
                bytes[i] ^= mask;
            }
            Edit::Flip(..) => {}
            Edit::Insert(i, byte) => bytes.insert(at(i), byte),
            Edit::Cut(i) => bytes.truncate(at(i)),
        }
    }
    bytes
}

proptest! {
    #[test]
    fn spoiled_seeds_are_accepted_or_refused_never_a_panic(
        which in 0..TARGETS.len(), pick in any::<usize>(), edits in proptest::collection::vec(edit(), 1..6),
    ) {
        let seeds = &seeds()[which];
        let input = spoil(seeds[pick % seeds.len()].clone(), &edits);
        (TARGETS[which].1)(&input);
    }

    #[test]
    fn any_bytes_are_accepted_or_refused_never_a_panic(
        which in 0..TARGETS.len(), bytes in proptest::collection::vec(any::<u8>(), 0..1600),
    ) {
        (TARGETS[which].1)(&bytes);
    }
}
