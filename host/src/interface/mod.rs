//! The host's UDP interface to the skin.
//!
//! One socket takes the datagrams of every interface port (Table 2), in
//! batches; [`Ingest`] checks each one (length, magic, version, port and
//! source, sequence; then every frame's CRC, kind, addresses and payload),
//! counts every outcome, keeps the [`Registry`] of cells and turns what the
//! skin said into [`Event`]s. Configuration writes and the answers to ID
//! requests go back down the same socket, to the port that leads to the
//! cell.
//!
//! ```no_run
//! # use skin_host::{config::InterfaceConfig, interface::Interface};
//! let mut interface = Interface::bind(&InterfaceConfig::default())?;
//! let mut events = Vec::new();
//! loop {
//!     events.clear();
//!     interface.poll(std::time::Duration::from_millis(10), &mut events)?;
//!     for e in &events { /* ... */ }
//! }
//! # Ok::<(), skin_host::interface::Error>(())
//! ```

mod counters;
mod event;
mod ingest;
pub mod loadgen;
mod ports;
mod ratelog;
mod sequence;
mod silence;
mod socket;

use std::net::SocketAddr;
use std::time::{Duration, Instant};

use skin_protocol::interface::{MAX_DATAGRAM, MAX_FRAMES};
use skin_protocol::message::{ConfigWrite, Setting};
use skin_protocol::update::Via;
use skin_protocol::{Address, Frame, Message};

pub use counters::{DatagramCounters, DatagramReject, FrameCounters, FrameReject, InterfaceCounters};
pub use event::{tactile_text, Event, EventKind};
pub use ingest::{Ingest, MAX_UNHEARD_IDS, RECLAIM_UNHEARD_US};
pub use ports::{Port, PortStats, Ports, REBIND_QUIET_US};
pub use silence::{silence_bound_s, Heard, SilenceWatch, Silent, WALL_BOUND};

use crate::config::InterfaceConfig;
use crate::registry::Registry;
use socket::BatchSocket;

/// Why the interface could not do what was asked.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// The interface configuration is inconsistent.
    #[error(transparent)]
    Config(#[from] crate::config::Error),
    /// The socket could not be opened on the address.
    #[error("cannot listen for the skin on {addr}: {source} (is another `skin` using it? pick another with --interface ADDR)")]
    Bind {
        /// The address asked for.
        addr: SocketAddr,
        /// What the OS said.
        source: std::io::Error,
    },
    /// The socket failed while running.
    #[error("interface socket: {0}")]
    Io(#[from] std::io::Error),
    /// A configuration write for a cell the interface has not heard from,
    /// so it does not know which port leads to it.
    #[error("{0} has not been heard from, so no interface port is known to lead to it")]
    UnknownCell(Address),
    /// A configuration write to an address that is neither a cell nor broadcast.
    #[error("{0} cannot be configured: address a cell or broadcast")]
    BadTarget(Address),
    /// A setting that no cell would accept.
    #[error("setting {0:?} is out of range")]
    InvalidSetting(Setting),
    /// No interface port has an address yet: none was configured and none
    /// has sent anything.
    #[error("no interface port has been heard from yet: wait for the skin, or give the ports' addresses in the configuration")]
    NoPortAddress,
}

/// The UDP interface: socket, checks, counters and registry.
#[derive(Debug)]
pub struct Interface {
    socket: BatchSocket,
    local_addr: SocketAddr,
    recv_buffer_bytes: usize,
    ingest: Ingest,
    started: Instant,
    next_tag: u8,
    send_buf: Vec<u8>,
}

impl Interface {
    /// Opens the socket of `config` with batched receive where the OS has it.
    pub fn bind(config: &InterfaceConfig) -> Result<Interface, Error> {
        Interface::bind_with(config, true)
    }

    /// As [`Interface::bind`]; `batched` false forces one system call per
    /// datagram (the path of systems without `recvmmsg`).
    pub fn bind_with(config: &InterfaceConfig, batched: bool) -> Result<Interface, Error> {
        config.validate()?;
        let socket = BatchSocket::bind(config.listen, config.recv_buffer_bytes, config.batch, batched)
            .map_err(|source| Error::Bind { addr: config.listen, source })?;
        let granted = socket.recv_buffer_bytes()?;
        if granted < config.recv_buffer_bytes {
            tracing::warn!(
                asked = config.recv_buffer_bytes,
                granted,
                "the OS gave a smaller receive buffer than configured; bursts may overflow it \
                 (on Linux raise net.core.rmem_max)"
            );
        }
        Ok(Interface {
            local_addr: socket.local_addr()?,
            recv_buffer_bytes: granted,
            socket,
            ingest: Ingest::new(&config.ports),
            started: Instant::now(),
            next_tag: 0,
            send_buf: vec![0; MAX_DATAGRAM],
        })
    }

    /// The address the interface listens on.
    pub fn local_addr(&self) -> SocketAddr {
        self.local_addr
    }

    /// The receive buffer the OS granted, in bytes.
    pub fn recv_buffer_bytes(&self) -> usize {
        self.recv_buffer_bytes
    }

    /// The host clock of the interface: microseconds since it was bound.
    pub fn now_us(&self) -> u64 {
        self.started.elapsed().as_micros() as u64
    }

    /// Waits up to `timeout` for datagrams, takes a batch of them and
    /// appends their events to `events`, then answers the ID requests among
    /// them. Returns the number of datagrams taken (0 on timeout).
    pub fn poll(&mut self, timeout: Duration, events: &mut Vec<Event>) -> Result<usize, Error> {
        self.poll_tapped(timeout, events, &mut |_, _, _| {})
    }

    /// As [`Interface::poll`], and shows `tap` every datagram as it came
    /// off the socket (source, [`Interface::now_us`], bytes) before it is
    /// checked: what a recording keeps.
    pub fn poll_tapped(
        &mut self,
        timeout: Duration,
        events: &mut Vec<Event>,
        tap: &mut dyn FnMut(SocketAddr, u64, &[u8]),
    ) -> Result<usize, Error> {
        let n = self.socket.recv(timeout)?;
        let now_us = self.now_us();
        for i in 0..n {
            let (from, bytes) = self.socket.datagram(i);
            tap(from, now_us, bytes);
            self.ingest.datagram(from, bytes, now_us, events);
        }
        let replies = self.ingest.take_replies();
        for (port, frames) in group_by_port(&replies) {
            self.send_down(port, &frames);
        }
        Ok(n)
    }

    /// Writes `settings` into cell `target`, or into every cell when
    /// `target` is [`Address::BROADCAST`]; returns the tags the cells will
    /// echo in their [`EventKind::ConfigAck`], one per setting.
    pub fn send_config(&mut self, target: Address, settings: &[Setting]) -> Result<Vec<u8>, Error> {
        if let Some(bad) = settings.iter().find(|s| !s.is_valid()) {
            return Err(Error::InvalidSetting(*bad));
        }
        let ports: Vec<usize> = if target == Address::BROADCAST {
            let known: Vec<usize> =
                (0..self.ingest.ports().len()).filter(|i| self.ingest.ports().get(*i).address().is_some()).collect();
            if known.is_empty() {
                return Err(Error::NoPortAddress);
            }
            known
        } else if target.is_cell() {
            let cell = self.ingest.registry().get(target).ok_or(Error::UnknownCell(target))?;
            self.ingest.ports().index_of(cell.interface()).into_iter().collect()
        } else {
            return Err(Error::BadTarget(target));
        };
        let mut tags = Vec::with_capacity(settings.len());
        let frames: Vec<Frame> = settings
            .iter()
            .map(|setting| {
                let tag = self.next_tag;
                self.next_tag = self.next_tag.wrapping_add(1);
                tags.push(tag);
                Frame::new(Address::HOST, target, &Message::ConfigWrite(ConfigWrite { tag, setting: *setting }))
            })
            .collect();
        for port in ports {
            self.send_down(port, &frames);
        }
        Ok(tags)
    }

    /// Sends update messages (see [`skin_protocol::update::Distributor`])
    /// to `target` down `via`: one interface port by its number, or (for
    /// [`Via::Every`]) the port a known cell is heard through, else every
    /// port whose address is known.
    pub fn send_update(&mut self, via: Via, target: Address, messages: &[Message]) -> Result<(), Error> {
        let known = |i: &usize| self.ingest.ports().get(*i).address().is_some();
        let cell_port = self.ingest.registry().get(target).and_then(|c| self.ingest.ports().index_of(c.interface()));
        let ports: Vec<usize> = match (via, cell_port) {
            (Via::Port(number), _) => self.ingest.ports().index_of(number).filter(known).into_iter().collect(),
            (Via::Every, Some(p)) => vec![p],
            (Via::Every, None) => (0..self.ingest.ports().len()).filter(known).collect(),
        };
        if ports.is_empty() {
            return Err(Error::NoPortAddress);
        }
        let frames: Vec<Frame> = messages.iter().map(|m| Frame::new(Address::HOST, target, m)).collect();
        for port in ports {
            self.send_down(port, &frames);
        }
        Ok(())
    }

    /// Sends frames down port `index`, in datagrams of up to 72 frames.
    /// Failures are counted and logged, not returned: the skin side repeats
    /// what matters (ID requests), and a lost configuration write shows as
    /// a missing acknowledgement.
    fn send_down(&mut self, index: usize, frames: &[Frame]) {
        let now_us = self.now_us();
        let (ports, counters) = self.ingest.ports_and_counters();
        let port = ports.get_mut(index);
        let Some(to) = port.address() else {
            counters.send_failures += frames.len() as u64;
            tracing::warn!(port = port.number(), "cannot send down a port whose address is unknown");
            return;
        };
        for chunk in frames.chunks(MAX_FRAMES) {
            let Some(len) = port.encode_down(chunk, now_us, &mut self.send_buf) else { continue };
            match self.socket.send_to(&self.send_buf[..len], to) {
                Ok(()) => {
                    counters.sent_datagrams += 1;
                    counters.sent_frames += chunk.len() as u64;
                }
                Err(e) => {
                    counters.send_failures += chunk.len() as u64;
                    tracing::warn!(port = port.number(), %to, "sending down failed: {e}");
                }
            }
        }
    }

    /// Everything counted so far.
    pub fn counters(&self) -> &InterfaceCounters {
        self.ingest.counters()
    }

    /// The cells heard.
    pub fn registry(&self) -> &Registry {
        self.ingest.registry()
    }

    /// The interface ports.
    pub fn ports(&self) -> &Ports {
        self.ingest.ports()
    }
}

/// Frames grouped by port index, keeping their order within each port.
fn group_by_port(frames: &[(usize, Frame)]) -> Vec<(usize, Vec<Frame>)> {
    let mut groups: Vec<(usize, Vec<Frame>)> = Vec::new();
    for (port, frame) in frames {
        match groups.iter_mut().find(|(p, _)| p == port) {
            Some((_, g)) => g.push(*frame),
            None => groups.push((*port, vec![*frame])),
        }
    }
    groups
}
