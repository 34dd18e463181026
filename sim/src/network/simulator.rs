//! The discrete-event network: cells running the firmware's protocol code
//! on a virtual clock, joined by timed links, with interface ports that
//! speak UDP datagrams to a host.
//!
//! Every cell is a [`Cell`] (organize + router) fed by a [`Processor`]
//! sampling its sensors; every interface port is a [`Sink`]. Nothing
//! happens on a fixed tick: a cell is visited when a frame reaches it, when
//! its sensors are due, or at its own [`Cell::poll_at`]; a transmitter
//! starts when a frame is queued for an idle port and asks for the next one
//! when its frame has left.
//!
//! A cell at rest costs nothing: when the stimulus leaves it at rest for a
//! while and its [`Processor`] proves that no reading within its noise
//! bounds makes it send ([`Processor::silent_within`]), the cell skips its
//! samples until the stimulus reaches it. The processor takes the skipped
//! samples in one go when the cell wakes (or when something needs its
//! state: a configuration write, readings fed from outside), reading the
//! same noise it would have read, as every cell has a noise stream of its
//! own: the run is the same as without skipping, frame for frame
//! ([`NetworkConfig::skip_resting_cells`] turns skipping off to show it).
//! Between them, a cell's sample due in the very nanosecond a frame reaches
//! it or a fault strikes it is taken first.
//!
//! The simulator follows each upstream frame through the router queues by
//! watching their lengths (they are FIFO), so it knows, without looking
//! into the firmware's queues, when each frame was made, how long it waited
//! in each cell and where it was lost.

use std::collections::VecDeque;

use skin_protocol::address::Address;
use skin_protocol::cell::{Cell, SendError};
use skin_protocol::frame::{Frame, Kind, FRAME_LEN};
use skin_protocol::interface::{self, Datagram, DatagramHeader, MAX_DATAGRAM, MAX_FRAMES};
use skin_protocol::message::{ConfigAck, Message, Neighbour, Port, Setting, TrafficMode};
use skin_protocol::organize::{Config, FromCell, Sink};
use skin_protocol::processing::Processor;
use skin_protocol::router::Counters;
use skin_protocol::Sample;

use super::fault::{FaultKind, REBOOT_DOWN_NS};
use super::ledger::{DropReason, Drops, Histogram, Ledger};
use super::link::{BitErrors, LinkTiming};
use super::scheduler::{Order, Scheduler};
use super::stimulus::{Stimulus, StimulusKind};
use super::topology::{PortRef, Topology};
use super::NetworkError;

/// Cells boot within this time of power-up, in a random order.
const BOOT_SPREAD_NS: u64 = 5_000_000;
/// The own queue's index in `Router::upstream_lens`.
const OWN: usize = 4;
/// Every port, as port bits.
const ALL_PORTS: u8 = 0b1111;
/// A cell rests only when it can skip at least this many samples.
const MIN_REST_SAMPLES: u64 = 2;

/// What a network is made of, besides its wiring.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NetworkConfig {
    /// Link timing.
    pub timing: LinkTiming,
    /// Self-organization timing of cells and interface ports.
    pub organize: Config,
    /// Sampling rate of every cell.
    pub rate_hz: f32,
    /// Clock- or event-driven sending.
    pub traffic: TrafficMode,
    /// What the skin feels.
    pub stimulus: StimulusKind,
    /// Send-on-delta thresholds the host sets, per sample channel (the
    /// order of `Sample::channels`), in counts; `None` keeps the firmware's
    /// default (about twice the sensor noise).
    pub delta_counts: [Option<u16>; 8],
    /// Bit-error rate of every cell-2-cell wire.
    pub bit_error_rate: f64,
    /// Seed of boot order, sampling phases, sensor noise and bit errors.
    pub seed: u64,
    /// Cells the stimulus leaves at rest skip their samples while they
    /// provably send nothing (the same run, faster); off only to check that.
    pub skip_resting_cells: bool,
}

impl Default for NetworkConfig {
    fn default() -> Self {
        NetworkConfig {
            timing: LinkTiming::default(),
            organize: Config::default(),
            rate_hz: 250.0,
            traffic: TrafficMode::Clock,
            stimulus: StimulusKind::Quiet,
            delta_counts: [None; 8],
            bit_error_rate: 0.0,
            seed: 0,
            skip_resting_cells: true,
        }
    }
}

/// Shortest and longest keep-alive or beacon period the simulator takes.
const PERIOD_RANGE_US: std::ops::RangeInclusive<u64> = 1_000..=10_000_000;

impl NetworkConfig {
    /// The same network with a keep-alive on settled links every
    /// `keepalive_us` and beacon waves every `beacon_us`; a link is given
    /// up after 3.5 keep-alive periods without a frame, a route and the link
    /// to the parent after 3.5 beacon periods without a wave (the cell asks
    /// its neighbours for waves after 1.5), as with the defaults (100 ms,
    /// 10 ms). Longer periods cost a large skin less control traffic (a
    /// settled skin carries about one wave relay per cell per beacon
    /// period) and detect a broken link or route later.
    pub fn with_periods(mut self, keepalive_us: u64, beacon_us: u64) -> Result<NetworkConfig, NetworkError> {
        for (what, us) in [("keep-alive", keepalive_us), ("beacon", beacon_us)] {
            if !PERIOD_RANGE_US.contains(&us) {
                return Err(NetworkError::Flag(format!(
                    "{what} period {} ms: use {} ms to {} ms",
                    us as f64 / 1e3,
                    *PERIOD_RANGE_US.start() as f64 / 1e3,
                    *PERIOD_RANGE_US.end() as f64 / 1e3
                )));
            }
        }
        self.organize.keepalive_period_us = keepalive_us;
        self.organize.keepalive_timeout_us = keepalive_us * 7 / 2;
        self.organize.link_timeout_us = beacon_us * 7 / 2;
        self.organize.beacon_period_us = beacon_us;
        self.organize.wave_timeout_us = beacon_us * 3 / 2;
        self.organize.route_timeout_us = beacon_us * 7 / 2;
        Ok(self)
    }
}

/// A datagram an interface port sent to the host, and when it arrived.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct HostDatagram {
    /// Virtual time of arrival at the host.
    pub at_ns: u64,
    /// The datagram in the `interface` format.
    pub bytes: Vec<u8>,
}

/// One end of a wire.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum End {
    /// A cell and its port.
    Cell(u16, Port),
    /// An interface port.
    Interface(u8),
}

// Every cell index fits an `End`.
const _: () = assert!(super::topology::MAX_CELLS <= 1 << 16);

impl End {
    fn cell(p: PortRef) -> End {
        End::Cell(p.cell as u16, p.port)
    }
}

/// An upstream frame the simulator follows from its making to the host.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Followed {
    created_ns: u64,
    /// A sample or tactile event.
    sensor: bool,
}

/// An upstream frame in a router queue, as the simulator follows it.
#[derive(Clone, Copy, Debug)]
struct Entry {
    frame: Followed,
    /// When it was received (for a forwarded frame) or made.
    since_ns: u64,
    /// It entered an empty queue: its wait is bounded by one round robin.
    head: bool,
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
struct Node {
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

/// A cell skipping its samples at rest, until its sample event.
#[derive(Clone, Copy, Debug)]
struct Rest {
    /// The first sample its processor has not taken.
    next_ns: u64,
    /// The first sample not yet counted in [`Measurements::samples`].
    count_ns: u64,
    /// The sampling period.
    period_ns: u64,
}

impl Rest {
    /// How many skipped samples fall from `from_ns` through `through_ns`
    /// (and before the sample event at `end_ns`), and the first one after.
    fn span(&self, from_ns: u64, through_ns: u64, end_ns: u64) -> (u64, u64) {
        let last = through_ns.min(end_ns.saturating_sub(1));
        if from_ns > last {
            return (0, from_ns);
        }
        let n = (last - from_ns) / self.period_ns + 1;
        (n, from_ns + n * self.period_ns)
    }
}

/// A simulated cell's firmware network stack, its ID store and the
/// simulator's view of its upstream queues.
#[derive(Debug, Default)]
struct Stack {
    cell: Option<Cell>,
    store: Option<Address>,
    shadow: [VecDeque<Entry>; 5],
    /// Router counters of earlier lives (before reboots).
    retired: Counters,
}

#[derive(Debug)]
struct Interface {
    sink: Sink,
    at: Option<PortRef>,
    alive: bool,
    busy_until_ns: u64,
    waking: bool,
    /// Frames for the host waiting for the Ethernet, followed or not.
    up: VecDeque<(Frame, Option<Followed>)>,
    seq: u32,
    /// Frames received from the cell since measuring began, and how many
    /// of them were sensor data.
    from_cell: u64,
    data_from_cell: u64,
}

/// What reaches the far end of a wire.
#[derive(Clone, Copy, Debug)]
enum Signal {
    /// The frame as sent: its CRC was computed when it was made, and no
    /// bit changed since, so the receiver takes it without parsing again.
    Intact(Frame),
    /// Bytes with flipped bits: the receiver parses them and checks the CRC.
    Corrupted([u8; FRAME_LEN]),
}

impl Signal {
    fn kind_byte(&self) -> u8 {
        match self {
            Signal::Intact(f) => f.kind() as u8,
            Signal::Corrupted(b) => b[0],
        }
    }

    fn bytes(&self) -> &[u8; FRAME_LEN] {
        match self {
            Signal::Intact(f) => f.as_bytes(),
            Signal::Corrupted(b) => b,
        }
    }
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
    ToHost { bytes: Vec<u8>, followed: u64 },
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
    nodes: Vec<Node>,
    stacks: Vec<Stack>,
    processors: Vec<Processor>,
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
    events: Scheduler<Event>,
    stimulus: Stimulus,
    bit_errors: BitErrors,
    phases: rand_chacha::ChaCha8Rng,
    ready: VecDeque<HostDatagram>,
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
        let processor = Self::processor(&config)?;
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
        let nodes = (0..topology.cells())
            .map(|i| {
                events.at(boot.random_range(0..BOOT_SPREAD_NS), Event::PowerOn(i));
                Node {
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
            period_ns: processor.period_us() * 1000,
            stacks: (0..topology.cells()).map(|_| Stack::default()).collect(),
            processors: vec![processor; topology.cells()],
            rests: vec![None; topology.cells()],
            resting: 0,
            nodes,
            peers,
            interfaces,
            ethernet_busy_until_ns: 0,
            ethernet_waking: false,
            next_flush: 0,
            datagram: Vec::with_capacity(MAX_FRAMES),
            events,
            stimulus: Stimulus::new(config.stimulus, topology.positions_m(), config.seed ^ 0x5717_0001),
            bit_errors: BitErrors::new(config.bit_error_rate, config.seed ^ 0xB17E_0002),
            phases: rand_chacha::ChaCha8Rng::seed_from_u64(config.seed ^ 0xF0A5_0003),
            ready: VecDeque::new(),
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

    /// A cell's processing as the network's settings ask (kept in the
    /// cell's flash, so a reboot keeps them).
    fn processor(config: &NetworkConfig) -> Result<Processor, NetworkError> {
        let mut p = Processor::new();
        if !p.apply(&Setting::SampleRateHz(config.rate_hz)) {
            return Err(NetworkError::Flag(format!("rate {} Hz: use a rate in (0, 10000] Hz", config.rate_hz)));
        }
        p.apply(&Setting::Traffic(config.traffic));
        for (channel, counts) in (0u8..).zip(config.delta_counts) {
            if let Some(counts) = counts {
                p.apply(&Setting::Delta { channel, counts });
            }
        }
        Ok(p)
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
        self.nodes.len()
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
    pub fn cell(&self, i: usize) -> Option<&Cell> {
        self.stacks.get(i).and_then(|s| s.cell.as_ref())
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
        let queued: usize = self.stacks.iter().flat_map(|s| s.shadow.iter()).map(VecDeque::len).sum();
        let at_interfaces: usize =
            self.interfaces.iter().map(|i| i.up.iter().filter(|(_, c)| c.is_some()).count()).sum();
        (queued + at_interfaces) as u64 + self.followed_on_wires + self.followed_on_ethernet
    }

    /// True when both books of the ledger add up, and the simulator's view
    /// of every router's upstream queues matches the router.
    pub fn balanced(&self) -> bool {
        let queues_agree = self.stacks.iter().all(|s| match &s.cell {
            Some(c) => c.router().upstream_lens().iter().zip(&s.shadow).all(|(l, q)| *l == q.len()),
            None => s.shadow.iter().all(VecDeque::is_empty),
        });
        queues_agree && self.m.ledger.balanced(self.upstream_in_network(), self.on_wires)
    }

    /// Router counters of all cells over all their lives.
    pub fn router_counters(&self) -> Counters {
        let mut sum = Counters::default();
        for s in &self.stacks {
            add(&mut sum, &s.retired);
            if let Some(c) = &s.cell {
                add(&mut sum, c.router().counters());
            }
        }
        sum
    }

    /// Frames waiting in routers (all kinds) and interface ports.
    pub fn queued(&self) -> u64 {
        let cells: usize = self.stacks.iter().filter_map(|s| s.cell.as_ref()).map(|c| c.router().queued()).sum();
        let ifs: usize = self.interfaces.iter().map(|i| i.up.len() + i.sink.queued()).sum();
        (cells + ifs) as u64
    }

    /// Frames on wires right now.
    pub fn on_wires(&self) -> u64 {
        self.on_wires
    }

    /// Schedules a fault at virtual time `at_ns`.
    pub fn schedule_fault(&mut self, at_ns: u64, fault: FaultKind) -> Result<(), NetworkError> {
        let ok = match fault {
            FaultKind::Cut(p) => self.peers.get(p.cell).is_some_and(|ps| ps[p.port.index()].is_some()),
            FaultKind::Dead(c) | FaultKind::Reboot(c) => c < self.nodes.len(),
            FaultKind::InterfaceDown(k) => usize::from(k) < self.interfaces.len(),
        };
        if !ok {
            return Err(NetworkError::Flag(format!(
                "fault {fault}: this skin has no such link, cell or interface port (cells 0..{}, interface ports 0..{})",
                self.nodes.len(),
                self.interfaces.len()
            )));
        }
        self.events.at(at_ns, Event::Fault(fault));
        Ok(())
    }

    /// Runs until `until_ns` or until a datagram reaches the host,
    /// whichever comes first, and returns that datagram.
    pub fn step(&mut self, until_ns: u64) -> Option<HostDatagram> {
        loop {
            if let Some(d) = self.ready.pop_front() {
                return Some(d);
            }
            let Some(event) = self.events.pop_until(until_ns) else {
                self.events.advance(until_ns);
                return None;
            };
            self.handle(event);
        }
    }

    /// Hands a datagram from the host to its interface port, now. Frames
    /// the port has no room for are dropped and counted.
    pub fn inject(&mut self, bytes: &[u8]) -> Result<(), NetworkError> {
        let d = Datagram::parse(bytes).map_err(NetworkError::Datagram)?;
        let k = d.header().interface;
        let Some(i) = self.interfaces.get_mut(usize::from(k)) else {
            return Err(NetworkError::Flag(format!("datagram for interface port {k}, which this skin does not have")));
        };
        for frame in d.frames() {
            match frame {
                Ok(f) if i.alive => {
                    if i.sink.send(f).is_err() {
                        self.m.ledger.host_frames_refused += 1;
                    }
                }
                _ => self.m.ledger.host_frames_refused += 1,
            }
        }
        self.kick_interface(k);
        Ok(())
    }

    /// Raw readings from outside, one per cell, that every cell samples
    /// from now on (until the next call) instead of the stimulus: what a
    /// simulated robot feels, carried by the network as the skin would.
    /// Cells at rest wake up: the stimulus no longer says where it acts.
    pub fn feed(&mut self, raw: &[Sample]) -> Result<(), NetworkError> {
        self.stimulus.feed(raw)?;
        if self.resting > 0 {
            (0..self.nodes.len()).for_each(|i| self.wake(i));
        }
        Ok(())
    }

    /// Who is on each port of cell `i` on the live wiring, as the cell
    /// should have learned it: `None` for a free or cut port, a dead or
    /// ID-less neighbour.
    pub fn true_neighbours(&self, i: usize) -> [Option<Neighbour>; 4] {
        self.peers[i].map(|end| match end? {
            End::Cell(j, q) => {
                let id = self.stacks[j as usize].cell.as_ref()?.id();
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
        let on = |c: usize| self.nodes[c].power == Power::On;
        let peers: Vec<[Option<PortRef>; 4]> = (0..self.nodes.len())
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
            Event::Poll(i, epoch) => {
                let now_us = self.now_us();
                let n = &mut self.nodes[i];
                if n.epoch != epoch || n.power != Power::On || n.poll_ns != self.events.now_ns() {
                    return;
                }
                if n.deadline_ns > n.poll_ns {
                    n.poll_ns = n.deadline_ns;
                    self.events.at(n.poll_ns, Event::Poll(i, epoch));
                    return;
                }
                n.poll_ns = u64::MAX;
                debug_assert!(self.stacks[i].cell.as_ref().is_some_and(|c| c.poll_at() <= now_us));
                self.touch(i, None, false, |c, _, now| c.poll(now));
                self.settle(i, ALL_PORTS);
            }
            Event::Sample(i, epoch) => {
                let n = &self.nodes[i];
                // Stale when the cell rebooted, or woke from rest earlier.
                if n.epoch == epoch && n.power == Power::On && n.sample_ns == self.events.now_ns() {
                    self.sample(i);
                }
            }
            Event::TxFree(end) => match end {
                End::Cell(i, p) => {
                    self.nodes[i as usize].waking[p.index()] = false;
                    self.kick_cell(i as usize, p);
                }
                End::Interface(k) => {
                    self.interfaces[usize::from(k)].waking = false;
                    self.kick_interface(k);
                }
            },
            Event::Arrive { from, to, signal, followed } => self.arrive(from, to, signal, followed),
            Event::SinkPoll(k) => {
                let now_us = self.now_us();
                let i = &mut self.interfaces[usize::from(k)];
                if !i.alive {
                    return;
                }
                i.sink.poll(now_us);
                let next = i.sink.poll_at().max(now_us + 1) * 1000;
                self.events.at(next, Event::SinkPoll(k));
                self.kick_interface(k);
            }
            Event::EthernetFree => {
                self.ethernet_waking = false;
                self.flush();
            }
            Event::ToHost { bytes, followed } => {
                self.followed_on_ethernet -= followed;
                self.m.ledger.delivered += followed;
                self.ready.push_back(HostDatagram { at_ns: self.now_ns(), bytes });
            }
            Event::Fault(f) => self.fault(f),
        }
    }

    fn power_on(&mut self, i: usize) {
        use rand::Rng;
        let now_us = self.now_us();
        let phase_ns = self.phases.random_range(0..self.period_ns);
        let n = &mut self.nodes[i];
        if n.power == Power::Dead {
            return;
        }
        n.power = Power::On;
        n.epoch += 1;
        n.sample_ns = self.events.now_ns() + phase_ns;
        self.events.at(n.sample_ns, Event::Sample(i, n.epoch));
        let s = &mut self.stacks[i];
        s.cell = Some(Cell::new(self.config.organize, &s.store, now_us));
        self.processors[i] = Self::processor(&self.config).expect("checked when the network was built");
        self.settle(i, ALL_PORTS);
    }

    /// Runs `f` on cell `i` and books what it did to the upstream queues:
    /// frames that entered (the `arriving` frame when it is followed, else
    /// frames made now, sensor frames when `sensor`) and frames the router
    /// dropped. Returns `f`'s result and whether `dropped_full` moved.
    fn touch<R>(
        &mut self,
        i: usize,
        arriving: Option<Followed>,
        sensor: bool,
        f: impl FnOnce(&mut Cell, &mut Option<Address>, u64) -> R,
    ) -> (R, bool) {
        let now_ns = self.events.now_ns();
        let n = &mut self.stacks[i];
        let cell = n.cell.as_mut().expect("only powered cells are touched");
        let (master, total) = (cell.router().master(), cell.router().upstream_queued());
        let full_before = cell.router().counters().dropped_full;
        let r = f(cell, &mut n.store, now_ns / 1000);
        let full = cell.router().counters().dropped_full != full_before;
        // Queues only grow, and only a new master port clears one: when
        // neither happened, the shadow queues still match.
        if cell.router().master() == master && cell.router().upstream_queued() == total {
            debug_assert_eq!(n.shadow.each_ref().map(VecDeque::len), cell.router().upstream_lens());
            return (r, full);
        }
        // The shadow queues have the router's upstream lengths before.
        let before = n.shadow.each_ref().map(VecDeque::len);
        let after = cell.router().upstream_lens();
        for q in 0..5 {
            let (b, a) = (before[q], after[q]);
            if a < b {
                // A queue is only ever cleared (its port became the master).
                let lost = n.shadow[q].len() as u64;
                let sensors = n.shadow[q].iter().filter(|e| e.frame.sensor).count() as u64;
                n.shadow[q].clear();
                self.m.ledger.drop_upstream(DropReason::Reroute, lost, sensors);
            }
            let fresh = if a < b { a } else { a - b };
            for k in 0..fresh {
                let frame = match arriving {
                    Some(f) if q != OWN => f,
                    _ => {
                        self.m.ledger.entered += 1;
                        Followed { created_ns: now_ns, sensor }
                    }
                };
                let since_ns = if q == OWN { now_ns } else { now_ns - self.config.timing.processing_ns };
                n.shadow[q].push_back(Entry { frame, since_ns, head: b == 0 && k == 0 });
            }
        }
        (r, full)
    }

    /// After a cell was touched: start idle transmitters that have frames,
    /// and wake the cell at its next deadline. Only the transmitters in
    /// `ports` (bit `p` for port `p`) can have been given a frame.
    fn settle(&mut self, i: usize, ports: u8) {
        for p in Port::ALL.into_iter().filter(|p| ports & 1 << p.index() != 0) {
            self.kick_cell(i, p);
        }
        let n = &self.nodes[i];
        let Some(cell) = &self.stacks[i].cell else { return };
        debug_assert!(
            Port::ALL.iter().all(|p| !cell.has_pending(*p) || n.waking[p.index()]),
            "cell {i}: a transmitter with a frame will not be woken"
        );
        let has_id = cell.id().is_cell();
        let at = cell.poll_at().saturating_mul(1000).max(self.events.now_ns());
        if n.has_id != has_id {
            // The samples it skipped so far were taken with the old state.
            self.count_skipped(i);
            self.nodes[i].has_id = has_id;
        }
        let n = &mut self.nodes[i];
        n.deadline_ns = at;
        if at < n.poll_ns {
            n.poll_ns = at;
            self.events.at(at, Event::Poll(i, n.epoch));
        }
    }

    /// Cell `i`'s master port as a port bit (none when it has no master).
    fn master_port(&self, i: usize) -> u8 {
        let master = self.stacks[i].cell.as_ref().and_then(|c| c.router().master());
        master.map_or(0, |p| 1 << p.index())
    }

    /// Cell `i` takes the sample due now (first the ones it skipped while
    /// at rest), and perhaps rests from the next one on.
    fn sample(&mut self, i: usize) {
        let now_ns = self.events.now_ns();
        if let Some(r) = self.rests[i] {
            self.end_rest(i, r, now_ns - 1);
        }
        let raw = self.stimulus.raw(i, now_ns as f64 * 1e-9);
        let outs = self.processors[i].process(&raw);
        self.schedule_sample(i);
        let n = &self.nodes[i];
        let measuring = now_ns >= self.measure_from_ns;
        if measuring && n.has_id {
            self.m.samples += 1;
        }
        for message in &outs {
            self.send_own(i, message, measuring);
        }
        // A sample that sends nothing leaves the cell as it was; what it
        // sends waits on the master port.
        if !outs.is_empty() {
            self.settle(i, self.master_port(i));
        }
    }

    /// Schedules cell `i`'s next sample, one period after the one it just
    /// took; or, when it can rest, the sample that ends its rest (none when
    /// the stimulus never reaches it).
    fn schedule_sample(&mut self, i: usize) {
        let now_ns = self.events.now_ns();
        let period_ns = self.processors[i].period_us() * 1000;
        let next_ns = now_ns + period_ns;
        let epoch = self.nodes[i].epoch;
        let Some(end_ns) = self.rest_end(i, next_ns, period_ns) else {
            self.nodes[i].sample_ns = next_ns;
            self.events.after_ranked(period_ns, i as u64, Event::Sample(i, epoch));
            return;
        };
        self.rests[i] = Some(Rest { next_ns, count_ns: next_ns, period_ns });
        self.resting += 1;
        self.nodes[i].sample_ns = end_ns;
        if end_ns < u64::MAX {
            // Where it would have been in a run without rests.
            let order = Order::ranked(end_ns, end_ns - period_ns, i as u64);
            self.events.at_order(order, Event::Sample(i, epoch));
        }
    }

    /// The sample at which cell `i` would wake when it rested from its
    /// sample at `next_ns` on (`u64::MAX`: never), or `None` when it cannot
    /// rest: its stimulus reaches it within a few samples, or its
    /// processor might send something at rest.
    fn rest_end(&self, i: usize, next_ns: u64, period_ns: u64) -> Option<u64> {
        if !self.config.skip_resting_cells {
            return None;
        }
        let until_s = self.stimulus.rest_until(i, next_ns as f64 * 1e-9);
        // Rounding down: the rest ends no later than the stimulus says.
        let until_ns = if until_s.is_finite() { (until_s * 1e9) as u64 } else { u64::MAX };
        if until_ns < next_ns.saturating_add(MIN_REST_SAMPLES * period_ns) {
            return None;
        }
        let (lo, hi) = self.stimulus.rest_bounds(i);
        if !self.processors[i].silent_within(lo, hi) {
            return None;
        }
        let samples = (until_ns - next_ns).div_ceil(period_ns);
        Some(samples.checked_mul(period_ns).and_then(|d| d.checked_add(next_ns)).unwrap_or(u64::MAX))
    }

    /// The last time at which cell `i`'s skipped samples have been taken by
    /// now, as events in a run without rests would have been: a sample due
    /// in this very nanosecond only when it comes before the event taken last.
    fn taken_through(&self, i: usize, r: &Rest) -> u64 {
        let now_ns = self.events.now_ns();
        let at_now = Order::ranked(now_ns, now_ns.saturating_sub(r.period_ns), i as u64);
        if self.events.is_done(at_now) {
            now_ns
        } else {
            now_ns.saturating_sub(1)
        }
    }

    /// How many of cell `i`'s skipped samples not counted yet, through
    /// `through_ns`, count in [`Measurements::samples`] (those of a cell
    /// with an ID that come after measuring began), and the first sample
    /// after them.
    fn skipped_measured(&self, i: usize, r: &Rest, through_ns: u64) -> (u64, u64) {
        let end_ns = self.nodes[i].sample_ns;
        let (_, after) = r.span(r.count_ns, through_ns, end_ns);
        if !self.nodes[i].has_id {
            return (0, after);
        }
        let m = self.measure_from;
        let first = if r.count_ns > m.at_ns {
            r.count_ns
        } else {
            let t = r.count_ns + (m.at_ns - r.count_ns) / r.period_ns * r.period_ns;
            let later = Order::ranked(t, t.saturating_sub(r.period_ns), i as u64) > m;
            if t == m.at_ns && later {
                t
            } else {
                t + r.period_ns
            }
        };
        (r.span(first, through_ns, end_ns).0, after)
    }

    /// Counts the samples cell `i` skipped so far, if it rests.
    fn count_skipped(&mut self, i: usize) {
        let Some(mut r) = self.rests[i] else { return };
        let (n, count_ns) = self.skipped_measured(i, &r, self.taken_through(i, &r));
        self.m.samples += n;
        r.count_ns = count_ns;
        self.rests[i] = Some(r);
    }

    /// Ends cell `i`'s rest: its processor takes the samples it skipped
    /// through `through_ns`, which provably send nothing; they are counted.
    fn end_rest(&mut self, i: usize, r: Rest, through_ns: u64) -> u64 {
        let (measured, _) = self.skipped_measured(i, &r, through_ns);
        self.m.samples += measured;
        let (n, next_ns) = r.span(r.next_ns, through_ns, self.nodes[i].sample_ns);
        for _ in 0..n {
            let raw = self.stimulus.rest(i);
            let outs = self.processors[i].process(&raw);
            assert!(outs.is_empty(), "cell {i} sent {outs:?} at rest");
        }
        self.rests[i] = None;
        self.resting -= 1;
        next_ns
    }

    /// Wakes cell `i` if it rests, now: it takes the samples it skipped
    /// so far, and samples on from the next one.
    fn wake(&mut self, i: usize) {
        let Some(r) = self.rests[i] else { return };
        let next_ns = self.end_rest(i, r, self.taken_through(i, &r));
        self.nodes[i].sample_ns = next_ns;
        let order = Order::ranked(next_ns, next_ns - r.period_ns, i as u64);
        self.events.at_order(order, Event::Sample(i, self.nodes[i].epoch));
    }

    /// A cell sends one of its own messages upstream.
    fn send_own(&mut self, i: usize, message: &Message, measuring: bool) {
        let sensor = is_data(message.kind());
        let (sent, _) = self.touch(i, None, sensor, |c, _, _| c.send(message));
        match sent {
            Ok(()) if measuring && sensor => {
                self.m.data_frames += 1;
                let w = self.events.now_ns() / self.period_ns;
                if w != self.window.0 {
                    self.m.peak_data_frames_per_period = self.m.peak_data_frames_per_period.max(self.window.1);
                    self.window = (w, 0);
                }
                self.window.1 += 1;
            }
            Ok(()) | Err(SendError::NoId) => {}
            Err(SendError::QueueFull) => {
                self.m.ledger.entered += 1;
                self.m.ledger.drop_upstream(DropReason::QueueFull, 1, u64::from(sensor));
            }
        }
    }

    /// Starts cell `i`'s transmitter on port `p` if it is idle and has a
    /// frame, or makes sure it is woken when it is free.
    fn kick_cell(&mut self, i: usize, p: Port) {
        let now_ns = self.events.now_ns();
        let n = &mut self.nodes[i];
        let s = &mut self.stacks[i];
        let Some(cell) = s.cell.as_mut() else { return };
        let busy = n.busy_until_ns[p.index()];
        // A busy transmitter that will be woken asks for its frame then.
        if busy > now_ns && n.waking[p.index()] || !cell.has_pending(p) {
            return;
        }
        if busy > now_ns {
            n.waking[p.index()] = true;
            self.events.at(busy, Event::TxFree(End::Cell(i as u16, p)));
            return;
        }
        let Some(frame) = cell.transmit(p) else { return };
        let end_ns = now_ns + self.frame_ns;
        // Only the master port serves the upstream queues; which one it
        // served shows against the shadow queues.
        let upstream = !frame.kind().is_link_local() && cell.router().master() == Some(p);
        let after = if upstream { cell.router().upstream_lens() } else { [usize::MAX; 5] };
        let followed = (0..5).find(|q| after[*q] < s.shadow[*q].len()).and_then(|q| {
            let e = s.shadow[q].pop_front()?;
            let stay = end_ns - e.since_ns;
            self.m.forwarding_any_ns = self.m.forwarding_any_ns.max(stay);
            if e.head {
                self.m.forwarding_head_ns = self.m.forwarding_head_ns.max(stay);
            }
            Some(e.frame)
        });
        n.busy_until_ns[p.index()] = end_ns;
        // At most one wake-up per transmitter: one may be due right now.
        if !n.waking[p.index()] && cell.has_pending(p) {
            n.waking[p.index()] = true;
            self.events.after(self.frame_ns, Event::TxFree(End::Cell(i as u16, p)));
        }
        self.put_on_wire(End::Cell(i as u16, p), frame, followed);
    }

    fn kick_interface(&mut self, k: u8) {
        let now_ns = self.events.now_ns();
        let i = &mut self.interfaces[usize::from(k)];
        if !i.alive {
            return;
        }
        if i.busy_until_ns > now_ns {
            if i.sink.queued() > 0 && !i.waking {
                i.waking = true;
                self.events.at(i.busy_until_ns, Event::TxFree(End::Interface(k)));
            }
            return;
        }
        let Some(frame) = i.sink.transmit() else { return };
        i.busy_until_ns = now_ns + self.frame_ns;
        if !i.waking && i.sink.queued() > 0 {
            i.waking = true;
            self.events.after(self.frame_ns, Event::TxFree(End::Interface(k)));
        }
        self.put_on_wire(End::Interface(k), frame, None);
    }

    fn peer(&self, end: End) -> Option<End> {
        match end {
            End::Cell(i, p) => self.peers[i as usize][p.index()],
            End::Interface(k) => self.interfaces[usize::from(k)].at.map(End::cell),
        }
    }

    fn put_on_wire(&mut self, from: End, frame: Frame, followed: Option<Followed>) {
        self.m.ledger.transmitted += 1;
        let Some(to) = self.peer(from) else {
            self.m.ledger.lost_no_link += 1;
            if let Some(f) = followed {
                self.m.ledger.drop_upstream(DropReason::NoLink, 1, u64::from(f.sensor));
            }
            return;
        };
        let mut bytes = *frame.as_bytes();
        let signal =
            if self.bit_errors.corrupt(&mut bytes) > 0 { Signal::Corrupted(bytes) } else { Signal::Intact(frame) };
        self.on_wires += 1;
        self.followed_on_wires += u64::from(followed.is_some());
        let processing = if matches!(to, End::Cell(..)) { self.config.timing.processing_ns } else { 0 };
        self.events.after(self.frame_ns + processing, Event::Arrive { from, to, signal, followed });
    }

    fn arrive(&mut self, from: End, to: End, signal: Signal, followed: Option<Followed>) {
        self.on_wires -= 1;
        self.followed_on_wires -= u64::from(followed.is_some());
        let lost = |net: &mut Network, reason| {
            if let Some(f) = followed {
                net.m.ledger.drop_upstream(reason, 1, u64::from(f.sensor));
            }
        };
        if self.peer(from) != Some(to) {
            self.m.ledger.lost_no_link += 1;
            return lost(self, DropReason::NoLink);
        }
        let corrupted = matches!(signal, Signal::Corrupted(_));
        let valid = match &signal {
            Signal::Intact(_) => true,
            Signal::Corrupted(bytes) => Frame::parse(bytes).is_ok_and(|f| f.message().is_ok()),
        };
        match to {
            End::Cell(i, p) => {
                let i = i as usize;
                if self.nodes[i].power != Power::On {
                    self.m.ledger.lost_dead_receiver += 1;
                    return lost(self, DropReason::DeadCell);
                }
                self.m.ledger.received += 1;
                self.count_corruption(corrupted, valid);
                let queued_before = followed.map_or(0, |_| self.stacks[i].shadow[p.index()].len());
                let sensor = Kind::try_from(signal.kind_byte()).is_ok_and(is_data);
                let upstream = match signal {
                    Signal::Intact(f) => !f.kind().is_link_local() && self.master_port(i) & 1 << p.index() == 0,
                    Signal::Corrupted(_) => false,
                };
                let (delivered, full) = self.touch(i, followed, sensor, |c, store, now| match signal {
                    Signal::Intact(frame) => c.receive_frame(p, frame, now, store),
                    Signal::Corrupted(bytes) => c.receive(p, &bytes, now, store),
                });
                if !valid {
                    lost(self, DropReason::Corrupt);
                } else if followed.is_some() && self.stacks[i].shadow[p.index()].len() <= queued_before {
                    // Refused by the router: full, or it came in on the master
                    // port (a transient loop while the tree changes).
                    lost(self, if full { DropReason::QueueFull } else { DropReason::Reroute });
                }
                if let Some((_, Message::ConfigWrite(w))) = delivered {
                    self.wake(i);
                    let accepted = self.processors[i].apply(&w.setting);
                    let ack = Message::ConfigAck(ConfigAck { tag: w.tag, accepted });
                    self.send_own(i, &ack, false);
                }
                // A frame from below only ever waits for the master port
                // (which it cannot change); anything else may go anywhere.
                let ports = if upstream { self.master_port(i) } else { ALL_PORTS };
                self.settle(i, ports);
            }
            End::Interface(k) => {
                let now_us = self.now_us();
                let measuring = self.events.now_ns() >= self.measure_from_ns;
                let i = &mut self.interfaces[usize::from(k)];
                if !i.alive {
                    self.m.ledger.lost_dead_receiver += 1;
                    return lost(self, DropReason::DeadInterface);
                }
                self.m.ledger.received += 1;
                match i.sink.receive(signal.bytes(), now_us) {
                    Err(_) => {
                        self.m.ledger.corrupt_rejected += 1;
                        lost(self, DropReason::Corrupt);
                    }
                    Ok(from_cell) => {
                        if measuring {
                            i.from_cell += 1;
                        }
                        if let FromCell::Host(frame) = from_cell {
                            if measuring && is_data(frame.kind()) {
                                i.data_from_cell += 1;
                            }
                            i.up.push_back((frame, followed));
                        }
                        if corrupted {
                            self.m.ledger.corrupt_accepted += 1;
                        }
                        self.kick_interface(k);
                        self.flush();
                    }
                }
            }
        }
    }

    fn count_corruption(&mut self, corrupted: bool, valid: bool) {
        match (corrupted, valid) {
            (true, true) => self.m.ledger.corrupt_accepted += 1,
            (_, false) => self.m.ledger.corrupt_rejected += 1,
            (false, true) => {}
        }
    }

    /// Sends one datagram to the host when the Ethernet is free: the frames
    /// of the next interface port (round robin) that has any.
    fn flush(&mut self) {
        let now_ns = self.events.now_ns();
        if self.ethernet_busy_until_ns > now_ns {
            if !self.ethernet_waking {
                self.ethernet_waking = true;
                self.events.at(self.ethernet_busy_until_ns, Event::EthernetFree);
            }
            return;
        }
        let count = self.interfaces.len();
        let Some(k) = (0..count).map(|j| (self.next_flush + j) % count).find(|k| !self.interfaces[*k].up.is_empty())
        else {
            return;
        };
        self.next_flush = (k + 1) % count;
        let i = &mut self.interfaces[k];
        let take = i.up.len().min(MAX_FRAMES);
        let delay_ns = self.config.timing.datagram_ns(take);
        let at_ns = now_ns + delay_ns;
        let frames = &mut self.datagram;
        frames.clear();
        let mut followed = 0;
        for (frame, f) in i.up.drain(..take) {
            frames.push(frame);
            let Some(f) = f else { continue };
            followed += 1;
            if f.created_ns >= self.measure_from_ns && f.sensor {
                let us = (at_ns - f.created_ns) / 1000;
                self.m.latency.record(us);
                if frame.kind() == Kind::Event {
                    self.m.event_latency.record(us);
                }
            }
        }
        let header = DatagramHeader { interface: k as u8, seq: i.seq, timestamp_us: now_ns / 1000 };
        i.seq = i.seq.wrapping_add(1);
        let mut buf = [0u8; MAX_DATAGRAM];
        let len = interface::encode(header, frames, &mut buf).expect("1..=72 frames fit a datagram");
        self.ethernet_busy_until_ns = at_ns;
        self.followed_on_ethernet += followed;
        self.events.after(delay_ns, Event::ToHost { bytes: buf[..len].to_vec(), followed });
        if !self.ethernet_waking && self.interfaces.iter().any(|i| !i.up.is_empty()) {
            self.ethernet_waking = true;
            self.events.after(delay_ns, Event::EthernetFree);
        }
    }

    fn fault(&mut self, fault: FaultKind) {
        match fault {
            FaultKind::Cut(a) => {
                if let Some(b) = self.peers[a.cell][a.port.index()].take() {
                    match b {
                        End::Cell(j, q) => self.peers[j as usize][q.index()] = None,
                        End::Interface(k) => self.interfaces[usize::from(k)].at = None,
                    }
                }
            }
            FaultKind::Dead(c) => self.power_off(c, Power::Dead),
            FaultKind::Reboot(c) => {
                if self.nodes[c].power == Power::On {
                    self.power_off(c, Power::Off);
                    self.events.at(self.events.now_ns() + REBOOT_DOWN_NS, Event::PowerOn(c));
                }
            }
            FaultKind::InterfaceDown(k) => {
                let i = &mut self.interfaces[usize::from(k)];
                i.alive = false;
                let followed = i.up.iter().filter_map(|(_, f)| *f);
                let (n, sensors) = followed.fold((0, 0), |(n, s), f| (n + 1, s + u64::from(f.sensor)));
                i.up.clear();
                self.m.ledger.drop_upstream(DropReason::DeadInterface, n, sensors);
            }
        }
    }

    fn power_off(&mut self, c: usize, power: Power) {
        // The samples it skipped so far were taken (their noise drawn).
        if let Some(r) = self.rests[c] {
            self.end_rest(c, r, self.taken_through(c, &r));
        }
        self.nodes[c].power = power;
        self.nodes[c].poll_ns = u64::MAX;
        self.nodes[c].sample_ns = u64::MAX;
        let n = &mut self.stacks[c];
        if let Some(cell) = n.cell.take() {
            add(&mut n.retired, cell.router().counters());
            self.m.ledger.lost_at_power_off += cell.router().queued() as u64;
        }
        let entries = n.shadow.iter().flatten();
        let (lost, sensors) = entries.fold((0, 0), |(n, s), e| (n + 1, s + u64::from(e.frame.sensor)));
        n.shadow.iter_mut().for_each(VecDeque::clear);
        self.m.ledger.drop_upstream(DropReason::DeadCell, lost, sensors);
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
