//! A UDP socket that moves datagrams in batches: one `recvmmsg`/`sendmmsg`
//! system call for many datagrams on Linux, where a skin's hundreds of
//! thousands of frames a second would otherwise cost as many calls; a loop
//! of ordinary calls elsewhere.

use std::io;
use std::net::{SocketAddr, UdpSocket};
use std::time::Duration;

use skin_protocol::interface::MAX_DATAGRAM;
use socket2::{Domain, Protocol, SockRef, Socket, Type};

/// Most datagrams moved by one call.
pub const MAX_BATCH: usize = 1024;
/// Room for one received datagram: a byte more than the largest valid one,
/// so that an oversized datagram shows as too long instead of being cut
/// to a valid length.
pub const SLOT: usize = MAX_DATAGRAM + 1;

/// A bound UDP socket with room for a batch of received datagrams.
#[derive(Debug)]
pub struct BatchSocket {
    socket: UdpSocket,
    batched: bool,
    /// `batch` slots of [`SLOT`] bytes.
    buf: Vec<u8>,
    received: Vec<(SocketAddr, usize)>,
    read_timeout: Option<Duration>,
    #[cfg(target_os = "linux")]
    mmsg: mmsg::Scratch,
}

impl BatchSocket {
    /// Binds `addr` with a receive buffer of (at least asking for)
    /// `recv_buffer_bytes`, taking up to `batch` datagrams per call;
    /// `batched` false uses the portable one-call-per-datagram path even
    /// where batching is available.
    pub fn bind(addr: SocketAddr, recv_buffer_bytes: usize, batch: usize, batched: bool) -> io::Result<BatchSocket> {
        let socket = Socket::new(Domain::for_address(addr), Type::DGRAM, Some(Protocol::UDP))?;
        socket.set_recv_buffer_size(recv_buffer_bytes)?;
        #[cfg(target_os = "linux")]
        if socket.recv_buffer_size()? < recv_buffer_bytes {
            // Past `net.core.rmem_max` only a privileged process may go; when
            // this one is, it gets the buffer it was configured with.
            use std::os::fd::AsRawFd;
            let _ = mmsg::force_recv_buffer(socket.as_raw_fd(), recv_buffer_bytes);
        }
        socket.bind(&addr.into())?;
        let batch = batch.clamp(1, MAX_BATCH);
        Ok(BatchSocket {
            socket: socket.into(),
            batched: batched && cfg!(target_os = "linux"),
            buf: vec![0; batch * SLOT],
            received: Vec::with_capacity(batch),
            read_timeout: None,
            #[cfg(target_os = "linux")]
            mmsg: mmsg::Scratch::new(batch),
        })
    }

    /// The bound address.
    pub fn local_addr(&self) -> io::Result<SocketAddr> {
        self.socket.local_addr()
    }

    /// The receive buffer the OS granted, in bytes (Linux reports twice the
    /// size asked for, the other half being its bookkeeping).
    pub fn recv_buffer_bytes(&self) -> io::Result<usize> {
        SockRef::from(&self.socket).recv_buffer_size()
    }

    /// Sends every later datagram to `peer` only, and takes datagrams from
    /// it only.
    pub fn connect(&self, peer: SocketAddr) -> io::Result<()> {
        self.socket.connect(peer)
    }

    fn batch(&self) -> usize {
        self.buf.len() / SLOT
    }

    /// Waits up to `timeout` (not at all when zero) for a datagram, then
    /// takes every datagram already queued, up to a batch. Returns how many
    /// were taken: 0 when none came in time.
    pub fn recv(&mut self, timeout: Duration) -> io::Result<usize> {
        self.received.clear();
        if !timeout.is_zero() && self.read_timeout != Some(timeout) {
            self.socket.set_read_timeout(Some(timeout))?;
            self.read_timeout = Some(timeout);
        }
        let result = if self.batched { self.recv_batched(timeout) } else { self.recv_portable(timeout) };
        match result {
            Ok(()) => Ok(self.received.len()),
            // Nothing came, or an ICMP error from an earlier send (some
            // systems report those on the next receive): no datagram.
            Err(e) if is_no_datagram(&e) => Ok(self.received.len()),
            Err(e) => Err(e),
        }
    }

    #[cfg(target_os = "linux")]
    fn recv_batched(&mut self, timeout: Duration) -> io::Result<()> {
        use std::os::fd::AsRawFd;
        let flags = if timeout.is_zero() { libc::MSG_DONTWAIT } else { libc::MSG_WAITFORONE };
        let batch = self.batch();
        let n = self.mmsg.recv(self.socket.as_raw_fd(), &mut self.buf, SLOT, batch, flags)?;
        for i in 0..n {
            // A source that is not IPv4 or IPv6 cannot come from a UDP/IP
            // socket; such a datagram would be dropped here uncounted, so
            // give it an unspecified source, which no port is bound to.
            let from = self.mmsg.source(i).unwrap_or_else(|| SocketAddr::from(([0, 0, 0, 0], 0)));
            self.received.push((from, self.mmsg.len(i).min(SLOT)));
        }
        Ok(())
    }

    #[cfg(not(target_os = "linux"))]
    fn recv_batched(&mut self, timeout: Duration) -> io::Result<()> {
        self.recv_portable(timeout)
    }

    fn recv_portable(&mut self, timeout: Duration) -> io::Result<()> {
        // The first datagram may be waited for; the rest of the batch is
        // taken only if already there.
        self.socket.set_nonblocking(timeout.is_zero())?;
        for i in 0..self.batch() {
            if i == 1 && !timeout.is_zero() {
                self.socket.set_nonblocking(true)?;
            }
            match self.socket.recv_from(&mut self.buf[i * SLOT..(i + 1) * SLOT]) {
                Ok((len, from)) => self.received.push((from, len)),
                Err(e) if self.received.is_empty() => return Err(e),
                Err(_) => break,
            }
        }
        Ok(())
    }

    /// Datagram `i` of the last [`recv`](BatchSocket::recv): its source and bytes.
    pub fn datagram(&self, i: usize) -> (SocketAddr, &[u8]) {
        let (from, len) = self.received[i];
        (from, &self.buf[i * SLOT..i * SLOT + len])
    }

    /// Sends one datagram to `to`.
    pub fn send_to(&self, bytes: &[u8], to: SocketAddr) -> io::Result<()> {
        self.socket.send_to(bytes, to).map(drop)
    }

    /// Sends datagrams to the connected peer, as many as possible in one
    /// call; returns how many went (a short count means: call again with
    /// the rest).
    pub fn send_batch(&mut self, datagrams: &[&[u8]]) -> io::Result<usize> {
        if datagrams.is_empty() {
            return Ok(0);
        }
        #[cfg(target_os = "linux")]
        if self.batched {
            use std::os::fd::AsRawFd;
            return self.mmsg.send(self.socket.as_raw_fd(), datagrams);
        }
        self.socket.send(datagrams[0]).map(|_| 1)
    }
}

/// Errors that mean "no datagram now", not a broken socket.
pub fn is_no_datagram(e: &io::Error) -> bool {
    matches!(
        e.kind(),
        io::ErrorKind::WouldBlock
            | io::ErrorKind::TimedOut
            | io::ErrorKind::ConnectionRefused
            | io::ErrorKind::ConnectionReset
            | io::ErrorKind::Interrupted
    )
}

/// The Linux batch calls, and the privileged receive buffer. The only
/// unsafe code of the interface: the message headers point into buffers
/// that outlive each call.
#[cfg(target_os = "linux")]
#[allow(unsafe_code)]
mod mmsg {
    use std::io;
    use std::mem::{size_of, zeroed};
    use std::net::{Ipv4Addr, Ipv6Addr, SocketAddr, SocketAddrV4, SocketAddrV6};
    use std::os::fd::RawFd;

    /// Asks for a receive buffer of `bytes` past the system limit, which
    /// needs `CAP_NET_ADMIN`; the error says when the process lacks it.
    pub fn force_recv_buffer(fd: RawFd, bytes: usize) -> io::Result<()> {
        let value = libc::c_int::try_from(bytes).unwrap_or(libc::c_int::MAX);
        // SAFETY: the option value is a c_int that lives for the call, and
        // its size is passed with it.
        let r = unsafe {
            libc::setsockopt(
                fd,
                libc::SOL_SOCKET,
                libc::SO_RCVBUFFORCE,
                (&value as *const libc::c_int).cast(),
                size_of::<libc::c_int>() as libc::socklen_t,
            )
        };
        if r < 0 {
            return Err(io::Error::last_os_error());
        }
        Ok(())
    }

    /// Headers, I/O vectors and source addresses for one batch.
    #[derive(Debug)]
    pub struct Scratch {
        hdrs: Vec<libc::mmsghdr>,
        iovs: Vec<libc::iovec>,
        names: Vec<libc::sockaddr_storage>,
    }

    // SAFETY: the raw pointers inside `hdrs` and `iovs` are written right
    // before each system call and never read outside it, so moving the
    // scratch to another thread cannot make anyone use a stale pointer.
    unsafe impl Send for Scratch {}

    impl Scratch {
        pub fn new(batch: usize) -> Scratch {
            // SAFETY: all three are plain C structs for which all-zero bytes
            // are a valid (empty) value.
            let (hdr, iov, name) = unsafe { (zeroed(), zeroed(), zeroed()) };
            Scratch { hdrs: vec![hdr; batch], iovs: vec![iov; batch], names: vec![name; batch] }
        }

        /// Receives up to `batch` datagrams into the `slot`-sized slots of `buf`.
        pub fn recv(&mut self, fd: RawFd, buf: &mut [u8], slot: usize, batch: usize, flags: i32) -> io::Result<usize> {
            let n = batch.min(self.hdrs.len()).min(buf.len() / slot);
            for i in 0..n {
                self.iovs[i] = libc::iovec { iov_base: buf[i * slot..].as_mut_ptr().cast(), iov_len: slot };
                // SAFETY: as in `new`.
                let mut msg: libc::msghdr = unsafe { zeroed() };
                msg.msg_name = (&mut self.names[i] as *mut libc::sockaddr_storage).cast();
                msg.msg_namelen = size_of::<libc::sockaddr_storage>() as libc::socklen_t;
                msg.msg_iov = &mut self.iovs[i];
                msg.msg_iovlen = 1;
                self.hdrs[i] = libc::mmsghdr { msg_hdr: msg, msg_len: 0 };
            }
            // SAFETY: `hdrs[..n]` are valid headers whose name and iovec
            // pointers point into `names`, `iovs` and `buf`, all alive and
            // not otherwise borrowed for the duration of the call; each
            // iovec is `slot` bytes inside `buf`.
            let r =
                unsafe { libc::recvmmsg(fd, self.hdrs.as_mut_ptr(), n as libc::c_uint, flags, std::ptr::null_mut()) };
            if r < 0 {
                return Err(io::Error::last_os_error());
            }
            Ok(r as usize)
        }

        /// Bytes received into slot `i`.
        pub fn len(&self, i: usize) -> usize {
            self.hdrs[i].msg_len as usize
        }

        /// The source of the datagram in slot `i`.
        pub fn source(&self, i: usize) -> Option<SocketAddr> {
            let name = &self.names[i];
            match i32::from(name.ss_family) {
                libc::AF_INET => {
                    // SAFETY: the kernel wrote a sockaddr_in (family AF_INET)
                    // into storage that is large and aligned enough for it.
                    let a: libc::sockaddr_in =
                        unsafe { std::ptr::read((name as *const libc::sockaddr_storage).cast()) };
                    let ip = Ipv4Addr::from(u32::from_be(a.sin_addr.s_addr));
                    Some(SocketAddr::V4(SocketAddrV4::new(ip, u16::from_be(a.sin_port))))
                }
                libc::AF_INET6 => {
                    // SAFETY: as above, for sockaddr_in6.
                    let a: libc::sockaddr_in6 =
                        unsafe { std::ptr::read((name as *const libc::sockaddr_storage).cast()) };
                    let ip = Ipv6Addr::from(a.sin6_addr.s6_addr);
                    Some(SocketAddr::V6(SocketAddrV6::new(
                        ip,
                        u16::from_be(a.sin6_port),
                        a.sin6_flowinfo,
                        a.sin6_scope_id,
                    )))
                }
                _ => None,
            }
        }

        /// Sends `datagrams` (as many as fit a batch) on a connected socket.
        pub fn send(&mut self, fd: RawFd, datagrams: &[&[u8]]) -> io::Result<usize> {
            let n = datagrams.len().min(self.hdrs.len());
            for (i, d) in datagrams[..n].iter().enumerate() {
                // The kernel only reads through this pointer.
                self.iovs[i] = libc::iovec { iov_base: d.as_ptr() as *mut libc::c_void, iov_len: d.len() };
                // SAFETY: as in `new`.
                let mut msg: libc::msghdr = unsafe { zeroed() };
                msg.msg_iov = &mut self.iovs[i];
                msg.msg_iovlen = 1;
                self.hdrs[i] = libc::mmsghdr { msg_hdr: msg, msg_len: 0 };
            }
            // SAFETY: `hdrs[..n]` are valid headers without names (the
            // socket is connected) whose iovecs point at the caller's
            // datagrams, alive for the duration of the call.
            let r = unsafe { libc::sendmmsg(fd, self.hdrs.as_mut_ptr(), n as libc::c_uint, 0) };
            if r < 0 {
                return Err(io::Error::last_os_error());
            }
            Ok(r as usize)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pair(batched: bool) -> (BatchSocket, UdpSocket) {
        let rx = BatchSocket::bind(SocketAddr::from(([127, 0, 0, 1], 0)), 1 << 20, 8, batched).unwrap();
        let tx = UdpSocket::bind("127.0.0.1:0").unwrap();
        tx.connect(rx.local_addr().unwrap()).unwrap();
        (rx, tx)
    }

    fn batches_and_oversized_datagrams(batched: bool) {
        let (mut rx, tx) = pair(batched);
        assert_eq!(rx.recv(Duration::ZERO).unwrap(), 0);
        assert_eq!(rx.recv(Duration::from_millis(5)).unwrap(), 0);
        let sizes = [1, 36, MAX_DATAGRAM, MAX_DATAGRAM + 1, 3000, 0, 7, 8, 9, 10];
        for (i, n) in sizes.iter().enumerate() {
            tx.send(&vec![i as u8; *n]).unwrap();
        }
        let mut got = Vec::new();
        while got.len() < sizes.len() {
            let n = rx.recv(Duration::from_secs(2)).unwrap();
            assert!(n > 0 && n <= 8, "a batch holds 1..=8, got {n}");
            for i in 0..n {
                let (from, bytes) = rx.datagram(i);
                assert_eq!(from, tx.local_addr().unwrap());
                got.push((bytes.len(), bytes.first().copied()));
            }
        }
        let expected: Vec<_> =
            sizes.iter().enumerate().map(|(i, n)| ((*n).min(SLOT), (*n > 0).then_some(i as u8))).collect();
        assert_eq!(got, expected, "every datagram, oversized ones one byte too long");
    }

    #[test]
    fn batched_receive_takes_every_datagram() {
        batches_and_oversized_datagrams(true);
    }

    #[test]
    fn portable_receive_takes_every_datagram() {
        batches_and_oversized_datagrams(false);
    }

    #[test]
    fn batched_send_sends_every_datagram() {
        let rx = UdpSocket::bind("127.0.0.1:0").unwrap();
        rx.set_read_timeout(Some(Duration::from_secs(2))).unwrap();
        for batched in [true, false] {
            let mut tx = BatchSocket::bind(SocketAddr::from(([127, 0, 0, 1], 0)), 1 << 16, 4, batched).unwrap();
            tx.connect(rx.local_addr().unwrap()).unwrap();
            let data: Vec<Vec<u8>> = (0..10u8).map(|i| vec![i; 20 + usize::from(i)]).collect();
            let mut refs: Vec<&[u8]> = data.iter().map(Vec::as_slice).collect();
            while !refs.is_empty() {
                let n = tx.send_batch(&refs).unwrap();
                assert!(n >= 1);
                refs.drain(..n);
            }
            let mut buf = [0u8; 64];
            for i in 0..10u8 {
                let n = rx.recv(&mut buf).unwrap();
                assert_eq!(&buf[..n], &data[usize::from(i)][..]);
            }
        }
    }
}
