//! `skin monitor`: a live terminal view of the skin as the interface hears
//! it: cells, rates, tactile events, drops. Redrawn in place on a terminal;
//! with `--once` or `--json` (or when the output is not a terminal) it
//! prints plain snapshots instead, so scripts and tests can use it.

use std::collections::{BTreeSet, VecDeque};
use std::io::{IsTerminal, Write};
use std::net::SocketAddr;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::{Duration, Instant};

use serde::Serialize;
use skin_host::config::{Config, PortConfig};
use skin_host::interface::{
    tactile_text, DatagramReject, Event, EventKind, FrameReject, Interface, InterfaceCounters, PortStats,
};
use skin_host::registry::Topology;
use skin_protocol::message::Channel;
use skin_protocol::Address;

use super::live::FoxgloveArgs;
use super::seconds;

/// Arguments of `skin monitor`.
#[derive(clap::Args)]
pub struct Args {
    /// Address to listen on for the skin [default: the configuration's `interface.listen`].
    #[arg(long, value_name = "ADDR")]
    interface: Option<SocketAddr>,
    /// Configuration file [default: the built-in defaults, see `skin config --default`].
    #[arg(long, value_name = "FILE")]
    config: Option<PathBuf>,
    /// Accept interface ports 0..N, each bound to the first source that claims it, instead of the configured ports.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u8).range(1..=254))]
    ports: Option<u8>,
    /// Write the configuration's cell settings into every cell as soon as a port is heard.
    #[arg(long)]
    write_settings: bool,
    /// Stop after this many seconds [default: run until Ctrl-C; 2 with --once or --json].
    #[arg(long, value_name = "SECONDS")]
    duration: Option<f64>,
    /// Print one plain snapshot at the end instead of the live view.
    #[arg(long)]
    once: bool,
    /// Print the final snapshot as one JSON object.
    #[arg(long)]
    json: bool,
    /// Redraw period in milliseconds.
    #[arg(long, default_value_t = 250, value_parser = clap::value_parser!(u64).range(10..))]
    refresh_ms: u64,
    #[command(flatten)]
    foxglove: FoxgloveArgs,
}

/// Cells heard within this time count as alive.
const ALIVE_US: u64 = 1_000_000;
/// Lines of recent events kept.
const RECENT: usize = 10;
/// Touched cells shown.
const TOUCHED: usize = 10;

pub fn run(args: Args) -> Result<ExitCode, Box<dyn std::error::Error>> {
    let mut config = match &args.config {
        Some(path) => Config::load(path)?,
        None => Config::default(),
    };
    if let Some(addr) = args.interface {
        config.interface.listen = addr;
    }
    if let Some(n) = args.ports {
        config.interface.ports = (0..n).map(|number| PortConfig { number, address: None }).collect();
    }
    config.validate()?;
    let duration = args
        .duration
        .or((args.once || args.json).then_some(2.0))
        .map(|s| seconds::duration("--duration", s))
        .transpose()?;
    let live = !args.once && !args.json && std::io::stdout().is_terminal();
    let periodic = !args.once && !args.json;

    let mut interface = Interface::bind(&config.interface)?;
    if !live {
        eprintln!("skin monitor: listening on {}", interface.local_addr());
    }
    let (foxglove, mut feed) = args.foxglove.open()?;
    let mut view = View::new(&interface);
    let settings = config.cells.settings();
    let mut settings_pending = args.write_settings;
    let refresh = Duration::from_millis(args.refresh_ms);
    let start = Instant::now();
    let mut next_draw = start + refresh;
    let mut events = Vec::new();
    let mut out = std::io::stdout().lock();
    while duration.is_none_or(|d| start.elapsed() < d) {
        events.clear();
        interface.poll(Duration::from_millis(20), &mut events)?;
        view.take(&events, interface.now_us());
        if let Some(feed) = &mut feed {
            feed.events(&events);
        }
        if settings_pending && interface.ports().iter().any(|p| p.address().is_some()) {
            let tags = interface.send_config(Address::BROADCAST, &settings)?;
            view.note(interface.now_us(), format!("wrote {} settings to every cell (tags {:?})", tags.len(), tags));
            settings_pending = false;
        }
        if periodic && Instant::now() >= next_draw {
            let snapshot = view.snapshot(&interface);
            if live {
                write!(out, "\x1b[H\x1b[J{}", snapshot.text())?;
            } else {
                writeln!(out, "{}", snapshot.text())?;
            }
            out.flush()?;
            next_draw += refresh;
        }
    }
    drop(feed);
    foxglove.finish();
    let snapshot = view.snapshot(&interface);
    if args.json {
        writeln!(out, "{}", serde_json::to_string_pretty(&snapshot)?)?;
    } else {
        writeln!(out, "{}", snapshot.text())?;
    }
    Ok(ExitCode::SUCCESS)
}

/// What the monitor keeps between redraws: activity, not the whole skin.
struct View {
    listen: SocketAddr,
    recv_buffer_bytes: usize,
    recent: VecDeque<String>,
    touched: BTreeSet<Address>,
    acks: [u64; 2],
    last: (u64, InterfaceCounters, Vec<PortStats>),
    /// The topology, recomputed only when a report changed or a cell joined:
    /// keyed by (topology version, cells heard).
    topology: ((u64, usize), Topology),
}

impl View {
    fn new(interface: &Interface) -> View {
        View {
            listen: interface.local_addr(),
            recv_buffer_bytes: interface.recv_buffer_bytes(),
            recent: VecDeque::with_capacity(RECENT),
            touched: BTreeSet::new(),
            acks: [0; 2],
            last: (0, InterfaceCounters::default(), interface.ports().iter().map(|p| *p.stats()).collect()),
            topology: ((0, 0), Topology::default()),
        }
    }

    fn note(&mut self, now_us: u64, line: String) {
        if self.recent.len() == RECENT {
            self.recent.pop_front();
        }
        self.recent.push_back(format!("{:9.3} s  {line}", now_us as f64 / 1e6));
    }

    fn take(&mut self, events: &[Event], now_us: u64) {
        for e in events {
            let cell = e.cell;
            let line = match e.kind {
                EventKind::Sample(_) => continue,
                EventKind::ConfigAck(a) => {
                    self.acks[usize::from(a.accepted)] += 1;
                    continue;
                }
                EventKind::Tactile(t) => {
                    self.touched.insert(cell);
                    format!("{cell}: {}", tactile_text(&t))
                }
                EventKind::Joined => format!("{cell} joined on port {}", e.interface),
                EventKind::Moved { from } => format!("{cell} moved from port {from} to port {}", e.interface),
                EventKind::Neighbours(_) => format!("{cell} reported new neighbours"),
                EventKind::IdAssigned { parent, port } => {
                    format!("gave ID {} to the cell on port {} of {parent}", cell.0, port.index())
                }
                EventKind::UpdateReport(r) => format!("{cell}: update {:?} of version {}", r.state, r.version),
            };
            self.note(now_us, line);
        }
    }

    fn snapshot(&mut self, interface: &Interface) -> Snapshot {
        let now_us = interface.now_us();
        let registry = interface.registry();
        let counters = *interface.counters();
        let dt = (now_us.saturating_sub(self.last.0) as f64 / 1e6).max(1e-6);
        let per_s = |now: u64, before: u64| now.saturating_sub(before) as f64 / dt;
        let ports = interface
            .ports()
            .iter()
            .zip(&self.last.2)
            .map(|(p, before)| PortView {
                number: p.number(),
                address: p.address().map(|a| a.to_string()),
                datagrams_per_s: per_s(p.stats().datagrams, before.datagrams),
                frames_per_s: per_s(p.stats().frames, before.frames),
                stats: *p.stats(),
            })
            .collect();
        let key = (registry.topology_version(), registry.len());
        if self.topology.0 != key {
            self.topology = (key, registry.topology());
        }
        let topology = &self.topology.1;
        let rates: Vec<f32> = registry
            .cells()
            .filter(|c| now_us.saturating_sub(c.last_seen_us()) <= ALIVE_US)
            .map(|c| c.health().sample_rate_hz(now_us))
            .collect();
        // Cells whose levels all fell back to 0 are no longer touched.
        self.touched.retain(|id| {
            registry.get(*id).is_some_and(|c| {
                [Channel::Proximity, Channel::Force0, Channel::Force1, Channel::Force2]
                    .iter()
                    .any(|ch| c.level(*ch) > 0)
            })
        });
        let touched = self
            .touched
            .iter()
            .filter_map(|id| registry.get(*id))
            .take(TOUCHED)
            .map(|c| TouchedCell {
                id: c.id().0,
                port: c.interface(),
                proximity_level: c.level(Channel::Proximity),
                force_level: [Channel::Force0, Channel::Force1, Channel::Force2].map(|ch| c.level(ch)),
                proximity: c.sample().map(|s| s.proximity()),
                force: c.sample().map(|s| s.force()),
            })
            .collect();
        let snapshot = Snapshot {
            listen: self.listen.to_string(),
            recv_buffer_bytes: self.recv_buffer_bytes,
            uptime_s: now_us as f64 / 1e6,
            datagrams_per_s: per_s(counters.datagrams.accepted, self.last.1.datagrams.accepted),
            frames_per_s: per_s(counters.frames.accepted, self.last.1.frames.accepted),
            counters,
            ports,
            cells: CellsView {
                heard: registry.len(),
                alive: rates.len(),
                patches: topology.patches.iter().map(Vec::len).collect(),
                max_hops: topology.hops.iter().map(|(_, h)| *h).max(),
                sample_rate_hz: (!rates.is_empty()).then(|| {
                    let min = rates.iter().copied().fold(f32::INFINITY, f32::min);
                    let max = rates.iter().copied().fold(0.0, f32::max);
                    [min, rates.iter().sum::<f32>() / rates.len() as f32, max]
                }),
            },
            acks_accepted: self.acks[1],
            acks_refused: self.acks[0],
            touched,
            touched_total: self.touched.len(),
            recent: self.recent.iter().cloned().collect(),
        };
        self.last = (now_us, counters, interface.ports().iter().map(|p| *p.stats()).collect());
        snapshot
    }
}

/// One view of the interface, for people (`text`) and machines (JSON).
#[derive(Serialize)]
struct Snapshot {
    listen: String,
    recv_buffer_bytes: usize,
    uptime_s: f64,
    /// Over the last refresh period (the whole run for the final snapshot).
    datagrams_per_s: f64,
    frames_per_s: f64,
    counters: InterfaceCounters,
    ports: Vec<PortView>,
    cells: CellsView,
    acks_accepted: u64,
    acks_refused: u64,
    touched: Vec<TouchedCell>,
    touched_total: usize,
    recent: Vec<String>,
}

#[derive(Serialize)]
struct PortView {
    number: u8,
    address: Option<String>,
    datagrams_per_s: f64,
    frames_per_s: f64,
    stats: PortStats,
}

#[derive(Serialize)]
struct CellsView {
    heard: usize,
    alive: usize,
    /// Sizes of the connected patches, largest first.
    patches: Vec<usize>,
    max_hops: Option<u16>,
    /// Min, mean and max over the alive cells.
    sample_rate_hz: Option<[f32; 3]>,
}

#[derive(Serialize)]
struct TouchedCell {
    id: u16,
    port: u8,
    proximity_level: u8,
    force_level: [u8; 3],
    proximity: Option<u16>,
    force: Option<[u16; 3]>,
}

impl Snapshot {
    fn text(&self) -> String {
        use std::fmt::Write as _;
        let c = &self.counters;
        let mut s = String::new();
        let _ = writeln!(
            s,
            "skin monitor on {}  (receive buffer {} bytes)  up {:.1} s",
            self.listen, self.recv_buffer_bytes, self.uptime_s
        );
        let _ = writeln!(
            s,
            "datagrams {:>10} accepted {:>9.0}/s   missing {}  late {}  restarts {}  rejected {}",
            c.datagrams.accepted,
            self.datagrams_per_s,
            c.datagrams.missing,
            c.datagrams.late,
            c.datagrams.restarts,
            c.datagrams.rejected_total()
        );
        let _ = writeln!(
            s,
            "frames    {:>10} accepted {:>9.0}/s   rejected {}",
            c.frames.accepted,
            self.frames_per_s,
            c.frames.rejected_total()
        );
        let reasons: Vec<String> = DatagramReject::ALL
            .iter()
            .map(|r| (r.name(), c.datagrams.rejected(*r)))
            .chain(FrameReject::ALL.iter().map(|r| (r.name(), c.frames.rejected(*r))))
            .filter(|(_, n)| *n > 0)
            .map(|(name, n)| format!("{name} {n}"))
            .collect();
        if !reasons.is_empty() {
            let _ = writeln!(s, "drops     {}", reasons.join(", "));
        }
        let cells = &self.cells;
        let _ = write!(
            s,
            "cells     {} heard, {} alive, {} patch{}",
            cells.heard,
            cells.alive,
            cells.patches.len(),
            if cells.patches.len() == 1 { "" } else { "es" }
        );
        if let Some(largest) = cells.patches.first() {
            let _ = write!(s, " (largest {largest})");
        }
        if let Some(h) = cells.max_hops {
            let _ = write!(s, ", deepest {h} hops");
        }
        if let Some([min, mean, max]) = cells.sample_rate_hz {
            let _ = write!(s, ", sampling {min:.0}/{mean:.0}/{max:.0} Hz (min/mean/max)");
        }
        s.push('\n');
        if self.acks_accepted + self.acks_refused + c.sent_frames > 0 {
            let _ = writeln!(
                s,
                "writes    {} frames sent down, {} acknowledged, {} refused, {} send failures, {} IDs given",
                c.sent_frames, self.acks_accepted, self.acks_refused, c.send_failures, c.id_replies
            );
        }
        let _ = writeln!(s, "\nport  address                  datagrams/s   frames/s  missing   late    dup  corrupt");
        for p in &self.ports {
            let _ = writeln!(
                s,
                "{:>4}  {:<22} {:>13.0} {:>10.0} {:>8} {:>6} {:>6} {:>8}",
                p.number,
                p.address.as_deref().unwrap_or("(not heard yet)"),
                p.datagrams_per_s,
                p.frames_per_s,
                p.stats.missing,
                p.stats.late,
                p.stats.duplicates,
                p.stats.corrupt_frames
            );
        }
        let _ =
            writeln!(s, "\ntouched   {} cell{}", self.touched_total, if self.touched_total == 1 { "" } else { "s" });
        for t in &self.touched {
            let _ = writeln!(
                s,
                "          cell {:>5} port {:>3}: proximity level {} ({}), force levels {:?} ({:?})",
                t.id,
                t.port,
                t.proximity_level,
                t.proximity.map_or("-".into(), |p| p.to_string()),
                t.force_level,
                t.force.unwrap_or_default()
            );
        }
        let _ = writeln!(s, "\nrecent");
        for line in &self.recent {
            let _ = writeln!(s, "  {line}");
        }
        s
    }
}
