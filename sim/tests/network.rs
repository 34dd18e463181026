//! The network simulator on small skins: self-organization, single-link
//! cuts, bit errors, reboots, the ledger, determinism (with recycled
//! datagram buffers too), the round-robin bound, traffic fractions, graph
//! files and UDP on loopback.
//!
//! The large runs (10,000 cells, the 5x capacity of event-driven traffic)
//! are `#[ignore]`d: `cargo test --release -p skin-sim --test network -- --ignored`.

use skin_protocol::message::TrafficMode;
use skin_sim::network::fault::{Fault, FaultKind};
use skin_sim::network::host::Host;
use skin_sim::network::scenario::pump;
use skin_sim::network::stimulus::StimulusKind;
use skin_sim::network::topology::PortRef;
use skin_sim::network::transport::Transport;
use skin_sim::network::{Network, NetworkConfig, NetworkReport, Scenario, Topology};

fn config(traffic: TrafficMode, stimulus: StimulusKind, seed: u64) -> NetworkConfig {
    NetworkConfig { traffic, stimulus, seed, ..NetworkConfig::default() }
}

fn patch(rows: usize, cols: usize, interfaces: usize) -> Topology {
    Topology::hex(rows, cols).and_then(|t| t.with_interfaces(interfaces)).unwrap()
}

fn run(scenario: &Scenario) -> NetworkReport {
    scenario.run(&mut Transport::memory(), &mut |_| {}).unwrap()
}

fn organized(r: &NetworkReport) {
    assert!(r.organize_time_s.is_some(), "did not organize: {}", r.summary());
    assert!(r.ids_unique, "{}", r.summary());
    assert_eq!(r.neighbours_correct, Some(true), "{}", r.summary());
    assert_eq!(r.cells_attached, r.cells_reachable, "{}", r.summary());
    assert!(r.ledger_balanced, "{}", r.summary());
}

#[test]
fn a_patch_with_two_interface_ports_organizes() {
    for seed in 0..3 {
        let r = run(&Scenario::new(patch(4, 5, 2), config(TrafficMode::Clock, StimulusKind::Quiet, seed), 0.2));
        organized(&r);
        assert_eq!(r.cells_reachable, 20);
        assert!(r.delivered > 0 && r.dropped == 0, "{}", r.summary());
    }
}

/// A 3x4 patch with its two interface ports on opposite corners, one of
/// them the only cell with a single link, so no single cut can cut a cell
/// off.
fn redundant_patch() -> Topology {
    let t = Topology::hex(3, 4).unwrap();
    let peers = t.peers();
    let leaves: Vec<usize> = (0..t.cells()).filter(|c| peers[*c].iter().flatten().count() == 1).collect();
    assert_eq!(leaves, [0]);
    let free = t.free_ports();
    let interfaces = [0, t.cells() - 1].map(|c| *free.iter().find(|p| p.cell == c).unwrap()).to_vec();
    Topology::new(t.cells(), Some(t.positions_m().to_vec()), t.links().to_vec(), interfaces).unwrap()
}

#[test]
fn every_single_cut_loses_no_cell_and_counts_what_it_loses() {
    let topology = redundant_patch();
    let cuts: Vec<PortRef> =
        topology.links().iter().map(|(a, _)| *a).chain(topology.interfaces().iter().copied()).collect();
    let mut lost = 0;
    for (k, at) in cuts.iter().enumerate() {
        let mut s = Scenario::new(topology.clone(), config(TrafficMode::Clock, StimulusKind::Quiet, k as u64), 0.6);
        s.faults.push(Fault { at_s: 0.05, kind: FaultKind::Cut(*at) });
        let r = run(&s);
        organized(&r);
        assert_eq!(r.cells_attached, 12, "cut {at:?} lost a cell: {}", r.summary());
        assert!(r.ids_kept, "cut {at:?}: {}", r.summary());
        lost += r.dropped;
    }
    assert!(lost > 0, "some cut loses frames on the wire or in a queue, and they are counted");
}

#[test]
fn bit_errors_are_rejected_never_accepted() {
    for ber in [1e-5, 1e-3] {
        let mut c = config(TrafficMode::Clock, StimulusKind::Touch, 5);
        c.bit_error_rate = ber;
        let r = run(&Scenario::new(patch(3, 3, 2), c, 2.0));
        assert!(r.ids_unique && r.ledger_balanced, "{}", r.summary());
        assert!(r.corrupt_rejected > 0, "ber {ber}: {}", r.summary());
        assert_eq!(r.corrupt_accepted, 0, "ber {ber}: {}", r.summary());
        assert!(r.dropped_by_reason.corrupt > 0 && r.dropped_by_reason.corrupt <= r.corrupt_rejected);
    }
}

#[test]
fn reboots_keep_ids_dead_cells_and_interface_ports_are_routed_around() {
    let mut s = Scenario::new(patch(3, 4, 2), config(TrafficMode::Clock, StimulusKind::Quiet, 2), 0.8);
    s.faults = vec![
        Fault { at_s: 0.05, kind: FaultKind::Reboot(5) },
        Fault { at_s: 0.1, kind: FaultKind::Dead(11) },
        Fault { at_s: 0.2, kind: FaultKind::InterfaceDown(0) },
    ];
    let r = run(&s);
    organized(&r);
    assert!(r.ids_kept, "{}", r.summary());
    assert_eq!(r.cells_reachable, 11, "the dead cell is gone, the rest reach interface 1");
    assert!(r.dropped_by_reason.dead_cell + r.dropped_by_reason.dead_interface > 0, "{}", r.summary());
}

#[test]
fn an_overloaded_interface_port_drops_frames_with_a_reason() {
    // 81 cells at 250 Hz on one port: more than its link carries.
    let mut s = Scenario::new(patch(9, 9, 1), config(TrafficMode::Clock, StimulusKind::Quiet, 1), 0.5);
    s.organize_timeout_s = 0.5;
    let r = run(&s);
    assert!(r.ids_unique && r.ledger_balanced, "{}", r.summary());
    assert!(r.dropped_by_reason.queue_full > 0 && !r.meets_rate, "{}", r.summary());
    assert!(r.sensor_dropped_while_measuring > 0, "{}", r.summary());
    assert!(r.sensor_dropped_while_measuring <= r.dropped_while_measuring && r.dropped_while_measuring <= r.dropped);
    assert!(r.delivered > 0);
}

/// Everything observable of a run: the datagrams to the host, byte for
/// byte, and the report without its wall time. With `recycle`, every
/// datagram's buffer goes back to the network scribbled over and longer.
fn trace(seed: u64, recycle: bool) -> (Vec<(u64, Vec<u8>)>, String) {
    let c = config(TrafficMode::Event, StimulusKind::Touch, seed);
    let mut net = Network::new(&patch(3, 3, 2), c).unwrap();
    let mut host = Host::new();
    let mut seen = Vec::new();
    while let Some(mut d) = net.step(300_000_000) {
        for reply in host.receive(&d.bytes) {
            net.inject(&reply).unwrap();
        }
        seen.push((d.at_ns, d.bytes.clone()));
        if recycle {
            d.bytes.iter_mut().for_each(|b| *b = 0xA5);
            d.bytes.resize(1_500, 0x5A);
            net.recycle(d);
        }
    }
    let mut r = run(&Scenario::new(patch(3, 3, 2), c, 0.3));
    r.wall_time_s = 0.0;
    (seen, serde_json::to_string(&r).unwrap())
}

#[test]
fn same_seed_same_result_byte_for_byte() {
    let (a, ra) = trace(42, false);
    let (b, rb) = trace(42, false);
    assert!(!a.is_empty());
    assert!(a == b, "datagrams differ");
    assert_eq!(ra, rb);
    let (c, _) = trace(43, false);
    assert!(a != c, "the seed changes nothing");
    let (r, _) = trace(42, true);
    assert!(a == r, "a recycled buffer's old bytes reach a later datagram");
}

#[test]
fn the_hrp2_skin_meets_250_hz_within_the_round_robin_bound() {
    let r = run(&Scenario::new(Topology::hrp2(), config(TrafficMode::Clock, StimulusKind::Touch, 1), 1.0));
    organized(&r);
    assert_eq!((r.cells, r.interfaces), (74, 5));
    assert!(r.meets_rate, "{}", r.summary());
    assert!(r.latency_us.max < 4_000, "{}", r.summary());
    assert!(r.forwarding_delay.head_of_line_max_us > 0.0);
    assert!(
        r.forwarding_delay.head_of_line_max_us <= r.model.forwarding_with_control_us,
        "a frame at the head of its queue waited longer than round robin allows: {}",
        r.summary()
    );
    assert!(r.event_latency_us.count > 0, "the touch makes tactile events");
}

#[test]
fn clock_driven_capacity_is_the_link_model_and_events_send_less() {
    let clock = run(&Scenario::new(patch(4, 4, 1), config(TrafficMode::Clock, StimulusKind::Quiet, 3), 0.5));
    organized(&clock);
    assert!(clock.traffic.fraction_of_clock >= 1.0);
    assert_eq!(
        clock.max_cells_per_interface_at_rate,
        Some(clock.model.cells_per_interface_with_control),
        "{}",
        clock.summary()
    );
    let quiet = run(&Scenario::new(patch(4, 4, 1), config(TrafficMode::Event, StimulusKind::Quiet, 3), 0.5));
    let grasp = run(&Scenario::new(patch(4, 4, 1), config(TrafficMode::Event, StimulusKind::Grasp, 3), 5.0));
    assert!(quiet.traffic.fraction_of_clock < 0.05, "{}", quiet.summary());
    assert!(grasp.traffic.fraction_of_clock > quiet.traffic.fraction_of_clock, "{}", grasp.summary());
    assert!(grasp.traffic.fraction_of_clock < 1.0, "{}", grasp.summary());
    let clock_cells = clock.max_cells_per_interface_at_rate.unwrap();
    assert!(quiet.max_cells_per_interface_at_rate.is_none_or(|n| n > 5 * clock_cells), "{}", quiet.summary());
}

#[test]
fn graph_files_in_toml_and_json() {
    let dir = std::env::temp_dir().join(format!("skin-sim-network-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    // A ring of four cells, two interface ports.
    let toml =
        "cells = 4\nlinks = [[0, 0, 1, 2], [1, 1, 2, 3], [2, 2, 3, 0], [3, 1, 0, 3]]\ninterfaces = [[0, 1], [2, 0]]\n";
    let json = r#"{"cells": 4, "links": [[0, 0, 1, 2], [1, 1, 2, 3], [2, 2, 3, 0], [3, 1, 0, 3]], "interfaces": [[0, 1], [2, 0]]}"#;
    for (name, text) in [("ring.toml", toml), ("ring.json", json)] {
        let path = dir.join(name);
        std::fs::write(&path, text).unwrap();
        let t = Topology::parse(path.to_str().unwrap()).unwrap();
        assert_eq!((t.cells(), t.links().len(), t.interfaces().len()), (4, 4, 2));
        organized(&run(&Scenario::new(t, NetworkConfig::default(), 0.1)));
    }
    for (name, text) in [
        ("twice.toml", "cells = 2\nlinks = [[0, 0, 1, 2], [0, 0, 1, 1]]\n"),
        ("port.toml", "cells = 2\nlinks = [[0, 4, 1, 2]]\n"),
        ("unknown.toml", "cells = 2\nwires = []\n"),
        ("bad.json", "{\"cells\": -1}"),
        ("ring.yaml", "cells: 4"),
    ] {
        let path = dir.join(name);
        std::fs::write(&path, text).unwrap();
        assert!(Topology::parse(path.to_str().unwrap()).is_err(), "{name}");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_host_on_loopback_organizes_the_skin_over_real_udp() {
    let socket = std::net::UdpSocket::bind("127.0.0.1:0").unwrap();
    socket.set_read_timeout(Some(std::time::Duration::from_millis(50))).unwrap();
    let host_addr = socket.local_addr().unwrap();
    let mut transport = Transport::udp(host_addr, "127.0.0.1:0".parse().unwrap()).unwrap();
    let sim_addr = transport.local_addr().unwrap();
    let stop = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
    let host = {
        let stop = stop.clone();
        std::thread::spawn(move || {
            let mut host = Host::new();
            let mut buf = [0u8; 2048];
            let mut received = 0;
            while !stop.load(std::sync::atomic::Ordering::Relaxed) {
                if let Ok((n, from)) = socket.recv_from(&mut buf) {
                    assert_eq!(from, sim_addr);
                    received += 1;
                    for reply in host.receive(&buf[..n]) {
                        socket.send_to(&reply, from).unwrap();
                    }
                }
            }
            received
        })
    };
    let mut net = Network::new(&patch(2, 3, 1), NetworkConfig::default()).unwrap();
    pump(&mut net, &mut transport, 300_000_000).unwrap();
    stop.store(true, std::sync::atomic::Ordering::Relaxed);
    assert!(host.join().unwrap() > 0);
    let ids: Vec<_> = (0..net.cells()).filter_map(|i| net.cell(i)).map(|c| c.id()).collect();
    assert!(ids.iter().all(|a| a.is_cell()), "{ids:?}");
    assert!(Transport::udp("10.0.0.1:9".parse().unwrap(), "127.0.0.1:0".parse().unwrap()).is_err());
}

/// 10,000 cells, 16 interface ports: self-organization at scale.
#[test]
#[ignore]
fn ten_thousand_cells_with_sixteen_ports_organize() {
    let r = run(&Scenario::new(patch(100, 100, 16), config(TrafficMode::Event, StimulusKind::Quiet, 0), 0.1));
    println!("{}", r.summary());
    organized(&r);
    assert_eq!(r.cells_reachable, 10_000);
}

/// Event-driven traffic on the grasp, with the firmware's default
/// send-on-delta thresholds (1% of full scale for proximity and force,
/// Table 3's finest step), serves five times the 80 cells the paper gives
/// one interface port at 250 Hz: 400 cells on one port, every tactile event
/// and every sensor frame within 4 ms, none lost.
#[test]
#[ignore]
fn event_driven_grasp_serves_five_times_the_cells_of_clock_driven() {
    let r = run(&Scenario::new(patch(20, 20, 1), config(TrafficMode::Event, StimulusKind::Grasp, 0), 14.0));
    println!("{}", r.summary());
    organized(&r);
    assert!(r.event_latency_us.count > 1000, "{}", r.summary());
    assert!(r.event_latency_us.max < 4_000 && r.latency_us.max < 4_000, "{}", r.summary());
    assert!(r.meets_rate && r.sensor_dropped_while_measuring == 0, "{}", r.summary());
}

/// Everything one run with scripted host actions shows: the datagrams to
/// the host, what was measured (less the count of simulator events), the
/// routers' counters, and how many events it took.
fn scripted(topology: &Topology, stimulus: StimulusKind, skip: bool) -> (Vec<(u64, Vec<u8>)>, String, u64) {
    use skin_protocol::interface::{self, DatagramHeader, MAX_DATAGRAM};
    use skin_protocol::message::{ConfigWrite, Message, Setting};
    use skin_protocol::{Address, Frame, Sample};
    let config = NetworkConfig { skip_resting_cells: skip, ..config(TrafficMode::Event, stimulus, 7) };
    let mut net = Network::new(topology, config).unwrap();
    let mut host = Host::new();
    let mut seen = Vec::new();
    let mut run_to = |net: &mut Network, until_s: f64| {
        while let Some(d) = net.step((until_s * 1e9) as u64) {
            for reply in host.receive(&d.bytes) {
                net.inject(&reply).unwrap();
            }
            seen.push((d.at_ns, d.bytes));
        }
    };
    run_to(&mut net, 0.5);
    net.measure_from();
    // The last cell is far from where both stimuli start.
    let far = topology.cells() - 1;
    for (at_s, fault) in [(0.8, FaultKind::Reboot(far)), (1.0, FaultKind::Dead(far - 1))] {
        net.schedule_fault((at_s * 1e9) as u64, fault).unwrap();
    }
    run_to(&mut net, 1.2);
    // Settings for resting cells: one of them changes its processing.
    assert!((far - 3..far - 1).all(|c| net.is_resting(c) == skip));
    for (cell, setting) in
        [(far - 2, Setting::Delta { channel: 1, counts: 30 }), (far - 3, Setting::Traffic(TrafficMode::Clock))]
    {
        let c = net.cell(cell).unwrap();
        let write = Message::ConfigWrite(ConfigWrite { tag: 1, setting });
        let frame = Frame::new(Address::HOST, c.id(), &write);
        let header = DatagramHeader { interface: c.organizer().interface().unwrap(), seq: 0, timestamp_us: 0 };
        let mut buf = [0u8; MAX_DATAGRAM];
        let len = interface::encode(header, &[frame], &mut buf).unwrap();
        net.inject(&buf[..len]).unwrap();
    }
    run_to(&mut net, 3.0);
    // Readings from outside wake every cell.
    let fed: Vec<Sample> =
        (0..net.cells()).map(|_| Sample::saturating(1_300, [600; 3], [0, 0, 256], 1_000, 0)).collect();
    net.feed(&fed).unwrap();
    assert!((0..net.cells()).all(|c| !net.is_resting(c)));
    run_to(&mut net, 3.1);
    let mut m = net.measurements();
    let events = std::mem::take(&mut m.events);
    assert!(net.balanced());
    (seen, format!("{m:?} {:?}", net.router_counters()), events)
}

/// Resting cells skip their samples, and the run is the same as without:
/// every datagram, every count, with faults, settings and fed readings.
#[test]
fn resting_cells_change_nothing_but_the_cost() {
    let wide = patch(4, 40, 2);
    let tall = patch(40, 4, 2);
    for (topology, stimulus) in
        [(&wide, StimulusKind::Touch), (&tall, StimulusKind::Grasp), (&wide, StimulusKind::Quiet)]
    {
        let (skipping, measured, events) = scripted(topology, stimulus, true);
        let (every, measured_every, events_every) = scripted(topology, stimulus, false);
        assert!(skipping == every, "{stimulus:?}: the datagrams differ");
        assert_eq!(measured, measured_every, "{stimulus:?}");
        assert!(events * 10 < events_every * 9, "{stimulus:?}: {events} events, {events_every} without resting");
    }
    // And the reports of whole runs with faults.
    let mut s = Scenario::new(wide.clone(), config(TrafficMode::Event, StimulusKind::Touch, 3), 1.0);
    s.faults = vec![
        Fault { at_s: 0.2, kind: FaultKind::Reboot(150) },
        Fault { at_s: 0.3, kind: FaultKind::Cut(PortRef::new(100, skin_protocol::Port::P1)) },
    ];
    let report = |skip: bool| {
        let mut s = s.clone();
        s.config.skip_resting_cells = skip;
        let mut r = run(&s);
        (r.events, r.wall_time_s) = (0, 0.0);
        serde_json::to_string(&r).unwrap()
    };
    assert_eq!(report(true), report(false));
}
