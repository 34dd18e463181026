//! The robot-PC side of the test: the UDP end of the interface, the ID
//! allocator, and a record of everything the skin sent.

use std::collections::BTreeMap;
use std::net::{SocketAddr, UdpSocket};
use std::time::{Duration, Instant};

use skin_protocol::frame::Frame;
use skin_protocol::interface::{self, Datagram, DatagramHeader, MAX_DATAGRAM};
use skin_protocol::message::{ConfigWrite, Message, NeighbourReport, Setting, TactileEvent, UpdateReport};
use skin_protocol::organize::Allocator;
use skin_protocol::{Address, Sample};

use super::{Context, QemuError};

/// A sample or event as it arrived.
#[derive(Clone, Copy, Debug)]
pub struct Arrival<T> {
    /// When the host got it.
    pub at: Instant,
    /// The sending cell.
    pub src: Address,
    /// What it was.
    pub value: T,
}

/// The host.
#[derive(Debug)]
pub struct Host {
    socket: UdpSocket,
    gateway: Option<SocketAddr>,
    allocator: Allocator,
    seq: u32,
    start: Instant,
    /// The latest neighbour report of every cell.
    pub reports: BTreeMap<Address, NeighbourReport>,
    /// Every sample received.
    pub samples: Vec<Arrival<Sample>>,
    /// Every tactile event received.
    pub events: Vec<Arrival<TactileEvent>>,
    /// Configuration acknowledgements by cell and tag.
    pub acks: BTreeMap<(Address, u8), bool>,
    /// Every update report received, in order.
    pub updates: Vec<Arrival<UpdateReport>>,
    /// Datagrams received.
    pub datagrams: u64,
    /// Frames in them that failed their CRC or payload check.
    pub bad_frames: u64,
}

impl Host {
    /// A host on a loopback UDP port.
    pub fn bind() -> Result<Host, QemuError> {
        let socket = UdpSocket::bind("127.0.0.1:0").context(|| "binding the host's UDP socket".into())?;
        Ok(Host {
            socket,
            gateway: None,
            allocator: Allocator::new(),
            seq: 0,
            start: Instant::now(),
            reports: BTreeMap::new(),
            samples: Vec::new(),
            events: Vec::new(),
            acks: BTreeMap::new(),
            updates: Vec::new(),
            datagrams: 0,
            bad_frames: 0,
        })
    }

    /// The host's UDP address.
    pub fn addr(&self) -> Result<SocketAddr, QemuError> {
        self.socket.local_addr().context(|| "host UDP address".into())
    }

    /// Tells the host where the interface port is before it has heard from it.
    pub fn set_gateway(&mut self, addr: SocketAddr) {
        self.gateway = Some(addr);
    }

    /// Takes the datagrams that arrive within `wait`.
    pub fn pump(&mut self, wait: Duration) -> Result<(), QemuError> {
        let end = Instant::now() + wait;
        let mut buf = [0u8; MAX_DATAGRAM + 1];
        loop {
            let left = end.saturating_duration_since(Instant::now());
            if left.is_zero() {
                return Ok(());
            }
            self.socket.set_read_timeout(Some(left)).context(|| "host socket".into())?;
            match self.socket.recv_from(&mut buf) {
                Ok((n, from)) => {
                    self.gateway = Some(from);
                    self.datagram(&buf[..n])?;
                }
                Err(e) if matches!(e.kind(), std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut) => {
                    return Ok(())
                }
                Err(e) => return Err(QemuError::Io { context: "host receive".into(), source: e }),
            }
        }
    }

    fn datagram(&mut self, bytes: &[u8]) -> Result<(), QemuError> {
        let Ok(datagram) = Datagram::parse(bytes) else {
            self.bad_frames += 1;
            return Ok(());
        };
        self.datagrams += 1;
        let at = Instant::now();
        for frame in datagram.frames() {
            let Ok((frame, message)) = frame.and_then(|f| Ok((f, f.message()?))) else {
                self.bad_frames += 1;
                continue;
            };
            let src = frame.src();
            self.allocator.observe(src);
            match message {
                Message::IdRequest(r) => {
                    if let Some(reply) = self.allocator.request(r) {
                        self.send(reply)?;
                    }
                }
                Message::NeighbourReport(r) => {
                    self.reports.insert(src, r);
                }
                Message::Sample(value) => self.samples.push(Arrival { at, src, value }),
                Message::Event(value) => self.events.push(Arrival { at, src, value }),
                Message::ConfigAck(a) => {
                    self.acks.insert((src, a.tag), a.accepted);
                }
                Message::UpdateReport(value) => self.updates.push(Arrival { at, src, value }),
                _ => {}
            }
        }
        Ok(())
    }

    /// Sends one frame down the interface port.
    pub fn send(&mut self, frame: Frame) -> Result<(), QemuError> {
        self.send_all(&[frame])
    }

    /// Sends frames down the interface port, as many to a datagram as fit.
    pub fn send_all(&mut self, frames: &[Frame]) -> Result<(), QemuError> {
        let Some(gateway) = self.gateway else { return Ok(()) };
        for chunk in frames.chunks(interface::MAX_FRAMES) {
            let header =
                DatagramHeader { interface: 0, seq: self.seq, timestamp_us: self.start.elapsed().as_micros() as u64 };
            self.seq = self.seq.wrapping_add(1);
            let mut buf = [0u8; MAX_DATAGRAM];
            let len = interface::encode(header, chunk, &mut buf).unwrap_or(0);
            self.socket.send_to(&buf[..len], gateway).context(|| "host send".into())?;
        }
        Ok(())
    }

    /// Writes a setting to every cell.
    pub fn broadcast(&mut self, tag: u8, setting: Setting) -> Result<(), QemuError> {
        let write = Message::ConfigWrite(ConfigWrite { tag, setting });
        self.send(Frame::new(Address::HOST, Address::BROADCAST, &write))
    }
}
