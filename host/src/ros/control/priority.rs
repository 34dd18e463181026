//! The bridge at real-time priority, as ros2_control's controller manager
//! runs its loop: on a robot PC loaded past its cores, a thread at normal
//! priority waits its turn for tens to hundreds of milliseconds, longer
//! than the 100 ms after which a silent `/joint_states` stops the robot.
//! The bridge's thread and the DDS threads that hear `/joint_states` take
//! [`PRIORITY`], below the robot's own 50, so the robot keeps its clock
//! first; the host's computing stays at normal priority.

/// SCHED_FIFO priority of the bridge and its DDS threads.
pub const PRIORITY: i32 = 40;

/// Puts the calling thread, and the threads it spawns from now on, at
/// SCHED_FIFO [`PRIORITY`]; an error where the system does not permit it
/// (no CAP_SYS_NICE, no rtprio limit).
#[cfg(target_os = "linux")]
pub fn raise() -> std::io::Result<()> {
    set(libc::SCHED_FIFO, PRIORITY)
}

/// Puts the calling thread back at normal priority.
#[cfg(target_os = "linux")]
pub fn lower() -> std::io::Result<()> {
    set(libc::SCHED_OTHER, 0)
}

#[cfg(target_os = "linux")]
#[allow(unsafe_code)]
fn set(policy: libc::c_int, priority: i32) -> std::io::Result<()> {
    let param = libc::sched_param { sched_priority: priority };
    // SAFETY: `param` is a valid sched_param for the call; pid 0 is the
    // calling thread.
    if unsafe { libc::sched_setscheduler(0, policy, &param) } != 0 {
        return Err(std::io::Error::last_os_error());
    }
    Ok(())
}

/// Elsewhere the bridge runs at normal priority.
#[cfg(not(target_os = "linux"))]
pub fn raise() -> std::io::Result<()> {
    Err(std::io::ErrorKind::Unsupported.into())
}

#[cfg(not(target_os = "linux"))]
pub fn lower() -> std::io::Result<()> {
    Ok(())
}
