//! The simulated skin of the load generator, without sockets: skin time in,
//! encoded interface datagrams out, port by port; configuration writes in,
//! acknowledgements out. Every cell runs the protocol's cell application
//! ([`App`]) straight onto its interface port: no cell-2-cell network.

use std::cmp::Reverse;
use std::collections::BinaryHeap;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use skin_protocol::app::{App, MemoryStore, Uplink};
use skin_protocol::cell::SendError;
use skin_protocol::interface::{self, Datagram, DatagramHeader, MAX_DATAGRAM, MAX_FRAMES};
use skin_protocol::message::{ConfigWrite, Neighbour, NeighbourReport, Port, Setting, TrafficMode};
use skin_protocol::{Address, Frame, Message, Sample};

use super::LoadSpec;
use crate::config::Traffic;

struct LoadCell {
    port: usize,
    /// Position in its patch, in cell pitches.
    row: f64,
    col: f64,
    app: AppCell,
    report: NeighbourReport,
    next_report_us: u64,
}

/// A load generator's cell: the cell application with an ID, sending
/// straight to its interface port (which never refuses).
#[derive(Debug)]
pub struct AppCell {
    id: Address,
    app: App<MemoryStore>,
}

/// The frames a port gathers, as a cell's uplink.
struct Gather<'a> {
    id: Address,
    frames: &'a mut Vec<Frame>,
}

impl Uplink for Gather<'_> {
    fn send(&mut self, message: &Message) -> Result<(), SendError> {
        self.frames.push(Frame::new(self.id, Address::HOST, message));
        Ok(())
    }
}

impl AppCell {
    /// Cell `id` booting from `store`.
    pub fn new(id: Address, store: MemoryStore) -> AppCell {
        AppCell { id, app: App::new(store) }
    }

    /// The sampling period.
    pub fn period_us(&self) -> u64 {
        self.app.processor().period_us()
    }

    /// Takes a raw sample; what it sends goes to `frames`.
    pub fn sample(&mut self, raw: &Sample, frames: &mut Vec<Frame>) {
        self.app.sample(raw, &mut Gather { id: self.id, frames });
    }

    /// Applies, keeps and acknowledges a configuration write into `frames`.
    pub fn configure(&mut self, write: &ConfigWrite, frames: &mut Vec<Frame>) {
        self.app.configure(write, &mut Gather { id: self.id, frames });
    }

    /// Powers the cell off and on: it boots again from its store.
    pub fn reboot(&mut self) {
        let store = *self.app.store();
        self.app = App::new(store);
    }
}

/// Datagrams waiting to leave one port.
#[derive(Default)]
struct Outgoing {
    bytes: Vec<u8>,
    /// Length and number of frames of each datagram.
    datagrams: Vec<(usize, usize)>,
}

/// The simulated cells and what their interface ports have gathered.
pub struct SimSkin {
    spec: LoadSpec,
    cells: Vec<LoadCell>,
    /// Next sampling time of every cell, earliest first: (time, cell index).
    due: BinaryHeap<Reverse<(u64, usize)>>,
    rng: ChaCha8Rng,
    report_period_us: u64,
    now_us: u64,
    next_flush_us: u64,
    pending: Vec<Vec<Frame>>,
    outgoing: Vec<Outgoing>,
    seq: Vec<u32>,
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
        let report_period_us = (spec.report_period_s * 1e6) as u64;
        let mode = match spec.traffic {
            Traffic::Clock => TrafficMode::Clock,
            Traffic::Event => TrafficMode::Event,
        };
        let mut cells = Vec::with_capacity(n);
        let mut due = BinaryHeap::with_capacity(n);
        for p in 0..ports {
            let (first, end) = (p * n / ports, (p + 1) * n / ports);
            let m = end - first;
            let cols = (m as f64).sqrt().ceil() as usize;
            for j in 0..m {
                let id = |k: usize| Address((first + k + 1) as u16);
                let mut report = NeighbourReport::default();
                for port in Port::ALL {
                    report.neighbours[port.index()] = match grid_neighbour(j, m, cols, port) {
                        Some((k, theirs)) => Some(Neighbour { id: id(k), port: theirs }),
                        // The first cell's free west port is wired to the interface port.
                        None if j == 0 && port == Port::P2 => {
                            Address::interface(p as u8).map(|a| Neighbour { id: a, port: Port::P0 })
                        }
                        None => None,
                    };
                }
                // The master-port tree: west along the row, north up the
                // first column, and the first cell's west to the interface.
                report.master = Some(if j % cols == 0 && j > 0 { Port::P1 } else { Port::P2 });
                // Calibrated at the factory, with the load's rate and traffic kept.
                let settings = [Setting::SampleRateHz(spec.rate_hz as f32), Setting::Traffic(mode)];
                let app = AppCell::new(id(j), MemoryStore::with(Some([0; 8]), settings));
                // The cells of a port sample at evenly spread phases, and the
                // heartbeats of the whole skin are spread over their period.
                due.push(Reverse((j as u64 * app.period_us() / m as u64, cells.len())));
                cells.push(LoadCell {
                    port: p,
                    row: (j / cols) as f64,
                    col: (j % cols) as f64,
                    app,
                    report,
                    next_report_us: (first + j) as u64 * report_period_us / n as u64,
                });
            }
        }
        Ok(SimSkin {
            rng: ChaCha8Rng::seed_from_u64(spec.seed),
            report_period_us,
            now_us: 0,
            next_flush_us: spec.flush_us,
            pending: (0..ports).map(|_| Vec::with_capacity(MAX_FRAMES)).collect(),
            outgoing: (0..ports).map(|_| Outgoing::default()).collect(),
            seq: vec![0; ports],
            spec,
            cells,
            due,
        })
    }

    /// What is simulated.
    pub fn spec(&self) -> &LoadSpec {
        &self.spec
    }

    /// Skin time reached, in microseconds.
    pub fn time_us(&self) -> u64 {
        self.now_us
    }

    /// Samples every cell whose sampling time is at or before `until_us`,
    /// and encodes the datagrams of the ports whose flush time has come.
    pub fn generate(&mut self, until_us: u64) {
        loop {
            let t_sample = self.due.peek().map_or(u64::MAX, |Reverse((t, _))| *t);
            if self.spec.flush_us > 0 && self.next_flush_us <= t_sample.min(until_us) {
                self.flush_all(self.next_flush_us);
                self.next_flush_us += self.spec.flush_us;
                continue;
            }
            if t_sample > until_us {
                break;
            }
            let Some(Reverse((t, index))) = self.due.pop() else { break };
            self.sample(index, t);
            let cell = &self.cells[index];
            self.due.push(Reverse((t + cell.app.period_us().max(1), index)));
            // A port forwards at once without a flush period, and early when
            // its datagram is nearly full.
            if self.spec.flush_us == 0 || self.pending[cell.port].len() + 5 > MAX_FRAMES {
                self.flush(cell.port, t);
            }
        }
        self.now_us = self.now_us.max(until_us);
    }

    /// One sampling instant of one cell: its raw signal through its
    /// processor, and its heartbeat when due.
    fn sample(&mut self, index: usize, t_us: u64) {
        let raw = self.raw(index, t_us as f64 / 1e6);
        let cell = &mut self.cells[index];
        cell.app.sample(&raw, &mut self.pending[cell.port]);
        if t_us >= cell.next_report_us {
            cell.next_report_us += self.report_period_us;
            let report = Message::NeighbourReport(cell.report);
            self.pending[cell.port].push(Frame::new(cell.app.id, Address::HOST, &report));
        }
    }

    /// The raw sensor signal of a cell at time `t_s`, in sensor counts.
    fn raw(&mut self, index: usize, t_s: f64) -> Sample {
        let cell = &self.cells[index];
        let (mut proximity, mut force) = (0.0, 0.0);
        if self.spec.touch && cell.port == 0 {
            // A fingertip circling over the patch every 4 s, approaching,
            // pressing and lifting every 2 s.
            let side = (f64::from(self.spec.cells) / f64::from(self.spec.ports)).sqrt();
            let angle = std::f64::consts::TAU * t_s / 4.0;
            let (cy, cx) = (side / 2.0 + side / 3.0 * angle.sin(), side / 2.0 + side / 3.0 * angle.cos());
            let d2 = (cell.row - cy).powi(2) + (cell.col - cx).powi(2);
            let height = 0.5 + 0.5 * (std::f64::consts::TAU * t_s / 2.0).cos();
            proximity = (-(d2 + (3.0 * height).powi(2)) / 2.0).exp();
            if height < 0.2 {
                force = 0.35 * (-d2).exp() * (0.2 - height) / 0.2;
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

    /// Takes a datagram the host sent down port `p`: every configuration
    /// write in it is applied by the cells it is addressed to (all cells of
    /// the port for a broadcast), which acknowledge it. Returns the number
    /// of writes applied; anything else is ignored, as a cell would.
    pub fn command(&mut self, p: usize, bytes: &[u8]) -> usize {
        let Ok(datagram) = Datagram::parse(bytes) else { return 0 };
        let mut applied = 0;
        for frame in datagram.frames().flatten() {
            let Ok(Message::ConfigWrite(write)) = frame.message() else { continue };
            let dst = frame.dst();
            for cell in self.cells.iter_mut().filter(|c| c.port == p && (dst == Address::BROADCAST || dst == c.app.id))
            {
                cell.app.configure(&write, &mut self.pending[p]);
                applied += 1;
            }
        }
        applied
    }

    /// Encodes what every port still gathers, stamped `t_us`.
    pub fn flush_all(&mut self, t_us: u64) {
        for p in 0..self.pending.len() {
            self.flush(p, t_us);
        }
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

    fn all_datagrams(skin: &SimSkin) -> Vec<(usize, Vec<u8>)> {
        (0..usize::from(skin.spec().ports)).flat_map(|p| skin.outgoing(p).map(move |(d, _)| (p, d.to_vec()))).collect()
    }

    #[test]
    fn clock_driven_rate_flush_period_and_determinism() {
        let spec = LoadSpec { cells: 40, ports: 2, flush_us: 1000, report_period_s: 0.5, ..LoadSpec::default() };
        let mut a = SimSkin::new(spec.clone()).unwrap();
        a.generate(999_999);
        a.flush_all(999_999);
        let frames: usize = (0..2).flat_map(|p| a.outgoing(p)).map(|(_, f)| f).sum();
        // 40 cells x 250 samples, plus two heartbeats each.
        assert_eq!(frames, 40 * 250 + 40 * 2);
        assert_eq!(a.outgoing(0).count(), 1000, "a datagram per port every 1 ms");
        let mut b = SimSkin::new(spec).unwrap();
        b.generate(999_999);
        b.flush_all(999_999);
        assert_eq!(all_datagrams(&a), all_datagrams(&b), "same seed, same bytes");
    }

    #[test]
    fn configuration_writes_are_applied_and_acknowledged() {
        let spec = LoadSpec { cells: 10, ports: 2, flush_us: 0, ..LoadSpec::default() };
        let mut skin = SimSkin::new(spec).unwrap();
        let write = |dst, setting| {
            let f = Frame::new(
                Address::HOST,
                dst,
                &Message::ConfigWrite(skin_protocol::message::ConfigWrite { tag: 7, setting }),
            );
            let mut buf = [0u8; MAX_DATAGRAM];
            let n =
                interface::encode(DatagramHeader { interface: 1, seq: 0, timestamp_us: 0 }, &[f], &mut buf).unwrap();
            buf[..n].to_vec()
        };
        assert_eq!(skin.command(1, &write(Address::BROADCAST, Setting::Traffic(TrafficMode::Event))), 5);
        assert_eq!(skin.command(1, &write(Address(2), Setting::Hysteresis(0.01))), 0, "cell 2 is on port 0");
        assert_eq!(skin.command(0, &write(Address(2), Setting::SampleRateHz(-1.0))), 1);
        assert_eq!(skin.command(0, b"not a datagram"), 0);
        skin.flush_all(0);
        let acks: Vec<(u16, bool)> = (0..2)
            .flat_map(|p| skin.outgoing(p).map(|(d, _)| d.to_vec()).collect::<Vec<_>>())
            .flat_map(|d| Datagram::parse(&d).unwrap().frames().map(Result::unwrap).collect::<Vec<_>>())
            .filter_map(|frame| match frame.message().unwrap() {
                Message::ConfigAck(a) => Some((frame.src().0, a.accepted)),
                _ => None,
            })
            .collect();
        assert_eq!(acks, [(2, false), (6, true), (7, true), (8, true), (9, true), (10, true)]);
        // Event-driven and quiet: port 1's cells fall silent after their first samples.
        skin.clear_outgoing();
        skin.generate(1_000_000);
        let port1: usize = skin.outgoing(1).map(|(_, f)| f).sum();
        let port0: usize = skin.outgoing(0).map(|(_, f)| f).sum();
        assert!(port1 < 20 && port0 > 1000, "port 0 {port0}, port 1 {port1}");
    }

    /// Highest level seen per channel (proximity, forces 0..3) in 4 s.
    fn max_levels(touch: bool) -> [u8; 4] {
        let spec = LoadSpec { cells: 80, ports: 1, flush_us: 0, touch, ..LoadSpec::default() };
        let mut skin = SimSkin::new(spec).unwrap();
        skin.generate(4_000_000);
        let mut levels = [0u8; 4];
        for (d, _) in skin.outgoing(0) {
            for frame in Datagram::parse(d).unwrap().frames() {
                if let Ok(Message::Event(e)) = frame.unwrap().message() {
                    let i = e.channel as usize;
                    levels[i] = levels[i].max(e.level);
                }
            }
        }
        levels
    }

    #[test]
    fn a_touch_raises_tactile_events_and_a_quiet_skin_none() {
        let touched = max_levels(true);
        assert!(touched[0] >= 3 && touched[1..].iter().all(|l| (2..=3).contains(l)), "{touched:?}");
        assert_eq!(max_levels(false), [0; 4]);
    }
}
