//! SIGINT and SIGTERM noted, not acted on: the handler only stores the
//! signal (all a handler may safely do); the bridge's thread, which wakes
//! every millisecond, sends the zero command and ends the process.

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

/// Routes SIGINT and SIGTERM to [`received`] for the rest of the process.
#[cfg(target_os = "linux")]
#[allow(unsafe_code)]
pub fn install() -> std::io::Result<()> {
    for signal in [libc::SIGINT, libc::SIGTERM] {
        // SAFETY: a zeroed sigaction is valid (empty mask, no flags); the
        // handler is an `extern "C"` function that only stores an atomic.
        let result = unsafe {
            let mut action: libc::sigaction = std::mem::zeroed();
            action.sa_sigaction = note as extern "C" fn(libc::c_int) as libc::sighandler_t;
            libc::sigaction(signal, &action, std::ptr::null_mut())
        };
        if result != 0 {
            return Err(std::io::Error::last_os_error());
        }
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
