//! The discrete-event network: cells running the firmware's protocol code
//! on a virtual clock, joined by timed links, with interface ports that
//! speak UDP datagrams to a host.
//!
//! Every cell is a [`CellApp`] (organize + router + processing + settings,
//! the firmware's very cell application) on a [`MemoryStore`] that outlives
//! its reboots; every interface port is a [`Sink`]. Nothing happens on a
//! fixed tick: a cell is visited when a frame reaches it, when its sensors
//! are due, or at its own [`CellApp::poll_at`]; a transmitter starts when a
//! frame is queued for an idle port and asks for the next one when its
//! frame has left.
//!
//! A cell at rest costs nothing: when the stimulus leaves it at rest for a
//! while and its processor proves that no reading within its noise
//! bounds makes it send ([`Processor::silent_within`](skin_protocol::processing::Processor::silent_within)), the cell skips its
//! samples until the stimulus reaches it. The processor takes the skipped
//! samples in one go when the cell wakes (or when something needs its
//! state: a configuration write, readings fed from outside), reading the
//! same noise it would have read, as every cell has a noise stream of its
//! own: the run is the same as without skipping, frame for frame
//! ([`NetworkConfig::skip_resting_cells`] turns skipping off to show it).
//! Between them, a cell's sample due in the very nanosecond a frame reaches
//! it or a fault strikes it is taken first.
//!
//! Every upstream frame carries a [`Trace`] through the routers (their
//! per-frame metadata), so the simulator knows when each frame was made,
//! how long it waited in each cell and where it was lost.
//!
//! The `impl` of [`Network`] is split by concern: this file holds the
//! public API, `config` what a network is made of, `cells` what happens in a cell, `rest` the skipping
//! of resting cells, `wires` the cell-2-cell links, `ethernet` the
//! interface ports' datagrams, `faults` the fault injection,
//! `prefetch` the cache hints for a cell a frame is on its way to and
//! `pages` the huge pages of a large skin's cell state.

mod cells;
mod config;
mod ethernet;
mod faults;
mod firmware;
mod pages;
mod prefetch;
mod rest;
mod wires;

use std::collections::VecDeque;

use skin_protocol::address::Address;
use skin_protocol::app::{CellApp, MemoryStore};
use skin_protocol::cell::Cell;
use skin_protocol::frame::{Frame, Kind};
use skin_protocol::interface::MAX_FRAMES;
use skin_protocol::message::{Neighbour, Port, Setting};
use skin_protocol::organize::Sink;
use skin_protocol::router::Counters;
use skin_protocol::Sample;

use super::fault::FaultKind;
use super::ledger::{Drops, Histogram, Ledger};
use super::link::BitErrors;
use super::scheduler::{Order, Scheduler};
use super::sensor_fault::{Broken, SensorFault};
use super::stimulus::Stimulus;
use super::topology::{PortRef, Topology};
use super::NetworkError;

use cells::Followed;
pub use cells::{SimCell, Stamper, Trace};
pub use config::NetworkConfig;
use ethernet::{Interface, ToHost};
pub use firmware::{Firmware, UpdateSetup, TRIAL_NS};
use rest::Rest;
use wires::{End, Signal};

/// Cells boot within this time of power-up, in a random order.
const BOOT_SPREAD_NS: u64 = 5_000_000;
/// Datagram buffers kept for reuse, at most ([`Network::recycle`]).
const SPARE_DATAGRAMS: usize = 64;
/// Every port, as port bits.
const ALL_PORTS: u8 = 0b1111;

/// A datagram an interface port sent to the host, and when it arrived.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct HostDatagram {
    /// Virtual time of arrival at the host.
    pub at_ns: u64,
    /// The datagram in the `interface` format.
    pub bytes: Vec<u8>,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Power {
    Off,
    On,
    Dead,
}

/// What the simulator checks of a cell on every event: its power, its
/// transmitters and its pending wake-ups, in one cache line apart from the
/// firmware's state (a few kilobytes per cell), so that a stale wake-up or
/// a sample that sends nothing does not reach for it.
#[derive(Debug)]
struct Pulse {
    power: Power,
    /// The cell has an ID (as of the last time it was touched).
    has_id: bool,
    waking: [bool; 4],
    epoch: u32,
    busy_until_ns: [u64; 4],
    /// When the cell's wake-up event is due (`u64::MAX`: none).
    poll_ns: u64,
    /// The cell's [`Cell::poll_at`] as of the last time it was touched: a
    /// deadline put off since the wake-up was scheduled (each wave puts off
    /// the route's) only moves the wake-up, without reading the cell.
    deadline_ns: u64,
    /// When the cell's sample event is due: its next sample, or the one
    /// that ends its rest (`u64::MAX`: none).
    sample_ns: u64,
}

#[derive(Debug)]
enum Event {
    PowerOn(usize),
    Poll(usize, u32),
    Sample(usize, u32),
    TxFree(End),
    Arrive { from: End, to: End, signal: Signal, followed: Option<Followed> },
    SinkPoll(u8),
    EthernetFree,
    Fault(FaultKind),
}

/// What the network measured since [`Network::measure_from`].
#[derive(Clone, Debug, Default)]
pub struct Measurements {
    /// Where every frame went (over the whole run).
    pub ledger: Ledger,
    /// Sensor frames (samples and tactile events): made to host.
    pub latency: Histogram,
    /// Tactile events: made to host.
    pub event_latency: Histogram,
    /// Longest stay of an upstream frame in one cell, from its last bit
    /// received (or its making) to its last bit sent, when it found its
    /// input queue empty: the round-robin bound.
    pub forwarding_head_ns: u64,
    /// Longest stay of any upstream frame in one cell.
    pub forwarding_any_ns: u64,
    /// Samples taken by cells that have an ID.
    pub samples: u64,
    /// Sensor frames sent (samples and tactile events).
    pub data_frames: u64,
    /// Most sensor frames made in one sampling period, over all cells.
    pub peak_data_frames_per_period: u64,
    /// Frames the interface ports received from their cells, and how many
    /// of them were sensor data, per port.
    pub interface_frames: Vec<(u64, u64)>,
    /// Measuring time in ns.
    pub measured_ns: u64,
    /// Events the simulator handled while measuring.
    pub events: u64,
    /// Upstream drops before measuring began (the ledger counts from power-up).
    pub dropped_before: Drops,
    /// Sensor frames among them.
    pub sensor_dropped_before: u64,
}

/// A skin network on a virtual clock.
#[derive(Debug)]
pub struct Network {
    config: NetworkConfig,
    frame_ns: u64,
    period_ns: u64,
    /// Cells get their state asked for ahead of a frame ([`prefetch`]).
    prefetch: bool,
    pulses: Vec<Pulse>,
    stacks: Vec<SimCell>,
    /// Cells at rest, and how many.
    rests: Vec<Option<Rest>>,
    resting: usize,
    peers: Vec<[Option<End>; 4]>,
    interfaces: Vec<Interface>,
    ethernet_busy_until_ns: u64,
    ethernet_waking: bool,
    next_flush: usize,
    /// The frames of the datagram being sent (kept to reuse its memory).
    datagram: Vec<Frame>,
    /// Datagram buffers handed back by the caller ([`Network::recycle`]).
    spare: Vec<Vec<u8>>,
    events: Scheduler<Event>,
    stimulus: Stimulus,
    /// Cells with a broken sensor, read through their fault.
    broken: Vec<Broken>,
    /// The readings fed, through the broken sensors (kept to reuse its memory).
    through_faults: Vec<Sample>,
    bit_errors: BitErrors,
    phases: rand_chacha::ChaCha8Rng,
    /// Datagrams on their way to the host, in the order they arrive.
    to_host: VecDeque<ToHost>,
    on_wires: u64,
    followed_on_wires: u64,
    followed_on_ethernet: u64,
    measure_from_ns: u64,
    /// The place in the event order where measuring began: a skipped
    /// sample counts when it comes later.
    measure_from: Order,
    window: (u64, u64),
    m: Measurements,
}

/// Router counters, summed.
fn add(a: &mut Counters, b: &Counters) {
    a.forwarded_up += b.forwarded_up;
    a.forwarded_down += b.forwarded_down;
    a.sent_own += b.sent_own;
    a.sent_link += b.sent_link;
    a.dropped_full += b.dropped_full;
    a.dropped_reroute += b.dropped_reroute;
    a.corrupt += b.corrupt;
}

fn is_data(kind: Kind) -> bool {
    matches!(kind, Kind::Sample | Kind::Event)
}

impl Network {
    /// A network of `topology`'s cells, all powered up at time 0.
    pub fn new(topology: &Topology, config: NetworkConfig) -> Result<Network, NetworkError> {
        use rand::{Rng, SeedableRng};
        if topology.interfaces().is_empty() {
            return Err(NetworkError::Topology(
                "no interface port: attach some (--interfaces N, or `interfaces` in the file)".into(),
            ));
        }
        let store = Self::factory_store(&config)?;
        let period_us = CellApp::<MemoryStore>::new(config.organize, store, 0).processor().period_us();
        if !(0.0..=0.5).contains(&config.bit_error_rate) {
            return Err(NetworkError::Flag(format!("bit-error rate {} is not in [0, 0.5]", config.bit_error_rate)));
        }
        let mut peers: Vec<[Option<End>; 4]> = topology.peers().iter().map(|ps| ps.map(|p| p.map(End::cell))).collect();
        let mut interfaces = Vec::new();
        for (k, at) in topology.interfaces().iter().enumerate() {
            let sink = Sink::new(k as u8, config.organize, 0).ok_or_else(|| {
                NetworkError::Topology(format!("{} interface ports; at most {}", k + 1, Address::MAX_INTERFACES))
            })?;
            peers[at.cell][at.port.index()] = Some(End::Interface(k as u8));
            interfaces.push(Interface {
                sink,
                at: Some(*at),
                alive: true,
                busy_until_ns: 0,
                waking: false,
                up: VecDeque::new(),
                seq: 0,
                from_cell: 0,
                data_from_cell: 0,
            });
        }
        let mut events = Scheduler::default();
        let mut boot = rand_chacha::ChaCha8Rng::seed_from_u64(config.seed);
        let pulses = (0..topology.cells())
            .map(|i| {
                events.at(boot.random_range(0..BOOT_SPREAD_NS), Event::PowerOn(i));
                Pulse {
                    power: Power::Off,
                    has_id: false,
                    waking: [false; 4],
                    epoch: 0,
                    busy_until_ns: [0; 4],
                    poll_ns: u64::MAX,
                    deadline_ns: u64::MAX,
                    sample_ns: u64::MAX,
                }
            })
            .collect();
        for k in 0..interfaces.len() {
            events.at(0, Event::SinkPoll(k as u8));
        }
        let m = Measurements { interface_frames: vec![(0, 0); interfaces.len()], ..Measurements::default() };
        Ok(Network {
            frame_ns: config.timing.frame_ns(),
            prefetch: prefetch::worth_it(topology.cells()),
            period_ns: period_us * 1000,
            stacks: {
                let mut stacks = Vec::with_capacity(topology.cells());
                pages::huge(&stacks);
                stacks.extend(
                    (0..topology.cells())
                        .map(|_| SimCell::new(store, config.update.map(|u| Box::new(Firmware::new(u))))),
                );
                stacks
            },
            rests: vec![None; topology.cells()],
            resting: 0,
            pulses,
            peers,
            interfaces,
            ethernet_busy_until_ns: 0,
            ethernet_waking: false,
            next_flush: 0,
            datagram: Vec::with_capacity(MAX_FRAMES),
            spare: Vec::new(),
            events,
            stimulus: Stimulus::new(config.stimulus, topology.positions_m(), config.seed ^ 0x5717_0001),
            broken: Vec::new(),
            through_faults: Vec::new(),
            bit_errors: BitErrors::new(config.bit_error_rate, config.seed ^ 0xB17E_0002),
            phases: rand_chacha::ChaCha8Rng::seed_from_u64(config.seed ^ 0xF0A5_0003),
            to_host: VecDeque::new(),
            on_wires: 0,
            followed_on_wires: 0,
            followed_on_ethernet: 0,
            measure_from_ns: 0,
            measure_from: Order::ranked(0, 0, 0),
            window: (0, 0),
            m,
            config,
        })
    }

    /// What every cell's store holds when it ships: the network's settings
    /// and offsets measured at the factory (the simulated sensors have none).
    pub fn factory_store(config: &NetworkConfig) -> Result<MemoryStore, NetworkError> {
        let rate = Setting::SampleRateHz(config.rate_hz);
        if !rate.is_valid() {
            return Err(NetworkError::Flag(format!("rate {} Hz: use a rate in (0, 10000] Hz", config.rate_hz)));
        }
        let deltas =
            (0u8..).zip(config.delta_counts).filter_map(|(channel, c)| Some(Setting::Delta { channel, counts: c? }));
        let settings = [rate, Setting::Traffic(config.traffic)].into_iter().chain(deltas);
        Ok(MemoryStore::with(Some([0; 8]), settings))
    }

    /// The settings the network was built with.
    pub fn config(&self) -> &NetworkConfig {
        &self.config
    }

    /// Virtual time in nanoseconds.
    pub fn now_ns(&self) -> u64 {
        self.events.now_ns()
    }

    fn now_us(&self) -> u64 {
        self.now_ns() / 1000
    }

    /// Number of cells.
    pub fn cells(&self) -> usize {
        self.pulses.len()
    }

    /// Number of interface ports.
    pub fn interfaces(&self) -> usize {
        self.interfaces.len()
    }

    /// True while cell `i` rests: the stimulus leaves it at rest, and its
    /// processor provably sends nothing, so it skips its samples.
    pub fn is_resting(&self, i: usize) -> bool {
        self.rests.get(i).is_some_and(Option::is_some)
    }

    /// Cells resting now.
    pub fn resting(&self) -> usize {
        self.resting
    }

    /// The network stack of cell `i` while it is powered.
    pub fn cell(&self, i: usize) -> Option<&Cell<Trace>> {
        self.app(i).map(CellApp::cell)
    }

    /// The application of cell `i` while it is powered.
    pub fn app(&self, i: usize) -> Option<&CellApp<MemoryStore, Trace>> {
        self.stacks.get(i).and_then(|s| s.app.as_ref())
    }

    /// Starts measuring latency and traffic now; the ledger keeps counting
    /// from the start.
    pub fn measure_from(&mut self) {
        self.measure_from_ns = self.now_ns();
        self.measure_from = self.events.done();
        self.window = (self.now_ns() / self.period_ns, 0);
        let ledger = std::mem::take(&mut self.m.ledger);
        self.m = Measurements {
            dropped_before: ledger.dropped,
            sensor_dropped_before: ledger.sensor_dropped,
            ledger,
            interface_frames: vec![(0, 0); self.interfaces.len()],
            ..Measurements::default()
        };
        for i in &mut self.interfaces {
            (i.from_cell, i.data_from_cell) = (0, 0);
        }
    }

    /// What was measured, up to now.
    pub fn measurements(&self) -> Measurements {
        let mut m = self.m.clone();
        for (i, rest) in self.rests.iter().enumerate() {
            if let Some(r) = rest {
                m.samples += self.skipped_measured(i, r, self.taken_through(i, r)).0;
            }
        }
        m.peak_data_frames_per_period = m.peak_data_frames_per_period.max(self.window.1);
        m.interface_frames = self.interfaces.iter().map(|i| (i.from_cell, i.data_from_cell)).collect();
        m.measured_ns = self.now_ns() - self.measure_from_ns;
        m
    }

    /// Upstream frames in queues, on wires, at interface ports or on the
    /// Ethernet, as followed by the simulator.
    pub fn upstream_in_network(&self) -> u64 {
        let queued: usize =
            self.stacks.iter().filter_map(|s| s.app.as_ref()).map(|a| a.cell().router().upstream_queued()).sum();
        let at_interfaces: usize =
            self.interfaces.iter().map(|i| i.up.iter().filter(|(_, c)| c.is_some()).count()).sum();
        (queued + at_interfaces) as u64 + self.followed_on_wires + self.followed_on_ethernet
    }

    /// True when both books of the ledger add up.
    pub fn balanced(&self) -> bool {
        self.m.ledger.balanced(self.upstream_in_network(), self.on_wires)
    }

    /// Router counters of all cells over all their lives.
    pub fn router_counters(&self) -> Counters {
        let mut sum = Counters::default();
        for s in &self.stacks {
            add(&mut sum, &s.retired);
            if let Some(a) = &s.app {
                add(&mut sum, a.cell().router().counters());
            }
        }
        sum
    }

    /// Frames waiting in routers (all kinds) and interface ports.
    pub fn queued(&self) -> u64 {
        let cells: usize = self.stacks.iter().filter_map(|s| s.app.as_ref()).map(|a| a.cell().router().queued()).sum();
        let ifs: usize = self.interfaces.iter().map(|i| i.up.len() + i.sink.queued()).sum();
        (cells + ifs) as u64
    }

    /// Frames on wires right now.
    pub fn on_wires(&self) -> u64 {
        self.on_wires
    }

    /// Runs until `until_ns` or until a datagram reaches the host,
    /// whichever comes first, and returns that datagram.
    pub fn step(&mut self, until_ns: u64) -> Option<HostDatagram> {
        loop {
            if let Some(d) = self.to_host.front() {
                if d.order.at_ns <= until_ns && self.events.next_order().is_none_or(|n| d.order < n) {
                    return self.reach_host();
                }
            }
            let Some(event) = self.events.pop_until(until_ns) else {
                self.events.advance(until_ns);
                return None;
            };
            self.handle(event);
        }
    }

    /// Takes back a datagram [`Network::step`] returned, once read: its
    /// buffer carries a later one, so that a datagram costs no allocation.
    pub fn recycle(&mut self, datagram: HostDatagram) {
        if self.spare.len() < SPARE_DATAGRAMS {
            self.spare.push(datagram.bytes);
        }
    }

    /// Breaks a sensor of one cell: from now on the readings fed to it
    /// ([`Network::feed`]) go through `fault`.
    pub fn break_sensor(&mut self, fault: SensorFault) -> Result<(), NetworkError> {
        if fault.cell >= self.pulses.len() {
            return Err(NetworkError::Flag(format!(
                "sensor fault on cell {}: the skin has cells 0 to {}",
                fault.cell,
                self.pulses.len() - 1
            )));
        }
        self.broken.push(Broken::new(fault));
        Ok(())
    }

    /// Raw readings from outside, one per cell, that every cell samples
    /// from now on (until the next call) instead of the stimulus: what a
    /// simulated robot feels, carried by the network as the skin would.
    /// Cells at rest wake up: the stimulus no longer says where it acts.
    pub fn feed(&mut self, raw: &[Sample]) -> Result<(), NetworkError> {
        if self.broken.is_empty() {
            self.stimulus.feed(raw)?;
        } else {
            self.through_faults.clear();
            self.through_faults.extend_from_slice(raw);
            for b in &mut self.broken {
                if let Some(s) = self.through_faults.get_mut(b.fault.cell) {
                    *s = b.read(*s);
                }
            }
            self.stimulus.feed(&self.through_faults)?;
        }
        if self.resting > 0 {
            (0..self.pulses.len()).for_each(|i| self.wake(i));
        }
        Ok(())
    }

    /// Who is on each port of cell `i` on the live wiring, as the cell
    /// should have learned it: `None` for a free or cut port, a dead or
    /// ID-less neighbour.
    pub fn true_neighbours(&self, i: usize) -> [Option<Neighbour>; 4] {
        self.peers[i].map(|end| match end? {
            End::Cell(j, q) => {
                let id = self.app(j as usize)?.id();
                id.is_cell().then_some(Neighbour { id, port: q })
            }
            End::Interface(k) => self.interfaces[usize::from(k)]
                .alive
                .then(|| Neighbour { id: self.interfaces[usize::from(k)].sink.address(), port: Port::P0 }),
        })
    }

    /// Hops from each powered cell to its nearest live interface port over
    /// live links and powered cells; `None` when cut off or unpowered.
    pub fn true_hops(&self) -> Vec<Option<u16>> {
        let on = |c: usize| self.pulses[c].power == Power::On;
        let peers: Vec<[Option<PortRef>; 4]> = (0..self.pulses.len())
            .map(|c| {
                self.peers[c].map(|e| match e {
                    Some(End::Cell(j, q)) if on(c) && on(j as usize) => Some(PortRef::new(j as usize, q)),
                    _ => None,
                })
            })
            .collect();
        let roots: Vec<PortRef> =
            self.interfaces.iter().filter(|i| i.alive).filter_map(|i| i.at).filter(|p| on(p.cell)).collect();
        Topology::hops(&peers, &roots)
    }

    fn handle(&mut self, event: Event) {
        self.m.events += 1;
        match event {
            Event::PowerOn(i) => self.power_on(i),
            Event::Poll(i, epoch) => self.poll(i, epoch),
            Event::Sample(i, epoch) => {
                let n = &self.pulses[i];
                // Stale when the cell rebooted, or woke from rest earlier.
                if n.epoch == epoch && n.power == Power::On && n.sample_ns == self.events.now_ns() {
                    self.sample(i);
                }
            }
            Event::TxFree(end) => match end {
                End::Cell(i, p) => {
                    self.pulses[i as usize].waking[p.index()] = false;
                    self.kick_cell(i as usize, p);
                }
                End::Interface(k) => {
                    self.interfaces[usize::from(k)].waking = false;
                    self.kick_interface(k);
                }
            },
            Event::Arrive { from, to, signal, followed } => self.arrive(from, to, signal, followed),
            Event::SinkPoll(k) => self.sink_poll(k),
            Event::EthernetFree => {
                self.ethernet_waking = false;
                self.flush();
            }
            Event::Fault(f) => self.fault(f),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        /// Any bytes from the host are a datagram for the skin or a typed
        /// error, and the network runs on either way.
        #[test]
        fn any_bytes_from_the_host(bytes in proptest::collection::vec(any::<u8>(), 0..200), port: u8) {
            let topology = Topology::hex(2, 2).and_then(|t| t.with_interfaces(2)).unwrap();
            let mut net = Network::new(&topology, NetworkConfig::default()).unwrap();
            while net.step(20_000_000).is_some() {}
            // The same bytes shaped as a datagram of 1..=3 (corrupt) frames.
            let mut datagram = bytes.clone();
            datagram.resize(16 + 20 * (1 + bytes.len() % 3), 0);
            datagram[..3].copy_from_slice(b"SK\x01");
            datagram[3] = port % 3;
            for b in [&bytes, &datagram] {
                let _ = net.inject(b);
                while net.step(30_000_000).is_some() {}
                prop_assert!(net.balanced());
                prop_assert_eq!(net.now_ns(), 30_000_000);
            }
        }
    }
}
