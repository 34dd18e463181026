//! One run of a skin network: power up, self-organize, carry traffic under
//! a stimulus for a while with faults injected, and report what happened.

use std::collections::BTreeSet;
use std::time::Instant;

use serde::Serialize;
use skin_protocol::address::Address;
use skin_protocol::message::{Port, TrafficMode};

use super::fault::Fault;
use super::ledger::{Drops, Quantiles};
use super::model::Model;
use super::simulator::{Measurements, Network, NetworkConfig};
use super::stimulus::StimulusKind;
use super::topology::Topology;
use super::transport::Transport;
use super::NetworkError;

/// How often the run checks whether the skin has organized, and hands
/// datagrams between skin and host at the latest.
const CHECK_NS: u64 = 10_000_000;

/// The longest virtual time a scenario's times may name, s: far past any
/// run, and its nanoseconds still add to a clock in a `u64`.
pub const MAX_TIME_S: f64 = 1e9;

/// `s` if it is a virtual time in [0, [`MAX_TIME_S`]]; `what` names it in
/// the error (a flag, for the command line).
pub fn time_s(what: &str, s: f64) -> Result<f64, NetworkError> {
    if (0.0..=MAX_TIME_S).contains(&s) {
        Ok(s)
    } else {
        Err(NetworkError::Flag(format!("{what} {s:?}: give a number of seconds in [0, 1e9]")))
    }
}

/// A run to make.
#[derive(Clone, Debug)]
pub struct Scenario {
    /// The wiring.
    pub topology: Topology,
    /// Rates, traffic, stimulus, timing, seed.
    pub config: NetworkConfig,
    /// Virtual seconds of traffic after the skin has organized.
    pub duration_s: f64,
    /// Faults, timed from the end of self-organization.
    pub faults: Vec<Fault>,
    /// Virtual seconds self-organization may take before the traffic phase
    /// starts anyway.
    pub organize_timeout_s: f64,
}

/// Self-organization as checked against the wiring.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Organization {
    ids_unique: bool,
    neighbours_correct: Option<bool>,
    attached: usize,
    reachable: usize,
    max_tree_depth: u16,
}

/// Worst per-hop stay of an upstream frame in a cell.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Forwarding {
    /// Of frames that found their input queue empty: the round-robin bound.
    pub head_of_line_max_us: f64,
    /// Of all frames, queueing included.
    pub any_max_us: f64,
}

/// Every frame of every kind, hop by hop, over the whole run: put on a
/// wire, then received, lost on the wire or still on it; taken into a
/// queue, then sent, dropped by a router or lost with its cell, or still
/// queued.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub struct Frames {
    /// Put on a wire by a cell or an interface port.
    pub transmitted: u64,
    /// Arrived at a live receiver.
    pub received: u64,
    /// Sent into a free or cut port.
    pub lost_no_link: u64,
    /// Sent to a dead cell or interface port.
    pub lost_dead_receiver: u64,
    /// On a wire at the end.
    pub on_wires: u64,
    /// Dropped by a router because a queue was full.
    pub router_dropped_full: u64,
    /// Dropped by a router because the tree changed.
    pub router_dropped_reroute: u64,
    /// In the queues of cells that died or rebooted.
    pub lost_at_power_off: u64,
    /// From the host, refused by an interface port.
    pub host_frames_refused: u64,
    /// In router and interface queues at the end.
    pub queued: u64,
}

/// Sensor traffic during the measured time.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Traffic {
    /// Samples taken by cells with an ID.
    pub samples: u64,
    /// Sensor frames sent (samples and tactile events).
    pub data_frames: u64,
    /// Sensor frames per sample: clock-driven sends every sample (1.0, plus
    /// events); event-driven sends fewer.
    pub fraction_of_clock: f64,
    /// Sensor frames per cell and second in the busiest sampling period.
    pub peak_per_cell_hz: f64,
    /// Frames per second other than sensor data on the busiest interface link.
    pub control_per_interface_hz: f64,
}

/// What a run shows; `--json` prints it as one object.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct NetworkReport {
    /// Cells in the skin.
    pub cells: usize,
    /// Interface ports.
    pub interfaces: usize,
    /// Sampling rate.
    pub rate_hz: f64,
    /// `clock` or `event`.
    pub traffic_mode: &'static str,
    /// `quiet`, `touch` or `grasp`.
    pub stimulus: &'static str,
    /// The seed.
    pub seed: u64,
    /// Every powered cell that can reach an interface port has a cell ID,
    /// and no two have the same (at the end of the run).
    pub ids_unique: bool,
    /// The host's neighbour table equals the live wiring for every such
    /// cell (`null` when the host is not built in).
    pub neighbours_correct: Option<bool>,
    /// Virtual time until the skin first was organized (`null`: not within
    /// the timeout).
    pub organize_time_s: Option<f64>,
    /// Cells on a route to an interface port, of those that can reach one.
    pub cells_attached: usize,
    /// Cells that can reach an interface port over live links.
    pub cells_reachable: usize,
    /// Every cell that had an ID when the traffic started still has it.
    pub ids_kept: bool,
    /// Most hops from a cell to its interface port.
    pub max_tree_depth: u16,
    /// Upstream frames delivered to the host.
    pub delivered: u64,
    /// Upstream frames lost.
    pub dropped: u64,
    /// Upstream frames lost, by reason.
    pub dropped_by_reason: Drops,
    /// Upstream frames lost after the skin organized (while measuring).
    pub dropped_while_measuring: u64,
    /// Sensor frames (samples, tactile events) among them.
    pub sensor_dropped_while_measuring: u64,
    /// Upstream frames still queued or on a wire at the end.
    pub in_network: u64,
    /// Frames of any kind whose CRC (or payload check) failed at a receiver.
    pub corrupt_rejected: u64,
    /// Frames with flipped bits that a receiver accepted.
    pub corrupt_accepted: u64,
    /// Delivered + dropped + in the network = sent, for every frame.
    pub ledger_balanced: bool,
    /// Every frame of every kind, hop by hop.
    pub frames: Frames,
    /// Sensor frames, made to host, in microseconds.
    pub latency_us: Quantiles,
    /// Tactile events, made to host, in microseconds.
    pub event_latency_us: Quantiles,
    /// Worst stay in one cell.
    pub forwarding_delay: Forwarding,
    /// Sensor traffic.
    pub traffic: Traffic,
    /// Cells one interface port could serve with this run's traffic at its
    /// busiest: the interface link's frames per second, less its control
    /// traffic, over the busiest per-cell sensor rate (`null` when no
    /// cell sent any).
    pub max_cells_per_interface_at_rate: Option<u64>,
    /// The same before rounding down to whole cells.
    pub cells_per_interface: Option<f64>,
    /// Keep-alive period of settled links.
    pub keepalive_period_ms: f64,
    /// Beacon wave period of the interface ports.
    pub beacon_period_ms: f64,
    /// The worst sensor latency stayed within one sampling period and no
    /// sensor frame was lost while measuring.
    pub meets_rate: bool,
    /// The paper's figures from the link model.
    pub model: Model,
    /// Simulator events handled while measuring.
    pub events: u64,
    /// Virtual time simulated.
    pub sim_time_s: f64,
    /// Wall time the run took.
    pub wall_time_s: f64,
}

impl Scenario {
    /// A run of `topology` with default settings for `duration_s` seconds.
    pub fn new(topology: Topology, config: NetworkConfig, duration_s: f64) -> Scenario {
        Scenario { topology, config, duration_s, faults: Vec::new(), organize_timeout_s: 30.0 }
    }

    /// Runs it; `progress` hears the fraction of virtual time done.
    pub fn run(&self, transport: &mut Transport, progress: &mut dyn FnMut(f64)) -> Result<NetworkReport, NetworkError> {
        time_s("duration", self.duration_s)?;
        time_s("organize timeout", self.organize_timeout_s)?;
        let wall = Instant::now();
        let mut net = Network::new(&self.topology, self.config)?;
        let timeout_ns = (self.organize_timeout_s * 1e9) as u64;
        let total_s = self.organize_timeout_s.min(5.0) + self.duration_s;
        let mut organize_time_s = None;
        while net.now_ns() < timeout_ns {
            let until = net.now_ns() + CHECK_NS;
            pump(&mut net, transport, until)?;
            progress((net.now_ns() as f64 * 1e-9 / total_s).min(1.0));
            let o = organization(&net, transport);
            if o.ids_unique && o.neighbours_correct != Some(false) && o.attached == o.reachable {
                organize_time_s = Some(net.now_ns() as f64 * 1e-9);
                break;
            }
        }
        let ids_before: Vec<Option<Address>> = (0..net.cells()).map(|i| net.cell(i).map(|c| c.id())).collect();
        let start_ns = net.now_ns();
        net.measure_from();
        for f in &self.faults {
            net.schedule_fault(start_ns + (f.at_s * 1e9) as u64, f.kind)?;
        }
        let end_ns = start_ns + (self.duration_s * 1e9) as u64;
        while net.now_ns() < end_ns {
            let until = (net.now_ns() + CHECK_NS).min(end_ns);
            pump(&mut net, transport, until)?;
            let done = (net.now_ns() - start_ns) as f64 * 1e-9;
            progress(((start_ns as f64 * 1e-9 + done) / (start_ns as f64 * 1e-9 + self.duration_s)).min(1.0));
        }
        let o = organization(&net, transport);
        let ids_kept = ids_before.iter().enumerate().all(|(i, before)| match (before, net.cell(i)) {
            (Some(b), Some(c)) if b.is_cell() => c.id() == *b,
            _ => true,
        });
        Ok(self.report(&net, o, organize_time_s, ids_kept, wall.elapsed().as_secs_f64()))
    }

    fn report(
        &self,
        net: &Network,
        o: Organization,
        organize_time_s: Option<f64>,
        ids_kept: bool,
        wall_time_s: f64,
    ) -> NetworkReport {
        let c = &self.config;
        let m: Measurements = net.measurements();
        let l = &m.ledger;
        let measured_s = (m.measured_ns as f64 * 1e-9).max(1e-9);
        let period_s = 1.0 / f64::from(c.rate_hz);
        let live = (0..net.cells()).filter(|i| net.cell(*i).is_some()).count().max(1);
        let peak_per_cell_hz = m.peak_data_frames_per_period as f64 / live as f64 / period_s;
        let control_hz =
            m.interface_frames.iter().map(|(all, data)| (all - data) as f64 / measured_s).fold(0.0, f64::max);
        let model = Model::new(&c.timing, f64::from(c.rate_hz), &c.organize);
        let capacity = (c.timing.frames_per_s() - control_hz).max(0.0);
        let cells_per_interface = (peak_per_cell_hz > 0.0).then(|| capacity / peak_per_cell_hz);
        let latency_us = m.latency.quantiles();
        NetworkReport {
            cells: net.cells(),
            interfaces: net.interfaces(),
            rate_hz: f64::from(c.rate_hz),
            traffic_mode: match c.traffic {
                TrafficMode::Clock => "clock",
                TrafficMode::Event => "event",
            },
            stimulus: match c.stimulus {
                StimulusKind::Quiet => "quiet",
                StimulusKind::Touch => "touch",
                StimulusKind::Grasp => "grasp",
            },
            seed: c.seed,
            ids_unique: o.ids_unique,
            neighbours_correct: o.neighbours_correct,
            organize_time_s,
            cells_attached: o.attached,
            cells_reachable: o.reachable,
            ids_kept,
            max_tree_depth: o.max_tree_depth,
            delivered: l.delivered,
            dropped: l.dropped.total(),
            dropped_by_reason: l.dropped,
            dropped_while_measuring: l.dropped.total() - m.dropped_before.total(),
            sensor_dropped_while_measuring: l.sensor_dropped - m.sensor_dropped_before,
            in_network: net.upstream_in_network(),
            corrupt_rejected: l.corrupt_rejected,
            corrupt_accepted: l.corrupt_accepted,
            ledger_balanced: net.balanced(),
            frames: {
                let r = net.router_counters();
                Frames {
                    transmitted: l.transmitted,
                    received: l.received,
                    lost_no_link: l.lost_no_link,
                    lost_dead_receiver: l.lost_dead_receiver,
                    on_wires: net.on_wires(),
                    router_dropped_full: u64::from(r.dropped_full),
                    router_dropped_reroute: u64::from(r.dropped_reroute),
                    lost_at_power_off: l.lost_at_power_off,
                    host_frames_refused: l.host_frames_refused,
                    queued: net.queued(),
                }
            },
            latency_us,
            event_latency_us: m.event_latency.quantiles(),
            forwarding_delay: Forwarding {
                head_of_line_max_us: m.forwarding_head_ns as f64 / 1e3,
                any_max_us: m.forwarding_any_ns as f64 / 1e3,
            },
            traffic: Traffic {
                samples: m.samples,
                data_frames: m.data_frames,
                fraction_of_clock: if m.samples > 0 { m.data_frames as f64 / m.samples as f64 } else { 0.0 },
                peak_per_cell_hz,
                control_per_interface_hz: control_hz,
            },
            max_cells_per_interface_at_rate: cells_per_interface.map(|n| n.floor() as u64),
            cells_per_interface,
            keepalive_period_ms: c.organize.keepalive_period_us as f64 / 1e3,
            beacon_period_ms: c.organize.beacon_period_us as f64 / 1e3,
            meets_rate: (latency_us.max as f64) < period_s * 1e6 && l.sensor_dropped == m.sensor_dropped_before,
            model,
            events: m.events,
            sim_time_s: net.now_ns() as f64 * 1e-9,
            wall_time_s,
        }
    }
}

/// Runs the network to `until_ns`, handing datagrams to the host and its
/// answers back; a host on UDP is heard every millisecond of virtual time.
pub fn pump(net: &mut Network, transport: &mut Transport, until_ns: u64) -> Result<(), NetworkError> {
    const POLL_NS: u64 = 1_000_000;
    loop {
        let slice = until_ns.min(net.now_ns().saturating_add(POLL_NS));
        while let Some(d) = net.step(slice) {
            for reply in transport.deliver(&d)? {
                net.inject(&reply)?;
            }
            net.recycle(d);
        }
        for reply in transport.poll(net.now_ns())? {
            net.inject(&reply)?;
        }
        if net.now_ns() >= until_ns {
            return Ok(());
        }
    }
}

/// Checks self-organization against the live wiring.
fn organization(net: &Network, transport: &Transport) -> Organization {
    let hops = net.true_hops();
    let reachable: Vec<usize> = (0..net.cells()).filter(|i| hops[*i].is_some()).collect();
    let mut seen = BTreeSet::new();
    let mut ids_unique = true;
    let mut attached = 0;
    let mut max_tree_depth = 0;
    let mut neighbours_correct = transport.host().map(|_| true);
    for &i in &reachable {
        let Some(cell) = net.cell(i) else { continue };
        let id = cell.id();
        ids_unique &= id.is_cell() && seen.insert(id);
        if let Some(h) = cell.organizer().hops() {
            attached += 1;
            max_tree_depth = max_tree_depth.max(h);
        }
        if let (Some(host), Some(ok)) = (transport.host(), neighbours_correct.as_mut()) {
            let truth = net.true_neighbours(i);
            *ok &= host.table(id).is_some_and(|t| Port::ALL.iter().all(|p| t[p.index()] == truth[p.index()]));
        }
    }
    Organization { ids_unique, neighbours_correct, attached, reachable: reachable.len(), max_tree_depth }
}

impl NetworkReport {
    /// A short summary for people.
    pub fn summary(&self) -> String {
        let yes = |b: bool| if b { "yes" } else { "NO" };
        let org = match self.organize_time_s {
            Some(t) => format!("organized in {t:.3} s (virtual)"),
            None => "did NOT organize within the timeout".into(),
        };
        let neighbours = match self.neighbours_correct {
            Some(b) => yes(b),
            None => "not checked (external host)",
        };
        format!(
            "{cells} cells, {ifs} interface ports, {rate} Hz {mode} traffic, {stim} skin, seed {seed}; \
             keep-alive every {keepalive} ms, beacons every {beacon} ms\n\
             {org}; tree depth {depth}; IDs unique: {ids}; neighbour table correct: {neighbours}; \
             attached {att}/{reach}; IDs kept: {kept}\n\
             delivered {del}, dropped {drop} ({after} after organizing, {sensors} of them sensor frames; {reasons:?}), \
             in network {inn}; \
             corrupt rejected {cr}, accepted {ca}; \
             ledger balanced: {bal}\n\
             sensor latency p50 {p50} us, p99 {p99} us, max {max} us; tactile events max {emax} us ({en} events)\n\
             worst stay in a cell {hol:.0} us (head of line), {any:.0} us (any); model {fw} us, {fwc} us with control\n\
             traffic {frac:.1}% of clock-driven; peak {peak:.1} frames/s per cell; \
             max cells per interface port at {rate} Hz: {maxc}; meets the rate: {meets}\n\
             simulated {sim:.3} s in {wall:.3} s wall ({speed:.2}x real time; {events} events measured)",
            cells = self.cells,
            ifs = self.interfaces,
            rate = self.rate_hz,
            mode = self.traffic_mode,
            stim = self.stimulus,
            seed = self.seed,
            depth = self.max_tree_depth,
            ids = yes(self.ids_unique),
            att = self.cells_attached,
            reach = self.cells_reachable,
            kept = yes(self.ids_kept),
            del = self.delivered,
            drop = self.dropped,
            after = self.dropped_while_measuring,
            sensors = self.sensor_dropped_while_measuring,
            reasons = self.dropped_by_reason,
            inn = self.in_network,
            cr = self.corrupt_rejected,
            ca = self.corrupt_accepted,
            bal = yes(self.ledger_balanced),
            p50 = self.latency_us.p50,
            p99 = self.latency_us.p99,
            max = self.latency_us.max,
            emax = self.event_latency_us.max,
            en = self.event_latency_us.count,
            hol = self.forwarding_delay.head_of_line_max_us,
            any = self.forwarding_delay.any_max_us,
            fw = self.model.forwarding_us,
            fwc = self.model.forwarding_with_control_us,
            frac = 100.0 * self.traffic.fraction_of_clock,
            peak = self.traffic.peak_per_cell_hz,
            maxc = self
                .cells_per_interface
                .map_or("unbounded (no sensor traffic)".into(), |n| format!("{} ({n:.2})", n.floor())),
            keepalive = self.keepalive_period_ms,
            beacon = self.beacon_period_ms,
            meets = yes(self.meets_rate),
            sim = self.sim_time_s,
            wall = self.wall_time_s,
            speed = self.sim_time_s / self.wall_time_s.max(1e-9),
            events = self.events,
        )
    }
}
