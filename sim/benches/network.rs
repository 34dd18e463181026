//! How fast the network simulator runs against real time.
//!
//! - The 74-cell HRP-2 skin (five interface ports), clock-driven at 250 Hz
//!   under a moving touch (the goal: 100 times real time).
//! - A 10,000-cell skin (100x100 patch, 16 interface ports), event-driven
//!   at 250 Hz under a moving touch (the goal: 3 times real time), with
//!   the default periods (10 ms beacon waves, 100 ms keep-alive).
//! - One hop of the protocol code alone (a cell takes a frame from a child
//!   port and sends it on its master port), no simulator around it: the
//!   HRP-2 run's frame arrivals per virtual second times this cost is the
//!   ceiling of any simulator that runs the real protocol code.
//!
//! Each network is organized first; the benchmark then times further
//! virtual time and prints the speed-up (by wall time, and by the CPU time
//! of the simulating thread, which leaves out the time it waited for a core
//! on a busy machine) with the run's quality (latency, losses, the ledger)
//! and its events and frame arrivals per virtual second beside it.
//!
//! `cargo bench -p skin-sim --bench network` (built with the bench
//! profile's LTO, see `Cargo.toml`)

use std::hint::black_box;
use std::time::{Duration, Instant};

use criterion::{criterion_group, criterion_main, Criterion, SamplingMode};
use skin_protocol::address::Address;
use skin_protocol::cell::{Arrived, Cell};
use skin_protocol::frame::Frame;
use skin_protocol::message::{Beacon, Message, Port, Probe, TrafficMode};
use skin_protocol::organize::Config;
use skin_protocol::Sample;
use skin_sim::network::scenario::pump;
use skin_sim::network::stimulus::StimulusKind;
use skin_sim::network::transport::Transport;
use skin_sim::network::{Network, NetworkConfig, Topology};

/// CPU time of this thread in ns, where the system tells it (Linux). On a
/// machine shared with other builds, wall time also counts the time the
/// thread waited for a core; the CPU time does not.
fn thread_cpu_ns() -> Option<u64> {
    let stat = std::fs::read_to_string("/proc/thread-self/schedstat").ok()?;
    stat.split_whitespace().next()?.parse().ok()
}

/// Builds and organizes a network, then reports speed over `slice_s`
/// slices; returns the frame arrivals per virtual second (`None` when a
/// filter left the benchmark out).
fn speed(
    c: &mut Criterion,
    name: &str,
    topology: Topology,
    config: NetworkConfig,
    organize_s: f64,
    slice_s: f64,
) -> Option<f64> {
    let mut net = Network::new(&topology, config).expect("a valid network");
    let mut host = Transport::memory();
    let wall = Instant::now();
    pump(&mut net, &mut host, (organize_s * 1e9) as u64).expect("in-memory host");
    let organize_wall = wall.elapsed().as_secs_f64();
    let ids = (0..net.cells()).filter(|i| net.cell(*i).is_some_and(|c| c.id().is_cell())).count();
    net.measure_from();
    let received_before = net.measurements().ledger.received;
    let (mut simulated, mut spent, mut cpu_ns) = (0.0, 0.0, Some(0));
    let mut group = c.benchmark_group("network");
    group.sampling_mode(SamplingMode::Flat);
    group.bench_function(name, |b| {
        b.iter_custom(|iters| {
            let (start, cpu_start) = (Instant::now(), thread_cpu_ns());
            for _ in 0..iters {
                let until = net.now_ns() + (slice_s * 1e9) as u64;
                pump(&mut net, &mut host, until).expect("in-memory host");
            }
            let t = start.elapsed();
            cpu_ns = cpu_ns.zip(cpu_start).zip(thread_cpu_ns()).map(|((sum, a), b)| sum + b - a);
            simulated += iters as f64 * slice_s;
            spent += t.as_secs_f64();
            t
        })
    });
    group.finish();
    if simulated == 0.0 {
        return None;
    }
    let m = net.measurements();
    let lat = m.latency.quantiles();
    let virtual_s = m.measured_ns as f64 * 1e-9;
    let arrivals = (m.ledger.received - received_before) as f64 / virtual_s;
    let cpu = cpu_ns.map_or("unknown".into(), |ns| {
        let s = ns as f64 * 1e-9;
        format!("{:.2}x, {:.0} ns per event", simulated / s, s * 1e9 / m.events as f64)
    });
    println!(
        "{name}: {cells} cells, {ids} with IDs after {organize_s} s virtual ({organize_wall:.2} s wall); \
         {simulated:.2} s simulated in {spent:.2} s wall = {x:.2}x real time \
         (per second of the thread's CPU time: {cpu}) ({events:.2}M events and {arrivals_m:.2}M frame arrivals per virtual s, {ns:.0} ns per event); \
         sensor latency p99 {p99} us max {max} us; sensor frames lost {lost}; balanced {bal}",
        cells = net.cells(),
        x = simulated / spent,
        events = m.events as f64 / virtual_s / 1e6,
        arrivals_m = arrivals / 1e6,
        p99 = lat.p99,
        max = lat.max,
        ns = spent * 1e9 / m.events as f64,
        lost = m.ledger.sensor_dropped - m.sensor_dropped_before,
        bal = net.balanced(),
    );
    Some(arrivals)
}

/// One hop of the protocol code alone: a settled cell takes a sample from
/// its child on port 1 and sends it on its master port 0. Returns the cost
/// in ns (`None` when a filter left it out).
fn hop(c: &mut Criterion) -> Option<f64> {
    let mut store = Some(Address(5));
    let mut cell: Cell = Cell::new(Config::default(), &store, 0);
    let sink = Address::interface(0).expect("interface 0");
    let beacon = Frame::new(sink, Address::BROADCAST, &Message::Beacon(Beacon { interface: 0, seq: 1, hops: 0 }));
    cell.receive_frame(Arrived { port: Port::P0, frame: beacon, meta: None }, 0, &mut store, &mut ());
    let probe = Probe { port: Port::P2, id: Address(9), master: true, known: true, lost: false };
    let probe = Frame::new(Address(9), Address::BROADCAST, &Message::Probe(probe));
    cell.receive_frame(Arrived { port: Port::P1, frame: probe, meta: None }, 0, &mut store, &mut ());
    for p in Port::ALL {
        while cell.transmit(p).is_some() {}
    }
    let sample = Frame::new(Address(9), Address::HOST, &Message::Sample(Sample::default()));
    let (mut hops, mut spent) = (0u64, 0.0);
    c.bench_function("protocol_hop", |b| {
        b.iter_custom(|iters| {
            let start = Instant::now();
            for _ in 0..iters {
                cell.receive_frame(
                    Arrived { port: Port::P1, frame: black_box(sample), meta: None },
                    1,
                    &mut store,
                    &mut (),
                );
                black_box(cell.transmit(Port::P0));
            }
            let t = start.elapsed();
            hops += iters;
            spent += t.as_secs_f64();
            t
        })
    });
    (hops > 0).then(|| spent * 1e9 / hops as f64)
}

fn benches(c: &mut Criterion) {
    let hrp2 = NetworkConfig { traffic: TrafficMode::Clock, stimulus: StimulusKind::Touch, ..NetworkConfig::default() };
    let arrivals = speed(c, "hrp2_74_cells_clock_250hz", Topology::hrp2(), hrp2, 1.0, 1.0);
    let big = Topology::hex(100, 100).and_then(|t| t.with_interfaces(16)).expect("a valid patch");
    let event =
        NetworkConfig { traffic: TrafficMode::Event, stimulus: StimulusKind::Touch, ..NetworkConfig::default() };
    speed(c, "hex_10000_cells_16_ports_event_250hz", big, event, 1.0, 0.2);
    match (hop(c), arrivals) {
        (Some(ns), Some(arrivals)) => println!(
            "protocol_hop: {ns:.1} ns per hop of the protocol code alone; the HRP-2 skin's {arrivals:.0} frame \
             arrivals per virtual s cap any simulator running that code at {cap:.0}x real time",
            cap = 1e9 / (arrivals * ns),
        ),
        (Some(ns), None) => println!("protocol_hop: {ns:.1} ns per hop of the protocol code alone"),
        (None, _) => {}
    }
}

criterion_group! {
    name = network;
    config = Criterion::default().sample_size(10).warm_up_time(Duration::from_millis(500)).measurement_time(Duration::from_secs(5));
    targets = benches
}
criterion_main!(network);
