//! How datagrams travel between the simulated interface and a host: in
//! memory to the built-in [`Host`], or over a UDP socket on loopback to a
//! real host program, with virtual time paced to the wall clock.

use std::net::{SocketAddr, UdpSocket};
use std::time::{Duration, Instant};

use skin_protocol::interface::MAX_DATAGRAM;

use super::host::Host;
use super::simulator::HostDatagram;
use super::NetworkError;

/// The path between the interface and the host.
#[derive(Debug)]
pub enum Transport {
    /// The built-in host, in memory, on the virtual clock: deterministic.
    Memory(Host),
    /// A host program on this machine.
    Udp(UdpLink),
}

/// A UDP socket on loopback and the host's address.
#[derive(Debug)]
pub struct UdpLink {
    socket: UdpSocket,
    host: SocketAddr,
    /// Wall time at virtual time 0.
    start: Option<Instant>,
}

impl Transport {
    /// The built-in host.
    pub fn memory() -> Transport {
        Transport::Memory(Host::new())
    }

    /// Datagrams to and from a host at `host`, which must be on loopback
    /// (this simulator talks to nothing beyond this machine); the local
    /// socket binds to `bind` (port 0 picks one).
    pub fn udp(host: SocketAddr, bind: SocketAddr) -> Result<Transport, NetworkError> {
        if !host.ip().is_loopback() || !bind.ip().is_loopback() {
            return Err(NetworkError::Flag(format!(
                "{host}: the simulated interface only talks to a host on this machine; use 127.0.0.1:PORT"
            )));
        }
        let socket = UdpSocket::bind(bind)?;
        socket.set_nonblocking(true)?;
        Ok(Transport::Udp(UdpLink { socket, host, start: None }))
    }

    /// The local address of the UDP socket.
    pub fn local_addr(&self) -> Option<SocketAddr> {
        match self {
            Transport::Memory(_) => None,
            Transport::Udp(u) => u.socket.local_addr().ok(),
        }
    }

    /// The built-in host, when there is one.
    pub fn host(&self) -> Option<&Host> {
        match self {
            Transport::Memory(h) => Some(h),
            Transport::Udp(_) => None,
        }
    }

    /// Hands a datagram to the host; returns the host's answers that are
    /// due now (the built-in host answers at once).
    pub fn deliver(&mut self, d: &HostDatagram) -> Result<Vec<Vec<u8>>, NetworkError> {
        match self {
            Transport::Memory(h) => Ok(h.receive(&d.bytes)),
            Transport::Udp(u) => {
                u.socket.send_to(&d.bytes, u.host)?;
                Ok(Vec::new())
            }
        }
    }

    /// Lets wall time catch up with virtual time `now_ns` (UDP only) and
    /// returns what the host sent meanwhile.
    pub fn poll(&mut self, now_ns: u64) -> Result<Vec<Vec<u8>>, NetworkError> {
        let Transport::Udp(u) = self else { return Ok(Vec::new()) };
        let start = *u.start.get_or_insert_with(Instant::now);
        let due = start + Duration::from_nanos(now_ns);
        if let Some(wait) = due.checked_duration_since(Instant::now()) {
            std::thread::sleep(wait);
        }
        let mut got = Vec::new();
        let mut buf = [0u8; MAX_DATAGRAM + 1];
        loop {
            match u.socket.recv_from(&mut buf) {
                Ok((n, from)) if from == u.host => got.push(buf[..n].to_vec()),
                Ok(_) => {}
                Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => return Ok(got),
                Err(e) => return Err(e.into()),
            }
        }
    }
}
