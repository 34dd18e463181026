//! A load generator: a skin of simulated cells behind interface ports that
//! sends real interface datagrams over UDP, clock-driven at a chosen rate,
//! so the interface can be measured and watched without hardware.
//!
//! Each interface port has its own socket (its own source address) and a
//! square patch of cells hanging off it. Every cell runs the very
//! [`Processor`] of the firmware on a synthetic raw signal (gravity,
//! temperature and noise, and optionally a fingertip circling, pressing and
//! lifting over the first patch), samples at its own phase of the sampling
//! period, reports its neighbour table as a staggered heartbeat, and has the
//! ID it would keep in flash (IDs `1..=cells`). Like an interface port that
//! forwards what its link delivered every `flush_us`, each port sends the
//! frames gathered in that time as one datagram (`flush_us = 0`: one
//! datagram per frame). Deterministic for a given seed.

use std::io;
use std::net::{IpAddr, Ipv4Addr, Ipv6Addr, SocketAddr};
use std::time::{Duration, Instant};

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use skin_protocol::interface::{self, DatagramHeader, MAX_DATAGRAM, MAX_FRAMES};
use skin_protocol::message::{Neighbour, NeighbourReport, Port, Setting, TrafficMode};
use skin_protocol::processing::Processor;
use skin_protocol::{Address, Frame, Message, Sample};

use super::socket::{is_no_datagram, BatchSocket};
use crate::config::{PortConfig, Traffic};

/// What skin to simulate and how it sends.
#[derive(Clone, Debug, PartialEq)]
pub struct LoadSpec {
    /// Number of cells.
    pub cells: u16,
    /// Number of interface ports (numbered from 0); the cells are split
    /// evenly among them, one patch each.
    pub ports: u8,
    /// Sampling rate of every cell.
    pub rate_hz: f64,
    /// Each port sends what it gathered every this many microseconds;
    /// 0 sends every frame in a datagram of its own.
    pub flush_us: u64,
    /// Clock-driven or event-driven sending.
    pub traffic: Traffic,
    /// A fingertip circling, pressing and lifting over the first patch.
    pub touch: bool,
    /// Period of each cell's neighbour-table heartbeat.
    pub report_period_s: f64,
    /// Seed of the sensor noise.
    pub seed: u64,
}

impl Default for LoadSpec {
    /// The heavy skin of the interface's requirement: 1,260 cells at 250 Hz,
    /// 80 cells (the paper's most per port at 250 Hz) on each of 16 ports.
    fn default() -> Self {
        LoadSpec {
            cells: 1260,
            ports: 16,
            rate_hz: 250.0,
            flush_us: 1000,
            traffic: Traffic::Clock,
            touch: false,
            report_period_s: 4.0,
            seed: 1,
        }
    }
}

impl LoadSpec {
    /// Samples per second of the whole skin (the frame rate when clock-driven).
    pub fn sample_rate_hz(&self) -> f64 {
        f64::from(self.cells) * self.rate_hz
    }

    /// Checks the values; the message names the bad one.
    pub fn validate(&self) -> Result<(), String> {
        if self.cells == 0 || self.cells > Address::MAX_CELL {
            return Err(format!("cells must be in 1..={}", Address::MAX_CELL));
        }
        if self.ports == 0 || u16::from(self.ports) > Address::MAX_INTERFACES || u16::from(self.ports) > self.cells {
            return Err(format!("ports must be in 1..={} and at most the number of cells", Address::MAX_INTERFACES));
        }
        if !(self.rate_hz > 0.0 && self.rate_hz <= 10_000.0) {
            return Err("rate must be in (0, 10000] Hz".into());
        }
        if !(self.report_period_s > 0.0 && self.report_period_s.is_finite()) {
            return Err("the report period must be positive".into());
        }
        Ok(())
    }

    /// The interface ports the host must accept: numbers `0..ports`, each
    /// bound to the address of the generator socket that sends for it.
    pub fn port_configs(&self, addresses: &[SocketAddr]) -> Vec<PortConfig> {
        addresses.iter().enumerate().map(|(i, a)| PortConfig { number: i as u8, address: Some(*a) }).collect()
    }
}

/// How fast to send.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Pace {
    /// On the sampling clock: the datagrams of each moment leave at that
    /// moment of wall time.
    RealTime,
    /// As fast as the generator can, for the given wall time.
    FlatOut,
}

/// What a run sent.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct LoadReport {
    /// Frames handed to the OS.
    pub frames: u64,
    /// Datagrams handed to the OS.
    pub datagrams: u64,
    /// Datagrams the OS refused to send (their frames are not in `frames`).
    pub send_errors: u64,
    /// Simulated time covered, in seconds.
    pub skin_time_s: f64,
    /// Wall time taken, in seconds.
    pub wall_time_s: f64,
    /// How far sending fell behind the sampling clock at worst (real-time
    /// pace only), in microseconds.
    pub behind_max_us: u64,
}

struct SimCell {
    id: Address,
    port: usize,
    /// Position in its patch, in cell pitches.
    row: f64,
    col: f64,
    phase_us: f64,
    processor: Processor,
    report: NeighbourReport,
    /// The heartbeat is sent in the cycles `k` with `k % report_cycles == report_slot`.
    report_slot: u64,
}

/// Datagrams waiting to leave one port.
#[derive(Default)]
struct Outgoing {
    bytes: Vec<u8>,
    /// Length and number of frames of each datagram.
    datagrams: Vec<(usize, usize)>,
}

/// The simulated skin, without sockets: it turns skin time into encoded
/// datagrams, port by port.
pub struct SimSkin {
    spec: LoadSpec,
    cells: Vec<SimCell>,
    /// Cell indices in order of sampling phase.
    order: Vec<usize>,
    rng: ChaCha8Rng,
    period_us: f64,
    report_cycles: u64,
    /// Next sample: cycle and position in `order`.
    cycle: u64,
    next: usize,
    next_flush_us: u64,
    pending: Vec<Vec<Frame>>,
    outgoing: Vec<Outgoing>,
    seq: Vec<u32>,
}

/// The simulated skin and one socket per interface port.
pub struct LoadGen {
    skin: SimSkin,
    sockets: Vec<BatchSocket>,
    report: LoadReport,
}

/// Grid neighbours of patch position `j` in a patch of `m` cells and `cols`
/// columns: port 0 east, 1 north, 2 west, 3 south; each neighbour is
/// reached on its opposite port.
fn grid_neighbour(j: usize, m: usize, cols: usize, port: Port) -> Option<(usize, Port)> {
    let (row, col) = (j / cols, j % cols);
    match port {
        Port::P0 if col + 1 < cols && j + 1 < m => Some((j + 1, Port::P2)),
        Port::P1 if row > 0 => Some((j - cols, Port::P3)),
        Port::P2 if col > 0 => Some((j - 1, Port::P0)),
        Port::P3 if j + cols < m => Some((j + cols, Port::P1)),
        _ => None,
    }
}

impl SimSkin {
    /// Builds the skin; the error names the bad value of `spec`.
    pub fn new(spec: LoadSpec) -> Result<SimSkin, String> {
        spec.validate()?;
        let ports = usize::from(spec.ports);
        let n = usize::from(spec.cells);
        let period_us = 1e6 / spec.rate_hz;
        let report_cycles = ((spec.report_period_s * spec.rate_hz).round() as u64).max(1);
        let mut cells = Vec::with_capacity(n);
        for p in 0..ports {
            let (first, end) = (p * n / ports, (p + 1) * n / ports);
            let m = end - first;
            let cols = (m as f64).sqrt().ceil() as usize;
            for j in 0..m {
                let id = |k: usize| Address((first + k + 1) as u16);
                let mut report = NeighbourReport::default();
                for port in Port::ALL {
                    report.neighbours[port.index()] = match grid_neighbour(j, m, cols, port) {
                        Some((k, their)) => Some(Neighbour { id: id(k), port: their }),
                        // The first cell's free west port is wired to the interface port.
                        None if j == 0 && port == Port::P2 => {
                            Address::interface(p as u8).map(|a| Neighbour { id: a, port: Port::P0 })
                        }
                        None => None,
                    };
                }
                let mut processor = Processor::new();
                let mode = match spec.traffic {
                    Traffic::Clock => TrafficMode::Clock,
                    Traffic::Event => TrafficMode::Event,
                };
                processor.apply(&Setting::SampleRateHz(spec.rate_hz as f32));
                processor.apply(&Setting::Traffic(mode));
                cells.push(SimCell {
                    id: id(j),
                    port: p,
                    row: (j / cols) as f64,
                    col: (j % cols) as f64,
                    phase_us: j as f64 * period_us / m as f64,
                    processor,
                    report,
                    report_slot: (first + j) as u64 % report_cycles,
                });
            }
        }
        let mut order: Vec<usize> = (0..n).collect();
        order.sort_by(|a, b| cells[*a].phase_us.total_cmp(&cells[*b].phase_us));
        Ok(SimSkin {
            rng: ChaCha8Rng::seed_from_u64(spec.seed),
            period_us,
            report_cycles,
            cycle: 0,
            next: 0,
            next_flush_us: spec.flush_us,
            pending: (0..ports).map(|_| Vec::with_capacity(MAX_FRAMES)).collect(),
            outgoing: (0..ports).map(|_| Outgoing::default()).collect(),
            seq: vec![0; ports],
            spec,
            cells,
            order,
        })
    }

    /// What is simulated.
    pub fn spec(&self) -> &LoadSpec {
        &self.spec
    }

    /// Skin time reached, in microseconds.
    pub fn time_us(&self) -> u64 {
        (self.cycle as f64 * self.period_us) as u64
    }

    /// The encoded datagrams waiting to leave port `p` (index = number),
    /// each with its number of frames.
    pub fn outgoing(&self, p: usize) -> impl Iterator<Item = (&[u8], usize)> {
        let out = &self.outgoing[p];
        out.datagrams.iter().scan(0, |at, (len, frames)| {
            let d = &out.bytes[*at..*at + len];
            *at += len;
            Some((d, *frames))
        })
    }

    /// Forgets the waiting datagrams (they were sent).
    pub fn clear_outgoing(&mut self) {
        for out in &mut self.outgoing {
            out.bytes.clear();
            out.datagrams.clear();
        }
    }

    /// Encodes what every port still gathers, stamped `t_us`.
    pub fn flush_all(&mut self, t_us: u64) {
        for p in 0..self.pending.len() {
            self.flush(p, t_us);
        }
    }

    /// Samples every cell whose sampling time is at or before `until_us`,
    /// and encodes the datagrams of the ports whose flush time has come.
    pub fn generate(&mut self, until_us: u64) {
        loop {
            let cell = &self.cells[self.order[self.next]];
            let t_sample = (self.cycle as f64 * self.period_us + cell.phase_us) as u64;
            if self.spec.flush_us > 0 && self.next_flush_us <= t_sample.min(until_us) {
                for p in 0..self.pending.len() {
                    self.flush(p, self.next_flush_us);
                }
                self.next_flush_us += self.spec.flush_us;
                continue;
            }
            if t_sample > until_us {
                return;
            }
            let index = self.order[self.next];
            self.sample(index, t_sample);
            let port = self.cells[index].port;
            if self.spec.flush_us == 0 || self.pending[port].len() + 5 > MAX_FRAMES {
                self.flush(port, t_sample);
            }
            self.next += 1;
            if self.next == self.order.len() {
                self.next = 0;
                self.cycle += 1;
            }
        }
    }

    /// One sampling instant of one cell: its raw signal through its
    /// processor, and its heartbeat when due.
    fn sample(&mut self, index: usize, t_us: u64) {
        let raw = self.raw(index, t_us as f64 / 1e6);
        let cell = &mut self.cells[index];
        for message in cell.processor.process(&raw) {
            self.pending[cell.port].push(Frame::new(cell.id, Address::HOST, &message));
        }
        if self.cycle % self.report_cycles == cell.report_slot {
            let frame = Frame::new(cell.id, Address::HOST, &Message::NeighbourReport(cell.report));
            self.pending[cell.port].push(frame);
        }
    }

    /// The raw sensor signal of a cell at time `t_s`, in sensor counts.
    fn raw(&mut self, index: usize, t_s: f64) -> Sample {
        let cell = &self.cells[index];
        let (mut proximity, mut force) = (0.0, 0.0);
        if self.spec.touch && cell.port == 0 {
            // A fingertip circling over the patch every 4 s, approaching,
            // pressing and lifting every 2 s.
            let m = usize::from(self.spec.cells) / usize::from(self.spec.ports);
            let side = (m as f64).sqrt();
            let angle = std::f64::consts::TAU * t_s / 4.0;
            let (cy, cx) = (side / 2.0 + side / 3.0 * angle.sin(), side / 2.0 + side / 3.0 * angle.cos());
            let d2 = (cell.row - cy).powi(2) + (cell.col - cx).powi(2);
            let height = 0.5 + 0.5 * (std::f64::consts::TAU * t_s / 2.0).cos();
            proximity = (-(d2 + (3.0 * height).powi(2)) / 2.0).exp();
            if height < 0.2 {
                force = 0.6 * (-d2).exp() * (0.2 - height) / 0.2;
            }
        }
        let rng = &mut self.rng;
        let mut noise = |amplitude: i32| rng.random_range(-amplitude..=amplitude);
        let p = (300.0 + proximity * 65_000.0) as i32 + noise(20);
        let f = (force * 4095.0) as i32;
        let forces = [f + noise(2), f + noise(2), f + noise(2)].map(|v| v.clamp(0, i32::from(u16::MAX)) as u16);
        Sample::saturating(
            p.clamp(0, i32::from(u16::MAX)) as u16,
            forces,
            [noise(2) as i16, noise(2) as i16, (256 + noise(2)) as i16],
            (960 + noise(1)) as i16,
            0,
        )
    }

    /// Encodes port `p`'s gathered frames as datagrams stamped `t_us`.
    fn flush(&mut self, p: usize, t_us: u64) {
        let frames = std::mem::take(&mut self.pending[p]);
        for chunk in frames.chunks(MAX_FRAMES) {
            let out = &mut self.outgoing[p];
            let at = out.bytes.len();
            out.bytes.resize(at + MAX_DATAGRAM, 0);
            let header = DatagramHeader { interface: p as u8, seq: self.seq[p], timestamp_us: t_us };
            // 1..=72 frames into a buffer of the largest datagram's size.
            let len = interface::encode(header, chunk, &mut out.bytes[at..]).unwrap_or(0);
            out.bytes.truncate(at + len);
            out.datagrams.push((len, chunk.len()));
            self.seq[p] = self.seq[p].wrapping_add(1);
        }
        self.pending[p] = frames;
        self.pending[p].clear();
    }
}

impl LoadGen {
    /// Builds the skin and opens one socket per port, each sending to `host`.
    pub fn new(spec: LoadSpec, host: SocketAddr) -> io::Result<LoadGen> {
        let skin = SimSkin::new(spec).map_err(|e| io::Error::new(io::ErrorKind::InvalidInput, e))?;
        // Bound to any address, connected: the OS picks the source address
        // that reaches the host, and `local_addr` then names it.
        let any =
            if host.is_ipv4() { IpAddr::from(Ipv4Addr::UNSPECIFIED) } else { IpAddr::from(Ipv6Addr::UNSPECIFIED) };
        let sockets = (0..skin.spec().ports)
            .map(|_| {
                let s = BatchSocket::bind(SocketAddr::new(any, 0), 1 << 16, 64, true)?;
                s.connect(host)?;
                Ok(s)
            })
            .collect::<io::Result<Vec<_>>>()?;
        Ok(LoadGen { skin, sockets, report: LoadReport::default() })
    }

    /// The source address of each port, in port order.
    pub fn port_addresses(&self) -> Vec<SocketAddr> {
        self.sockets.iter().filter_map(|s| s.local_addr().ok()).collect()
    }

    /// The simulated skin.
    pub fn spec(&self) -> &LoadSpec {
        self.skin.spec()
    }

    /// Sends for `duration` (of skin time when real-time, of wall time when
    /// flat out); `progress` is called with the totals after every slice.
    pub fn run(&mut self, duration: Duration, pace: Pace, mut progress: impl FnMut(&LoadReport)) -> LoadReport {
        const SLICE_US: u64 = 250;
        let start = Instant::now();
        let start_us = self.skin.time_us();
        let end_us = start_us + duration.as_micros() as u64;
        let mut t_us = start_us;
        loop {
            let done = match pace {
                Pace::RealTime => t_us >= end_us,
                Pace::FlatOut => start.elapsed() >= duration,
            };
            if done {
                break;
            }
            let slice = if pace == Pace::FlatOut { 4 * SLICE_US } else { SLICE_US };
            t_us = if pace == Pace::RealTime { (t_us + slice).min(end_us) } else { t_us + slice };
            self.skin.generate(t_us);
            if pace == Pace::RealTime {
                let due = Duration::from_micros(t_us - start_us);
                match due.checked_sub(start.elapsed()) {
                    Some(wait) => std::thread::sleep(wait),
                    None => {
                        let behind = (start.elapsed() - due).as_micros() as u64;
                        self.report.behind_max_us = self.report.behind_max_us.max(behind);
                    }
                }
            }
            self.send();
            self.report.skin_time_s = t_us as f64 / 1e6;
            self.report.wall_time_s = start.elapsed().as_secs_f64();
            progress(&self.report);
        }
        self.skin.flush_all(t_us);
        self.send();
        self.report.wall_time_s = start.elapsed().as_secs_f64();
        self.report
    }

    /// Sends every encoded datagram.
    fn send(&mut self) {
        for (p, socket) in self.sockets.iter_mut().enumerate() {
            let datagrams: Vec<(&[u8], usize)> = self.skin.outgoing(p).collect();
            let mut rest = &datagrams[..];
            while !rest.is_empty() {
                let bytes: Vec<&[u8]> = rest.iter().map(|(d, _)| *d).collect();
                match socket.send_batch(&bytes) {
                    Ok(n) => {
                        self.report.datagrams += n as u64;
                        self.report.frames += rest[..n].iter().map(|(_, f)| *f as u64).sum::<u64>();
                        rest = &rest[n..];
                    }
                    Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
                    Err(e) => {
                        // Nobody listening yet (refused) or a full buffer:
                        // the datagram is lost, as on a real link.
                        if !is_no_datagram(&e) {
                            tracing::debug!("load generator send failed: {e}");
                        }
                        self.report.send_errors += 1;
                        rest = &rest[1..];
                    }
                }
            }
        }
        self.skin.clear_outgoing();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grids_wire_both_ends_of_every_link() {
        for (m, cols) in [(80, 9), (7, 3), (1, 1), (10, 4)] {
            for j in 0..m {
                for port in Port::ALL {
                    if let Some((k, theirs)) = grid_neighbour(j, m, cols, port) {
                        assert!(k < m);
                        assert_eq!(grid_neighbour(k, m, cols, theirs), Some((j, port)), "{m} {cols} {j} {port:?}");
                    }
                }
            }
        }
    }
}
