//! A load generator: a skin of simulated cells behind interface ports that
//! sends real interface datagrams over UDP, clock-driven at a chosen rate,
//! so the interface can be measured and watched without hardware.
//!
//! Each interface port has its own socket (its own source address) and a
//! square patch of cells hanging off it. Every cell runs the very
//! [`Processor`](skin_protocol::processing::Processor) of the firmware on a
//! synthetic raw signal (gravity, temperature and noise, and optionally a
//! fingertip circling, pressing and lifting over the first patch), samples
//! at its own phase of the sampling period, reports its neighbour table as a
//! staggered heartbeat, applies and acknowledges the configuration writes
//! the host sends down, and has the ID it would keep in flash (IDs
//! `1..=cells`). Like an interface port that forwards what its link
//! delivered every `flush_us`, each port sends the frames gathered in that
//! time as one datagram (`flush_us = 0`: one datagram per frame).
//! Deterministic for a given seed, apart from the timing of the host's writes.

mod skin;

use std::io;
use std::net::{IpAddr, Ipv4Addr, Ipv6Addr, SocketAddr};
use std::time::{Duration, Instant};

use skin_protocol::Address;

pub use skin::{AppCell, SimSkin};

use super::socket::{is_no_datagram, BatchSocket};
use crate::config::Traffic;

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
    /// at most 80 cells (the paper's limit per port at 250 Hz) on each of
    /// 16 ports.
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
            return Err("the rate must be in (0, 10000] Hz".into());
        }
        if !(self.report_period_s >= 1e-3 && self.report_period_s.is_finite()) {
            return Err("the report period must be at least 0.001 s".into());
        }
        Ok(())
    }
}

/// How fast to send.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Pace {
    /// On the sampling clock: the datagrams of each moment leave at that
    /// moment of wall time. A generator that cannot keep up sends late (and
    /// says how late) and stops at the end of the wall time all the same,
    /// having covered less skin time.
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
    /// Configuration writes received from the host and applied by a cell.
    pub writes_applied: u64,
    /// Simulated time covered, in seconds.
    pub skin_time_s: f64,
    /// Wall time taken, in seconds.
    pub wall_time_s: f64,
    /// How far sending fell behind the sampling clock at worst (real-time
    /// pace only), in microseconds.
    pub behind_max_us: u64,
}

/// How often the ports look for datagrams from the host, in skin time.
const COMMAND_PERIOD_US: u64 = 10_000;

/// The simulated skin and one socket per interface port.
pub struct LoadGen {
    skin: SimSkin,
    sockets: Vec<BatchSocket>,
    report: LoadReport,
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
                let s = BatchSocket::bind(SocketAddr::new(any, 0), 1 << 16, 16, true)?;
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

    /// Sends for `duration` of wall time (at most that much skin time when
    /// real-time); `progress` is called with the totals after every slice of
    /// 0.25 ms (real time) or 1 ms (flat out) of skin time.
    pub fn run(&mut self, duration: Duration, pace: Pace, mut progress: impl FnMut(&LoadReport)) -> LoadReport {
        let slice_us = if pace == Pace::RealTime { 250 } else { 1000 };
        let start = Instant::now();
        let start_us = self.skin.time_us();
        let end_us = start_us + duration.as_micros() as u64;
        let mut t_us = start_us;
        while start.elapsed() < duration && (pace == Pace::FlatOut || t_us < end_us) {
            let before_us = t_us;
            t_us += slice_us;
            if pace == Pace::RealTime {
                t_us = t_us.min(end_us);
            }
            if before_us / COMMAND_PERIOD_US != t_us / COMMAND_PERIOD_US {
                self.receive_commands();
            }
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

    /// Hands every datagram the host sent down to the cells of its port.
    fn receive_commands(&mut self) {
        for (p, socket) in self.sockets.iter_mut().enumerate() {
            // A socket error here only means no command is taken now.
            while let Ok(n @ 1..) = socket.recv(Duration::ZERO) {
                for i in 0..n {
                    let applied = self.skin.command(p, socket.datagram(i).1);
                    self.report.writes_applied += applied as u64;
                }
            }
        }
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
