//! Receiving from a peer in lockstep, whose answer comes within
//! microseconds: a bounded run of non-blocking tries before the blocking
//! wait. A thread that blocks sleeps, and when its core then idles the
//! wake-up costs that core's exit from halt (tens of microseconds on a
//! virtual machine that polls nothing before halting) every control
//! period; a thread that keeps trying stays on its core.
//!
//! Trying only pays while each end has a core of its own. Where the two
//! ends share a core, or other processes want the cores, the tries take
//! time from the peer they wait for and miss. So a miss (no answer in the
//! time tried, or the thread descheduled while trying) makes the next
//! [`REST`] waits sleep at once.

use std::io::{self, ErrorKind};
use std::net::{SocketAddr, UdpSocket};
use std::time::{Duration, Instant};

/// The most a lockstep peer tries before it sleeps: longer than nearly
/// every control period takes to compute at either end, short enough that
/// a peer that went away costs a fraction of a millisecond.
pub const LOCKSTEP_SPIN: Duration = Duration::from_micros(300);

/// Waits that sleep without trying after a miss.
pub const REST: u32 = 16;

/// Longer than any try takes on its core: a gap this long between two
/// tries means the thread was descheduled.
const DESCHEDULED: Duration = Duration::from_micros(50);

/// Spin-loop hints between two tries: a try is a system call, and the
/// hints let a sibling hardware thread run meanwhile. The thread does not
/// yield instead: that hands the core to any other runnable process for a
/// whole time slice (`skin demo --quick` took 29.5 s instead of 5.1 s
/// beside two `nice -n 10` busy loops).
const HINTS: u32 = 32;

/// Receives from one socket, trying before it blocks while that pays.
#[derive(Debug)]
pub struct SpinRecv {
    most: Duration,
    /// Waits left to sleep without trying.
    resting: u32,
}

impl SpinRecv {
    /// Tries for up to `most` (never when zero: a real-time peer answers
    /// when its period is up, not within microseconds).
    pub fn new(most: Duration) -> SpinRecv {
        SpinRecv { most, resting: 0 }
    }

    /// Tries for up to [`LOCKSTEP_SPIN`] when the peer runs in `lockstep`,
    /// never otherwise: the one place that decides when trying pays.
    pub fn for_peer(lockstep: bool) -> SpinRecv {
        SpinRecv::new(if lockstep { LOCKSTEP_SPIN } else { Duration::ZERO })
    }

    /// As [`UdpSocket::recv_from`] on a blocking `socket` (its read
    /// timeout bounds the wait), trying without blocking first. A signal
    /// that interrupts the wait is waited through: a debugger attached to
    /// `skin demo` ended its robot link with "Interrupted system call".
    pub fn recv_from(&mut self, socket: &UdpSocket, buf: &mut [u8]) -> io::Result<(usize, SocketAddr)> {
        if self.resting > 0 {
            self.resting -= 1;
        } else if !self.most.is_zero() {
            socket.set_nonblocking(true)?;
            let tried = self.try_for(socket, buf);
            socket.set_nonblocking(false)?;
            match tried {
                Err(e) if e.kind() == ErrorKind::WouldBlock => self.resting = REST,
                answered => return answered,
            }
        }
        loop {
            match socket.recv_from(buf) {
                Err(e) if e.kind() == ErrorKind::Interrupted => continue,
                got => return got,
            }
        }
    }

    /// Tries a non-blocking `socket` until a datagram or an error comes,
    /// `most` passes, or the thread was descheduled (`WouldBlock` both).
    fn try_for(&self, socket: &UdpSocket, buf: &mut [u8]) -> io::Result<(usize, SocketAddr)> {
        let mut last = Instant::now();
        let until = last + self.most;
        loop {
            let tried = socket.recv_from(buf);
            let now = Instant::now();
            match tried {
                Err(e) if e.kind() == ErrorKind::WouldBlock && now < until && now - last < DESCHEDULED => {
                    last = now;
                    (0..HINTS).for_each(|_| std::hint::spin_loop());
                }
                other => return other,
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn socket(timeout: Duration) -> (UdpSocket, SocketAddr) {
        let s = UdpSocket::bind("127.0.0.1:0").unwrap();
        s.set_read_timeout(Some(timeout)).unwrap();
        let addr = s.local_addr().unwrap();
        (s, addr)
    }

    #[test]
    fn a_datagram_is_taken_while_trying_or_after_and_a_miss_rests_the_tries() {
        let timeout = Duration::from_millis(20);
        let (rx, to) = socket(timeout);
        let tx = UdpSocket::bind("127.0.0.1:0").unwrap();
        let mut spin = SpinRecv::new(LOCKSTEP_SPIN);
        let mut buf = [0u8; 8];
        // Already there: taken by the first try.
        tx.send_to(b"now", to).unwrap();
        let (n, from) = spin.recv_from(&rx, &mut buf).unwrap();
        assert_eq!((&buf[..n], from, spin.resting), (&b"now"[..], tx.local_addr().unwrap(), 0));
        // Nothing comes: a miss, and the blocking wait still times out.
        let start = Instant::now();
        let e = spin.recv_from(&rx, &mut buf).unwrap_err();
        assert!(matches!(e.kind(), ErrorKind::WouldBlock | ErrorKind::TimedOut), "{e}");
        assert!(start.elapsed() >= timeout, "the socket blocks again after trying");
        assert_eq!(spin.resting, REST);
        // Sent later: the blocking wait takes it; the rest counts down. The
        // wait is long, so that a loaded machine late to run the sender
        // still delivers (at `timeout` it timed out beside two busy processes).
        rx.set_read_timeout(Some(Duration::from_secs(10))).unwrap();
        let late = std::thread::spawn(move || {
            std::thread::sleep(Duration::from_millis(5));
            tx.send_to(b"late", to).unwrap();
        });
        let (n, _) = spin.recv_from(&rx, &mut buf).unwrap();
        assert_eq!((&buf[..n], spin.resting), (&b"late"[..], REST - 1));
        late.join().unwrap();
        rx.set_read_timeout(Some(timeout)).unwrap();
        // A real-time peer is never tried for.
        let mut never = SpinRecv::new(Duration::ZERO);
        let e = never.recv_from(&rx, &mut buf).unwrap_err();
        assert!(matches!(e.kind(), ErrorKind::WouldBlock | ErrorKind::TimedOut), "{e}");
        assert_eq!(never.resting, 0);
    }

    #[test]
    #[allow(unsafe_code)] // to install a handler and send a signal
    fn a_signal_does_not_end_the_wait() {
        use std::os::unix::thread::JoinHandleExt;
        extern "C" fn nothing(_: libc::c_int) {}
        // A handler without SA_RESTART: the signal interrupts recvfrom.
        // SAFETY: a zeroed sigaction with a handler that does nothing, for
        // a signal nothing else in this test binary uses.
        unsafe {
            let mut action: libc::sigaction = std::mem::zeroed();
            action.sa_sigaction = nothing as extern "C" fn(libc::c_int) as libc::sighandler_t;
            assert_eq!(libc::sigaction(libc::SIGUSR2, &action, std::ptr::null_mut()), 0);
        }
        let (rx, to) = socket(Duration::from_secs(10));
        let waiting = std::thread::spawn(move || {
            let mut buf = [0u8; 8];
            let got = SpinRecv::new(Duration::ZERO).recv_from(&rx, &mut buf);
            got.map(|(n, _)| buf[..n].to_vec())
        });
        std::thread::sleep(Duration::from_millis(100));
        // SAFETY: the thread is alive, blocked in its wait.
        assert_eq!(unsafe { libc::pthread_kill(waiting.as_pthread_t(), libc::SIGUSR2) }, 0);
        std::thread::sleep(Duration::from_millis(100));
        UdpSocket::bind("127.0.0.1:0").unwrap().send_to(b"after", to).unwrap();
        assert_eq!(waiting.join().unwrap().unwrap(), b"after");
    }

    #[test]
    fn trying_ends_when_the_thread_is_descheduled() {
        // Four times as many threads as cores, each trying for up to 2 s:
        // they can only share the cores by being taken off them, and each
        // stops at the first time it is, long before 2 s.
        let threads = 4 * std::thread::available_parallelism().map_or(2, usize::from);
        let tries: Vec<_> = (0..threads)
            .map(|_| {
                std::thread::spawn(|| {
                    let (rx, _) = socket(Duration::from_millis(20));
                    rx.set_nonblocking(true).unwrap();
                    let start = Instant::now();
                    let e = SpinRecv::new(Duration::from_secs(2)).try_for(&rx, &mut [0u8; 8]).unwrap_err();
                    assert_eq!(e.kind(), ErrorKind::WouldBlock);
                    start.elapsed()
                })
            })
            .collect();
        for t in tries {
            let took = t.join().unwrap();
            assert!(took < Duration::from_secs(1), "tried {took:?}");
        }
    }
}
