//! The interface port: the far end of one free port of the patch, turning
//! the cell's frames into UDP datagrams for the host and the host's
//! datagrams into frames for the cell ([`skin_protocol::interface`]).

use std::io::{ErrorKind, Read, Write};
use std::net::{SocketAddr, UdpSocket};
use std::os::unix::net::{UnixListener, UnixStream};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use skin_firmware::deframer::Deframer;
use skin_protocol::frame::Frame;
use skin_protocol::interface::{self, Datagram, DatagramHeader, MAX_DATAGRAM, MAX_FRAMES};
use skin_protocol::organize::{Config, FromCell, Sink};

use super::{Context, QemuError};

/// Frame and datagram counts of a gateway.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct GatewayStats {
    /// Frames from the cell sent on to the host.
    pub frames_up: u64,
    /// Frames from the host sent to the cell.
    pub frames_down: u64,
    /// Datagrams sent to the host.
    pub datagrams_up: u64,
    /// Datagrams from the host that did not parse, or frames in them that did not.
    pub bad_from_host: u64,
    /// Bytes from the cell skipped to find frame boundaries.
    pub slipped: u64,
}

/// A running interface port; dropping it stops its thread.
#[derive(Debug)]
pub struct Gateway {
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<GatewayStats>>,
    udp: SocketAddr,
}

impl Gateway {
    /// Interface port `number`: waits on `listener` for the cell's UART and
    /// exchanges datagrams with `host` from a loopback UDP socket.
    pub fn start(number: u8, config: Config, listener: UnixListener, host: SocketAddr) -> Result<Gateway, QemuError> {
        let sink = Sink::new(number, config, 0).ok_or(QemuError::BadSize(usize::from(number)))?;
        let udp = UdpSocket::bind("127.0.0.1:0").context(|| "binding the gateway's UDP socket".into())?;
        udp.set_nonblocking(true).context(|| "gateway UDP socket".into())?;
        listener.set_nonblocking(true).context(|| "gateway listener".into())?;
        let addr = udp.local_addr().context(|| "gateway UDP address".into())?;
        let stop = Arc::new(AtomicBool::new(false));
        let flag = stop.clone();
        let thread = std::thread::Builder::new()
            .name("gateway".into())
            .spawn(move || {
                Relay {
                    sink,
                    udp,
                    host,
                    listener,
                    stream: None,
                    deframer: Deframer::new(),
                    seq: 0,
                    start: Instant::now(),
                    stats: GatewayStats::default(),
                }
                .run(&flag)
            })
            .context(|| "starting the gateway thread".into())?;
        Ok(Gateway { stop, thread: Some(thread), udp: addr })
    }

    /// The gateway's UDP address.
    pub fn udp_addr(&self) -> SocketAddr {
        self.udp
    }

    /// Stops the thread and returns its counts.
    pub fn stop(mut self) -> GatewayStats {
        self.stop.store(true, Ordering::Relaxed);
        self.thread.take().and_then(|t| t.join().ok()).unwrap_or_default()
    }
}

impl Drop for Gateway {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

struct Relay {
    sink: Sink,
    udp: UdpSocket,
    host: SocketAddr,
    listener: UnixListener,
    stream: Option<UnixStream>,
    deframer: Deframer,
    seq: u32,
    start: Instant,
    stats: GatewayStats,
}

impl Relay {
    fn now_us(&self) -> u64 {
        self.start.elapsed().as_micros() as u64
    }

    fn run(mut self, stop: &AtomicBool) -> GatewayStats {
        while !stop.load(Ordering::Relaxed) {
            if self.stream.is_none() {
                if let Ok((s, _)) = self.listener.accept() {
                    let _ = s.set_nonblocking(true);
                    self.stream = Some(s);
                    self.deframer = Deframer::new();
                }
            }
            self.relay_up();
            self.relay_down();
            let now = self.now_us();
            self.sink.poll(now);
            self.transmit();
            std::thread::sleep(Duration::from_micros(500));
        }
        self.stats.slipped = u64::from(self.deframer.slipped());
        self.stats
    }

    fn relay_up(&mut self) {
        let now = self.now_us();
        let Some(stream) = &mut self.stream else { return };
        let mut buf = [0u8; 4096];
        let mut up: Vec<Frame> = Vec::new();
        loop {
            match stream.read(&mut buf) {
                Ok(0) => {
                    self.stream = None; // the cell went away; wait for it again
                    break;
                }
                Ok(n) => {
                    for b in &buf[..n] {
                        if let Some(frame) = self.deframer.push(*b) {
                            if let Ok(FromCell::Host(f)) = self.sink.receive(frame.as_bytes(), now) {
                                up.push(f);
                            }
                        }
                    }
                }
                Err(e) if e.kind() == ErrorKind::WouldBlock => break,
                Err(_) => {
                    self.stream = None;
                    break;
                }
            }
        }
        let mut datagram = [0u8; MAX_DATAGRAM];
        for chunk in up.chunks(MAX_FRAMES) {
            let header = DatagramHeader {
                interface: self.sink.address().interface_number().unwrap_or(0),
                seq: self.seq,
                timestamp_us: now,
            };
            if let Some(len) = interface::encode(header, chunk, &mut datagram) {
                self.seq = self.seq.wrapping_add(1);
                if self.udp.send_to(&datagram[..len], self.host).is_ok() {
                    self.stats.datagrams_up += 1;
                    self.stats.frames_up += chunk.len() as u64;
                }
            }
        }
    }

    fn relay_down(&mut self) {
        let mut buf = [0u8; MAX_DATAGRAM + 1];
        while let Ok((n, _)) = self.udp.recv_from(&mut buf) {
            let Ok(datagram) = Datagram::parse(&buf[..n]) else {
                self.stats.bad_from_host += 1;
                continue;
            };
            for frame in datagram.frames() {
                match frame {
                    Ok(f) if self.sink.send(f).is_ok() => self.stats.frames_down += 1,
                    _ => self.stats.bad_from_host += 1,
                }
            }
        }
    }

    fn transmit(&mut self) {
        let mut bytes = Vec::new();
        while let Some(f) = self.sink.transmit() {
            bytes.extend_from_slice(f.as_bytes());
        }
        if let (Some(stream), false) = (&mut self.stream, bytes.is_empty()) {
            // A short stall of the cell blocks the write briefly, as a UART would.
            let _ = stream.set_nonblocking(false);
            let _ = stream.write_all(&bytes);
            let _ = stream.set_nonblocking(true);
        }
    }
}
