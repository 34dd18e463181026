//! Receiving from a peer in lockstep, whose answer comes within
//! microseconds: a bounded run of non-blocking tries before the blocking
//! wait. A thread that blocks sleeps, and its wake-up costs an idle core's
//! latency (tens of microseconds on a virtual machine whose idle cores
//! halt) every control period; a thread that keeps trying stays on its
//! core. Between tries it yields, so a peer sharing its core runs.

use std::io::{self, ErrorKind};
use std::net::{SocketAddr, UdpSocket};
use std::time::{Duration, Instant};

/// How long a lockstep peer keeps trying before it sleeps: longer than
/// nearly every control period takes to compute at either end (of the
/// demo's 160,000 waits, 3,000-14,000 still slept at 100 us, 90-320 at
/// 300 us), short enough that a peer that went away costs a fraction of a
/// millisecond.
pub const LOCKSTEP_SPIN: Duration = Duration::from_micros(300);

/// As [`UdpSocket::recv_from`] on a blocking `socket` (its read timeout
/// bounds the wait), trying without blocking for `spin` first.
pub fn recv_from(socket: &UdpSocket, buf: &mut [u8], spin: Duration) -> io::Result<(usize, SocketAddr)> {
    if !spin.is_zero() {
        socket.set_nonblocking(true)?;
        let until = Instant::now() + spin;
        let tried = loop {
            match socket.recv_from(buf) {
                Err(e) if e.kind() == ErrorKind::WouldBlock && Instant::now() < until => std::thread::yield_now(),
                other => break other,
            }
        };
        socket.set_nonblocking(false)?;
        match tried {
            Err(e) if e.kind() == ErrorKind::WouldBlock => {}
            other => return other,
        }
    }
    socket.recv_from(buf)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_datagram_is_taken_while_trying_or_after_and_the_timeout_still_holds() {
        let rx = UdpSocket::bind("127.0.0.1:0").unwrap();
        rx.set_read_timeout(Some(Duration::from_millis(20))).unwrap();
        let tx = UdpSocket::bind("127.0.0.1:0").unwrap();
        let mut buf = [0u8; 8];
        // Already there: taken by the first try.
        tx.send_to(b"now", rx.local_addr().unwrap()).unwrap();
        let (n, from) = recv_from(&rx, &mut buf, LOCKSTEP_SPIN).unwrap();
        assert_eq!((&buf[..n], from), (&b"now"[..], tx.local_addr().unwrap()));
        // Nothing comes: the tries end and the blocking wait times out.
        let start = Instant::now();
        let e = recv_from(&rx, &mut buf, LOCKSTEP_SPIN).unwrap_err();
        assert!(matches!(e.kind(), ErrorKind::WouldBlock | ErrorKind::TimedOut), "{e}");
        assert!(start.elapsed() >= Duration::from_millis(20), "the socket blocks again after trying");
        // Sent after the tries ended: the blocking wait takes it.
        let to = rx.local_addr().unwrap();
        let late = std::thread::spawn(move || {
            std::thread::sleep(Duration::from_millis(5));
            tx.send_to(b"late", to).unwrap();
        });
        let (n, _) = recv_from(&rx, &mut buf, Duration::from_micros(10)).unwrap();
        assert_eq!(&buf[..n], b"late");
        late.join().unwrap();
    }
}
