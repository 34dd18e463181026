//! A firmware update of the HRP-2 skin (74 cells, 5 interface ports) in the
//! simulator, every cell running the real protocol code with 250 Hz
//! clock-driven sensor traffic going on: every cell ends on the new
//! version, and sensor latency stays within one period.
//!
//! `cargo test --release -p skin-sim --test update -- --nocapture` prints
//! the figures of the README.

use skin_protocol::image::{self, Board};
use skin_protocol::message::{Refusal, TrafficMode};
use skin_protocol::update::Outcome;
use skin_sim::network::host::Host;
use skin_sim::network::update::{organize, update, UpdateRun};
use skin_sim::network::{Network, NetworkConfig, Topology, UpdateSetup};

fn key(seed: u8) -> salty::Keypair {
    salty::Keypair::from(&[seed; 32])
}

/// A signed image of `len` body bytes, the size of the cell firmware.
fn image(board: Board, version: u32, len: usize, seed: u8) -> Vec<u8> {
    let body: Vec<u8> = (0..len).map(|i| (i * 131 + 17) as u8).collect();
    image::sign(&body, board, version, &[seed; 32]).unwrap()
}

fn hrp2_update(image: &[u8], per_ms: usize) -> UpdateRun {
    let config = NetworkConfig {
        traffic: TrafficMode::Clock,
        rate_hz: 250.0,
        skip_resting_cells: false,
        update: Some(UpdateSetup { key: key(1).public.to_bytes(), version: 1 }),
        ..NetworkConfig::default()
    };
    let mut net = Network::new(&Topology::hrp2(), config).unwrap();
    let mut host = Host::new();
    organize(&mut net, &mut host, 10_000_000_000).unwrap();
    let run = update(&mut net, &mut host, image, per_ms, 60_000_000_000).unwrap();
    println!("{} chunks, {per_ms} frames/ms per port, {} frames per port:", run.chunks, run.frames_per_port);
    for (name, p) in [("transfer", run.transfer), ("boot and confirm", run.boot)] {
        println!(
            "  {name}: {:.2} s; sensor latency p50 {} us, p99 {} us, max {} us over {} frames, {} dropped",
            p.time_s, p.latency_us.p50, p.latency_us.p99, p.latency_us.max, p.latency_us.count, p.sensor_dropped
        );
    }
    run
}

#[test]
fn the_hrp2_skin_updates_every_cell_with_sensor_latency_within_4_ms() {
    // 37,364 bytes: the size of today's cell-qemu firmware.
    let run = hrp2_update(&image(Board::Mps2An386, 2, 37_364, 1), 16);
    assert_eq!(run.outcomes.len(), 74);
    let not_updated: Vec<_> = run.outcomes.iter().filter(|(_, o)| *o != Outcome::Updated).collect();
    assert!(not_updated.is_empty(), "{not_updated:?}");
    // While the image flows the touch data keeps its bound; the restarts
    // into the new image are outages (measured, not bounded here).
    assert!(run.transfer.latency_us.max < 4_000, "{:?}", run.transfer);
    assert_eq!(run.transfer.sensor_dropped, 0);
    assert!(run.transfer.time_s + run.boot.time_s < 10.0, "{run:?}");
}

#[test]
fn a_forged_image_is_refused_by_every_cell_of_the_hrp2_skin() {
    let run = hrp2_update(&image(Board::Mps2An386, 2, 5_000, 9), 16);
    assert_eq!(run.outcomes.len(), 74);
    assert!(run.outcomes.iter().all(|(_, o)| *o == Outcome::Refused(Refusal::BadSignature)), "{:?}", run.outcomes);
}
