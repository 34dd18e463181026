//! The interface ports the host knows, each bound to one source address.
//!
//! A datagram's header names the interface port it came from; the host
//! believes it only when the datagram's source address is the one bound to
//! that port. A port configured with an address is bound from the start; a
//! port configured without one is bound to the first source that claims it
//! (convenient on loopback, where a simulator's ports have ephemeral
//! addresses). A claimed port whose source has been silent for
//! [`REBIND_QUIET_US`] goes to the next source that claims it, with a log
//! line: a skin endpoint that restarts comes back from new addresses, and
//! its cells re-organize under the IDs their places in the tree had (the
//! allocator answers the same request with the same ID). A port configured
//! with an address never moves: pin addresses where spoofing matters.

use std::net::SocketAddr;

use serde::Serialize;
use skin_protocol::interface::{self, DatagramHeader};
use skin_protocol::Frame;

use super::counters::DatagramReject;
use super::sequence::{SeqWindow, Verdict};
use crate::config::PortConfig;

/// What the host counted for one interface port.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct PortStats {
    /// Datagrams accepted.
    pub datagrams: u64,
    /// Frames decoded and dispatched.
    pub frames: u64,
    /// Frames that failed their CRC, kind or payload check.
    pub corrupt_frames: u64,
    /// Datagrams dropped as duplicates or too old to tell.
    pub duplicates: u64,
    /// Accepted datagrams that arrived after a later one.
    pub late: u64,
    /// Sequence numbers skipped and never filled: datagrams lost.
    pub missing: u64,
    /// Times the port's sender started its sequence over.
    pub restarts: u64,
    /// Host clock at the last accepted datagram, in microseconds.
    pub last_rx_us: Option<u64>,
    /// The latest sender's clock among the accepted datagrams, in
    /// microseconds (a simulated skin's is the simulation's clock).
    pub latest_timestamp_us: Option<u64>,
    /// Times the port went to a new source after its old one fell silent.
    pub rebinds: u64,
}

/// How long a claimed port's source must be silent before another source
/// may claim the port: 2 s, ten times the longest quiet a running skin
/// keeps (its slowest neighbour report period).
pub const REBIND_QUIET_US: u64 = 2_000_000;

/// One interface port as the host sees it.
#[derive(Clone, Debug)]
pub struct Port {
    number: u8,
    address: Option<SocketAddr>,
    /// True when the address came from the configuration, not a claim.
    pinned: bool,
    /// Host clock when the bound source was last admitted.
    heard_us: u64,
    window: SeqWindow,
    down_seq: u32,
    stats: PortStats,
}

impl Port {
    /// The port number that datagrams carry.
    pub fn number(&self) -> u8 {
        self.number
    }

    /// The address the port sends from and the host sends to, once known.
    pub fn address(&self) -> Option<SocketAddr> {
        self.address
    }

    /// What was counted on this port.
    pub fn stats(&self) -> &PortStats {
        &self.stats
    }

    pub(crate) fn stats_mut(&mut self) -> &mut PortStats {
        &mut self.stats
    }

    /// Takes the datagram's sequence number; false when the datagram is a
    /// duplicate or stale and must be dropped.
    pub(crate) fn sequence(&mut self, seq: u32, counters: &mut super::counters::DatagramCounters) -> bool {
        let verdict = self.window.observe(seq);
        match verdict {
            Verdict::Ahead { skipped } => {
                self.stats.missing += u64::from(skipped);
                counters.missing += u64::from(skipped);
            }
            Verdict::Late => {
                self.stats.late += 1;
                self.stats.missing = self.stats.missing.saturating_sub(1);
                counters.late += 1;
                counters.missing = counters.missing.saturating_sub(1);
            }
            Verdict::Restart => {
                // The very first datagram also restarts the window; only
                // later ones are restarts of a running sender.
                if self.stats.datagrams > 0 {
                    self.stats.restarts += 1;
                    counters.restarts += 1;
                }
            }
            Verdict::Duplicate => {
                self.stats.duplicates += 1;
                counters.reject(DatagramReject::Duplicate);
            }
            Verdict::Stale => {
                self.stats.duplicates += 1;
                counters.reject(DatagramReject::Stale);
            }
        }
        verdict.accepts()
    }

    /// Encodes `frames` (1..=72) as the next datagram down this port.
    pub(crate) fn encode_down(&mut self, frames: &[Frame], timestamp_us: u64, buf: &mut [u8]) -> Option<usize> {
        let header = DatagramHeader { interface: self.number, seq: self.down_seq, timestamp_us };
        let len = interface::encode(header, frames, buf)?;
        self.down_seq = self.down_seq.wrapping_add(1);
        Some(len)
    }
}

/// All configured ports.
#[derive(Clone, Debug, Default)]
pub struct Ports {
    ports: Vec<Port>,
    /// Index into `ports` by port number.
    by_number: Vec<Option<usize>>,
}

impl Ports {
    /// The configured ports; numbers and addresses are assumed unique (the
    /// configuration checks that).
    pub fn new(config: &[PortConfig]) -> Ports {
        let mut by_number = vec![None; 256];
        let ports = config
            .iter()
            .enumerate()
            .map(|(i, c)| {
                by_number[usize::from(c.number)] = Some(i);
                Port {
                    number: c.number,
                    address: c.address,
                    pinned: c.address.is_some(),
                    heard_us: 0,
                    window: SeqWindow::default(),
                    down_seq: 0,
                    stats: PortStats::default(),
                }
            })
            .collect();
        Ports { ports, by_number }
    }

    /// The index of the port a datagram from `from` received at host time
    /// `now_us` claiming port `number` belongs to, binding an unbound port to
    /// its first source and a claimed port whose source fell silent to the
    /// new one.
    pub fn admit(&mut self, from: SocketAddr, number: u8, now_us: u64) -> Result<usize, DatagramReject> {
        let i = self.by_number[usize::from(number)].ok_or(DatagramReject::UnknownPort)?;
        let port = &self.ports[i];
        if port.address == Some(from) {
            self.ports[i].heard_us = now_us;
            return Ok(i);
        }
        if port.pinned || self.ports.iter().any(|p| p.address == Some(from)) {
            return Err(DatagramReject::Spoofed);
        }
        let port = &mut self.ports[i];
        match port.address {
            None => tracing::info!(port = number, %from, "interface port bound to its first source"),
            Some(old) if now_us.saturating_sub(port.heard_us) >= REBIND_QUIET_US => {
                tracing::warn!(
                    port = number, %old, new = %from,
                    "interface port rebound: its source was silent {:.1} s and a new one claims it (the skin endpoint restarted?)",
                    now_us.saturating_sub(port.heard_us) as f64 / 1e6
                );
                port.stats.rebinds += 1;
                // The new source numbers its datagrams from the start.
                port.window = SeqWindow::default();
            }
            Some(_) => return Err(DatagramReject::Spoofed),
        }
        port.address = Some(from);
        port.heard_us = now_us;
        Ok(i)
    }

    /// The port at `index`.
    pub fn get(&self, index: usize) -> &Port {
        &self.ports[index]
    }

    pub(crate) fn get_mut(&mut self, index: usize) -> &mut Port {
        &mut self.ports[index]
    }

    /// The index of port `number`, if configured.
    pub fn index_of(&self, number: u8) -> Option<usize> {
        self.by_number[usize::from(number)]
    }

    /// Every port, in configuration order.
    pub fn iter(&self) -> impl Iterator<Item = &Port> {
        self.ports.iter()
    }

    /// Number of ports.
    pub fn len(&self) -> usize {
        self.ports.len()
    }

    /// True when no port is configured.
    pub fn is_empty(&self) -> bool {
        self.ports.is_empty()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn addr(p: u16) -> SocketAddr {
        SocketAddr::from(([127, 0, 0, 1], p))
    }

    #[test]
    fn bound_unbound_unknown_and_spoofed() {
        let mut ports =
            Ports::new(&[PortConfig { number: 0, address: Some(addr(100)) }, PortConfig { number: 3, address: None }]);
        assert_eq!(ports.admit(addr(100), 0, 0), Ok(0));
        assert_eq!(ports.admit(addr(101), 0, 0), Err(DatagramReject::Spoofed));
        assert_eq!(ports.admit(addr(100), 7, 0), Err(DatagramReject::UnknownPort));
        // Port 0's source may not take over port 3 ...
        assert_eq!(ports.admit(addr(100), 3, 0), Err(DatagramReject::Spoofed));
        // ... a new source binds it, and then owns it.
        assert_eq!(ports.admit(addr(200), 3, 0), Ok(1));
        assert_eq!(ports.get(1).address(), Some(addr(200)));
        assert_eq!(ports.admit(addr(201), 3, 0), Err(DatagramReject::Spoofed));
        assert_eq!(ports.admit(addr(200), 0, 0), Err(DatagramReject::Spoofed));
    }

    #[test]
    fn a_claimed_port_goes_to_a_new_source_only_after_the_old_one_fell_silent() {
        let mut ports =
            Ports::new(&[PortConfig { number: 0, address: Some(addr(100)) }, PortConfig { number: 3, address: None }]);
        assert_eq!(ports.admit(addr(200), 3, 0), Ok(1));
        assert_eq!(ports.admit(addr(200), 3, 1_000_000), Ok(1));
        // Still talking: a newcomer is a spoofer.
        assert_eq!(ports.admit(addr(300), 3, 1_000_000 + REBIND_QUIET_US - 1), Err(DatagramReject::Spoofed));
        // Silent for the quiet time: the restarted endpoint takes the port.
        assert_eq!(ports.admit(addr(300), 3, 1_000_000 + REBIND_QUIET_US), Ok(1));
        assert_eq!(ports.get(1).address(), Some(addr(300)));
        assert_eq!(ports.get(1).stats().rebinds, 1);
        assert_eq!(ports.admit(addr(200), 3, 1_000_000 + REBIND_QUIET_US), Err(DatagramReject::Spoofed));
        // A port pinned by the configuration never moves.
        assert_eq!(ports.admit(addr(100), 0, 0), Ok(0));
        assert_eq!(ports.admit(addr(101), 0, 100 * REBIND_QUIET_US), Err(DatagramReject::Spoofed));
    }
}
