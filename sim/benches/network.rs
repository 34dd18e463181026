//! How fast the network simulator runs against real time.
//!
//! - The 74-cell HRP-2 skin (five interface ports), clock-driven at 250 Hz
//!   under a moving touch (the target: 1,000 times real time).
//! - A 10,000-cell skin (100x100 patch, 16 interface ports), event-driven
//!   at 250 Hz under a moving touch (the target: real time), with
//!   the default 10 ms keep-alive and beacon periods, and with 100 ms ones,
//!   the choice for a skin this large (a tenth of the control traffic; a
//!   broken link is noticed after 350 ms instead of 35 ms).
//!
//! Each network is organized first; the benchmark then times further
//! virtual time and prints the speed-up with the run's quality (latency,
//! losses, the ledger) and its events per virtual second beside it.
//!
//! `cargo bench -p skin-sim --bench network`

use std::time::{Duration, Instant};

use criterion::{criterion_group, criterion_main, Criterion, SamplingMode};
use skin_protocol::message::TrafficMode;
use skin_sim::network::scenario::pump;
use skin_sim::network::stimulus::StimulusKind;
use skin_sim::network::transport::Transport;
use skin_sim::network::{Network, NetworkConfig, Topology};

/// Builds and organizes a network, then reports speed over `slice_s` slices.
fn speed(c: &mut Criterion, name: &str, topology: Topology, config: NetworkConfig, organize_s: f64, slice_s: f64) {
    let mut net = Network::new(&topology, config).expect("a valid network");
    let mut host = Transport::memory();
    let wall = Instant::now();
    pump(&mut net, &mut host, (organize_s * 1e9) as u64).expect("in-memory host");
    let organize_wall = wall.elapsed().as_secs_f64();
    let ids = (0..net.cells()).filter(|i| net.cell(*i).is_some_and(|c| c.id().is_cell())).count();
    net.measure_from();
    let (mut simulated, mut spent) = (0.0, 0.0);
    let mut group = c.benchmark_group("network");
    group.sampling_mode(SamplingMode::Flat);
    group.bench_function(name, |b| {
        b.iter_custom(|iters| {
            let start = Instant::now();
            for _ in 0..iters {
                let until = net.now_ns() + (slice_s * 1e9) as u64;
                pump(&mut net, &mut host, until).expect("in-memory host");
            }
            let t = start.elapsed();
            simulated += iters as f64 * slice_s;
            spent += t.as_secs_f64();
            t
        })
    });
    group.finish();
    let m = net.measurements();
    let lat = m.latency.quantiles();
    println!(
        "{name}: {cells} cells, {ids} with IDs after {organize_s} s virtual ({organize_wall:.2} s wall); \
         {simulated:.2} s simulated in {spent:.2} s wall = {x:.2}x real time \
         ({events:.2}M events per virtual s, {ns:.0} ns per event); \
         sensor latency p99 {p99} us max {max} us; sensor frames lost {lost}; balanced {bal}",
        cells = net.cells(),
        x = simulated / spent,
        events = m.events as f64 / (m.measured_ns as f64 * 1e-9) / 1e6,
        p99 = lat.p99,
        max = lat.max,
        ns = spent * 1e9 / m.events as f64,
        lost = m.ledger.sensor_dropped - m.sensor_dropped_before,
        bal = net.balanced(),
    );
}

fn benches(c: &mut Criterion) {
    let hrp2 = NetworkConfig { traffic: TrafficMode::Clock, stimulus: StimulusKind::Touch, ..NetworkConfig::default() };
    speed(c, "hrp2_74_cells_clock_250hz", Topology::hrp2(), hrp2, 1.0, 1.0);
    let big = Topology::hex(100, 100).and_then(|t| t.with_interfaces(16)).expect("a valid patch");
    let event =
        NetworkConfig { traffic: TrafficMode::Event, stimulus: StimulusKind::Touch, ..NetworkConfig::default() };
    speed(c, "hex_10000_cells_16_ports_event_250hz", big.clone(), event, 1.0, 0.1);
    let slow = event.with_periods(100_000, 100_000).expect("valid periods");
    speed(c, "hex_10000_cells_16_ports_event_250hz_probe_beacon_100ms", big, slow, 1.0, 0.2);
}

criterion_group! {
    name = network;
    config = Criterion::default().sample_size(10).warm_up_time(Duration::from_millis(500)).measurement_time(Duration::from_secs(5));
    targets = benches
}
criterion_main!(network);
