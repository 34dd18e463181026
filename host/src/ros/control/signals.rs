//! SIGINT and SIGTERM noted, not acted on: the handler only stores the
//! signal (all a handler may safely do); the bridge's thread, which wakes
//! every millisecond, sends the zero command and ends the process. The
//! host's thread blocks them, so no wait of its own ends early with EINTR,
//! and so do DDS's threads, started while they were blocked.

use std::sync::atomic::{AtomicI32, Ordering};

static RECEIVED: AtomicI32 = AtomicI32::new(0);

/// The signal received, if any.
pub fn received() -> Option<i32> {
    Some(RECEIVED.load(Ordering::SeqCst)).filter(|&s| s != 0)
}

#[cfg(target_os = "linux")]
extern "C" fn note(signal: libc::c_int) {
    RECEIVED.store(signal, Ordering::SeqCst);
}

/// Routes SIGINT and SIGTERM to [`received`] for the rest of the process,
/// and blocks them in the calling thread (the host's), so its waits on the
/// skin and the robot are never cut short by them; [`unblock`] lets the
/// bridge's thread take them.
#[cfg(target_os = "linux")]
#[allow(unsafe_code)]
pub fn install() -> std::io::Result<()> {
    for signal in [libc::SIGINT, libc::SIGTERM] {
        // SAFETY: a zeroed sigaction is valid (empty mask); the handler is
        // an `extern "C"` function that only stores an atomic.
        let result = unsafe {
            let mut action: libc::sigaction = std::mem::zeroed();
            action.sa_sigaction = note as extern "C" fn(libc::c_int) as libc::sighandler_t;
            action.sa_flags = libc::SA_RESTART;
            libc::sigaction(signal, &action, std::ptr::null_mut())
        };
        if result != 0 {
            return Err(std::io::Error::last_os_error());
        }
    }
    mask(libc::SIG_BLOCK)
}

/// Lets the calling thread take SIGINT and SIGTERM.
#[cfg(target_os = "linux")]
pub fn unblock() -> std::io::Result<()> {
    mask(libc::SIG_UNBLOCK)
}

/// Runs `start` with SIGINT and SIGTERM blocked in the calling thread, so
/// the threads it starts (DDS's event loops) inherit the mask and never
/// take them: RustDDS's event loop ends when a signal cuts its wait short,
/// and a SIGTERM delivered there left the zero command unsent (1 stop in
/// 3 of the starved host's test). The thread's mask is restored after.
#[cfg(target_os = "linux")]
#[allow(unsafe_code)]
pub fn blocked_while<T>(start: impl FnOnce() -> T) -> T {
    let set = stop_signals();
    // SAFETY: `old` is zeroed, then written by pthread_sigmask before it is read.
    let old = unsafe {
        let mut old: libc::sigset_t = std::mem::zeroed();
        (libc::pthread_sigmask(libc::SIG_BLOCK, &set, &mut old) == 0).then_some(old)
    };
    let started = start();
    if let Some(old) = old {
        // SAFETY: `old` is the mask pthread_sigmask wrote above.
        unsafe { libc::pthread_sigmask(libc::SIG_SETMASK, &old, std::ptr::null_mut()) };
    }
    started
}

/// The set of SIGINT and SIGTERM.
#[cfg(target_os = "linux")]
#[allow(unsafe_code)]
fn stop_signals() -> libc::sigset_t {
    // SAFETY: a zeroed sigset_t is initialized by sigemptyset before use.
    unsafe {
        let mut set: libc::sigset_t = std::mem::zeroed();
        libc::sigemptyset(&mut set);
        libc::sigaddset(&mut set, libc::SIGINT);
        libc::sigaddset(&mut set, libc::SIGTERM);
        set
    }
}

#[cfg(target_os = "linux")]
#[allow(unsafe_code)]
fn mask(how: libc::c_int) -> std::io::Result<()> {
    let set = stop_signals();
    // SAFETY: the set is initialized; the old mask is not asked for.
    let result = unsafe { libc::pthread_sigmask(how, &set, std::ptr::null_mut()) };
    if result != 0 {
        return Err(std::io::Error::from_raw_os_error(result));
    }
    Ok(())
}

/// Elsewhere the default handlers stay: the process ends without the zero
/// command, which the robot's own command timeout must cover.
#[cfg(not(target_os = "linux"))]
pub fn install() -> std::io::Result<()> {
    tracing::warn!("SIGINT and SIGTERM are not caught on this system: stopping skin leaves the robot's last command");
    Ok(())
}

/// Nothing to unblock where nothing was blocked.
#[cfg(not(target_os = "linux"))]
pub fn unblock() -> std::io::Result<()> {
    Ok(())
}

/// Nothing is caught, so nothing to keep from other threads.
#[cfg(not(target_os = "linux"))]
pub fn blocked_while<T>(start: impl FnOnce() -> T) -> T {
    start()
}
