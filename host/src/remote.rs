//! A robot and its skin reached over UDP, as on the real HRP-2: the robot
//! on the robot link ([`skin_protocol::robot_link`]), the skin through the
//! interface ([`Interface`]).
//!
//! [`RobotLink`] is the three requirements of section 3.2 over the wire:
//! the number of revolute DoFs (and their names) at connection, then one
//! velocity command per control period answered by position feedback.
//! [`Remote`] joins it with the interface into the [`Robot`] +
//! [`SampleSource`] the exploration and the controller drive: one tick is
//! one command and its feedback, then every datagram the skin sent
//! meanwhile. A robot in lockstep (a simulator) moves one period per
//! command, so ticks run as fast as both ends go; a real-time robot is
//! paced by the host's clock.

use std::net::{SocketAddr, UdpSocket};
use std::time::{Duration, Instant};

use skin_model::spin_recv::SpinRecv;
use skin_protocol::robot_link::{self, FromRobot, ToRobot, MAX_DOFS, MAX_NAME};
use skin_protocol::{Address, Sample};

use crate::interface::{DatagramReject, Event, EventKind, Heard, Interface, SilenceWatch, WALL_BOUND};
use crate::recording::{RecordError, Session};
use crate::robot::{DofKind, Robot, RobotError, SampleSource};

/// Tries of one request before the robot counts as gone.
const TRIES: u32 = 5;
/// Longest wall-clock time the robot's clock may stand still while it
/// answers: the wall-clock bound of every wait counted in robot time (a
/// lockstep robot advances it on every command, a real-time one every
/// period).
const CLOCK_STALL: Duration = Duration::from_secs(2);

/// The longest one wait for late datagrams blocks before the ports are judged again.
const SILENCE_POLL: Duration = Duration::from_millis(2);

/// What the robot said about itself when the link opened.
#[derive(Clone, Debug, PartialEq)]
pub struct RobotInfo {
    /// DoF names, in command order.
    pub dof_names: Vec<String>,
    /// DoF kinds, in command order.
    pub dof_kinds: Vec<DofKind>,
    /// The robot's control period, s.
    pub period_s: f64,
    /// The robot advances one period per command (a simulator).
    pub lockstep: bool,
}

/// Counts of the link's trouble.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct LinkCounters {
    /// Requests sent again after no answer came in time.
    pub retries: u64,
    /// Datagrams that were not the answer awaited (late, foreign, malformed).
    pub ignored: u64,
}

/// The robot over the robot link.
#[derive(Debug)]
pub struct RobotLink {
    socket: UdpSocket,
    robot: SocketAddr,
    info: RobotInfo,
    timeout: Duration,
    seq: u32,
    command: Vec<f64>,
    positions: Vec<f64>,
    time_us: u64,
    /// When `time_us` last advanced, on the host's clock.
    clock_moved: Instant,
    /// How long a wait for an answer tries before it sleeps: a lockstep
    /// robot (a simulator) answers within microseconds, a real one when
    /// its period is up.
    spin: SpinRecv,
    counters: LinkCounters,
}

fn gone(robot: SocketAddr, why: impl std::fmt::Display) -> RobotError {
    RobotError::Disconnected(format!("robot at {robot}: {why}"))
}

/// The local address on the interface that routes to `robot` (loopback for
/// a robot on loopback), any port: the link listens nowhere else. Where the
/// route cannot be asked, every interface.
fn local_toward(robot: SocketAddr) -> SocketAddr {
    let any: SocketAddr = if robot.is_ipv4() { ([0, 0, 0, 0], 0).into() } else { ([0u16; 8], 0).into() };
    // Connecting a UDP socket sends nothing; it only picks the route.
    let routed = UdpSocket::bind(any).and_then(|probe| probe.connect(robot).and_then(|()| probe.local_addr()));
    match routed {
        Ok(local) if !local.ip().is_unspecified() => SocketAddr::new(local.ip(), 0),
        _ => any,
    }
}

impl RobotLink {
    /// Opens the link: asks the robot for its DoFs and their names, and
    /// reads its first feedback with a zero command. `timeout` bounds each
    /// wait for an answer.
    pub fn connect(robot: SocketAddr, timeout: Duration) -> Result<RobotLink, RobotError> {
        let local = local_toward(robot);
        let socket = UdpSocket::bind(local).map_err(|e| RobotError::Bind { local, robot, message: e.to_string() })?;
        let mut link = RobotLink {
            socket,
            robot,
            info: RobotInfo { dof_names: Vec::new(), dof_kinds: Vec::new(), period_s: 0.0, lockstep: false },
            timeout,
            seq: 0,
            command: Vec::new(),
            positions: Vec::new(),
            time_us: 0,
            clock_moved: Instant::now(),
            spin: SpinRecv::for_peer(false),
            counters: LinkCounters::default(),
        };
        let (dofs, period_us, lockstep) =
            match link.exchange(&ToRobot::Hello, |m| matches!(m, FromRobot::Info { .. }))? {
                FromRobot::Info { dofs, period_us, lockstep } => (dofs, period_us, lockstep),
                other => return Err(gone(robot, format!("answered hello with {other:?}"))),
            };
        if dofs == 0 {
            return Err(gone(robot, "claims no DoFs: there is nothing to explore or move"));
        }
        if usize::from(dofs) > MAX_DOFS {
            return Err(gone(robot, format!("claims {dofs} DoFs, more than the {MAX_DOFS} the robot link carries")));
        }
        if period_us == 0 {
            return Err(gone(robot, "claims a control period of 0 us"));
        }
        let (mut names, mut kinds) = (Vec::with_capacity(usize::from(dofs)), Vec::with_capacity(usize::from(dofs)));
        for index in 0..dofs {
            let refused = |m: &FromRobot| matches!(m, FromRobot::Refused { .. });
            let name = link.exchange(&ToRobot::DofName { index }, |m| {
                matches!(m, FromRobot::DofName { index: i, .. } if *i == index) || refused(m)
            })?;
            match name {
                FromRobot::DofName { name, .. } => names.push(name.as_str().to_owned()),
                other => return Err(gone(robot, format!("has no name for DoF {index}: {other:?}"))),
            }
            let kind = link.exchange(&ToRobot::DofKind { index }, |m| {
                matches!(m, FromRobot::DofKind { index: i, .. } if *i == index) || refused(m)
            })?;
            // A robot that does not know the request has revolute DoFs only.
            kinds.push(if let FromRobot::DofKind { kind, .. } = kind { kind } else { DofKind::Revolute });
        }
        link.info = RobotInfo { dof_names: names, dof_kinds: kinds, period_s: f64::from(period_us) / 1e6, lockstep };
        link.command = vec![0.0; usize::from(dofs)];
        link.clock_moved = Instant::now();
        link.spin = SpinRecv::for_peer(lockstep);
        link.tick()?;
        Ok(link)
    }

    /// What the robot said about itself.
    pub fn info(&self) -> &RobotInfo {
        &self.info
    }

    /// The robot's clock at the last feedback, s.
    pub fn time_s(&self) -> f64 {
        self.time_us as f64 / 1e6
    }

    /// The link's trouble so far.
    pub fn counters(&self) -> LinkCounters {
        self.counters
    }

    /// Sends the held command as a new one and waits for its feedback; a
    /// robot clock that runs backwards, or stands still for 2 s of
    /// wall-clock time, is an error.
    pub fn tick(&mut self) -> Result<(), RobotError> {
        self.seq = self.seq.wrapping_add(1);
        let seq = self.seq;
        let velocities = self.command.iter().copied().collect();
        let answer = self.exchange(&ToRobot::Command { seq, velocities }, |m| match m {
            FromRobot::State { seq: s, .. } | FromRobot::Refused { seq: s, .. } => *s == seq,
            _ => false,
        })?;
        match answer {
            FromRobot::State { time_us, positions, .. } if positions.len() == self.command.len() => {
                // A broken encoder or driver is refused at once, in every step.
                if let Some(d) = positions.iter().position(|q| !q.is_finite()) {
                    return Err(RobotError::FeedbackNotFinite(d));
                }
                self.clock(time_us)?;
                self.positions.clear();
                self.positions.extend_from_slice(&positions);
                Ok(())
            }
            FromRobot::State { positions, .. } => {
                Err(RobotError::DofCountChanged { answered: positions.len(), dofs: self.command.len() })
            }
            other => Err(gone(self.robot, format!("answered command {seq} with {other:?}"))),
        }
    }

    /// Takes the robot's clock from a feedback.
    fn clock(&mut self, time_us: u64) -> Result<(), RobotError> {
        let now = Instant::now();
        if time_us < self.time_us {
            return Err(RobotError::ClockBackwards { from_s: self.time_s(), to_s: time_us as f64 / 1e6 });
        }
        if time_us > self.time_us {
            self.clock_moved = now;
        } else if now - self.clock_moved > CLOCK_STALL {
            return Err(RobotError::ClockStopped {
                at_s: self.time_s(),
                wall_s: (now - self.clock_moved).as_secs_f64(),
            });
        }
        self.time_us = time_us;
        Ok(())
    }

    /// Sends `request` until an answer `wanted` comes, at most [`TRIES`] times.
    fn exchange(&mut self, request: &ToRobot, wanted: impl Fn(&FromRobot) -> bool) -> Result<FromRobot, RobotError> {
        let mut out = [0u8; robot_link::MAX_DATAGRAM];
        let len = robot_link::encode(request, &mut out).map_err(|e| gone(self.robot, e))?;
        let mut buf = [0u8; robot_link::MAX_DATAGRAM + 1];
        // What the robot itself sent that this host cannot read, if anything.
        let mut unreadable = None;
        for attempt in 0..TRIES {
            if attempt > 0 {
                self.counters.retries += 1;
                tracing::debug!(robot = %self.robot, attempt, "no answer from the robot in time; asking again");
            }
            self.socket.send_to(&out[..len], self.robot).map_err(|e| gone(self.robot, e))?;
            let deadline = Instant::now() + self.timeout;
            while let Some(left) = deadline.checked_duration_since(Instant::now()).filter(|d| !d.is_zero()) {
                self.socket.set_read_timeout(Some(left)).map_err(|e| gone(self.robot, e))?;
                let (n, from) = match self.spin.recv_from(&self.socket, &mut buf) {
                    Ok(got) => got,
                    Err(e) if matches!(e.kind(), std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut) => {
                        break
                    }
                    Err(e) if e.kind() == std::io::ErrorKind::ConnectionRefused => {
                        return Err(gone(self.robot, "nothing listens there (is the robot endpoint running?)"))
                    }
                    Err(e) => return Err(gone(self.robot, e)),
                };
                match robot_link::decode::<FromRobot>(&buf[..n]) {
                    Ok(answer) if from == self.robot && wanted(&answer) => return Ok(answer),
                    Ok(FromRobot::Refused { reason: robot_link::Refusal::Busy, .. }) if from == self.robot => {
                        return Err(RobotError::Busy(self.robot))
                    }
                    Err(e) if from == self.robot => {
                        unreadable = Some(e);
                        self.counters.ignored += 1;
                    }
                    _ => self.counters.ignored += 1,
                }
            }
        }
        Err(gone(
            self.robot,
            match unreadable {
                Some(e) => format!(
                    "answered {request:?} with a datagram this host cannot read ({e}){}",
                    if matches!(request, ToRobot::DofName { .. }) {
                        format!(": a DoF name may be at most {MAX_NAME} bytes of UTF-8")
                    } else {
                        String::new()
                    }
                ),
                None => format!("no answer after {TRIES} tries of {:?} each", self.timeout),
            },
        ))
    }
}

impl Robot for RobotLink {
    fn dof_names(&self) -> Vec<String> {
        self.info.dof_names.clone()
    }

    fn dof_kinds(&self) -> Vec<DofKind> {
        self.info.dof_kinds.clone()
    }

    fn command_velocities(&mut self, omega_rad_s: &[f64]) -> Result<(), RobotError> {
        if omega_rad_s.len() != self.command.len() {
            return Err(RobotError::WrongLength { expected: self.command.len(), got: omega_rad_s.len() });
        }
        if let Some(d) = omega_rad_s.iter().position(|w| !w.is_finite()) {
            return Err(RobotError::NotFinite(d));
        }
        self.command.copy_from_slice(omega_rad_s);
        Ok(())
    }

    fn positions(&self) -> Vec<f64> {
        self.positions.clone()
    }
}

/// The robot link and the skin interface as one rig.
#[derive(Debug)]
pub struct Remote {
    link: RobotLink,
    interface: Interface,
    events: Vec<Event>,
    /// Real-time robots: when the next tick is due on the host's clock.
    next_due: Option<Instant>,
    /// The recording being written, if any.
    recording: Option<Session>,
    /// The watch on ports that stop delivering, when on.
    silence: Option<SilenceWatch>,
}

impl Remote {
    /// Joins an open robot link and a bound interface.
    pub fn new(link: RobotLink, interface: Interface) -> Remote {
        Remote { link, interface, events: Vec::new(), next_due: None, recording: None, silence: None }
    }

    /// Records every tick from now on into `session`.
    pub fn record(&mut self, session: Session) {
        self.recording = Some(session);
    }

    /// The recording being written, to add what the host learned.
    pub fn recording_mut(&mut self) -> Option<&mut Session> {
        self.recording.as_mut()
    }

    /// Stops recording and publishing and closes the file; `None` when no file was recorded.
    pub fn finish_recording(&mut self) -> Option<Result<std::path::PathBuf, RecordError>> {
        self.recording.take().map(Session::finish)?.transpose()
    }

    /// From now on a tick fails with [`RobotError::SkinSilent`] when an
    /// interface port that delivered sends nothing for `bound_s` of robot
    /// time and as long of wall-clock time, or [`WALL_BOUND`] of it for a
    /// lockstep robot, whose clock may run ahead of datagrams on their way
    /// (see [`SilenceWatch`]); `None` stops watching. For the steps where
    /// every cell sends every sample.
    pub fn watch_silence(&mut self, bound_s: Option<f64>) {
        let lockstep = self.link.info.lockstep;
        self.silence =
            bound_s.map(|s| SilenceWatch::new(s, if lockstep { WALL_BOUND } else { Duration::from_secs_f64(s) }));
    }

    /// The robot link.
    pub fn link(&self) -> &RobotLink {
        &self.link
    }

    /// The skin interface.
    pub fn interface(&self) -> &Interface {
        &self.interface
    }

    /// The skin interface, to write configuration.
    pub fn interface_mut(&mut self) -> &mut Interface {
        &mut self.interface
    }

    /// Everything the skin said during the last tick.
    pub fn events(&self) -> &[Event] {
        &self.events
    }

    /// One control period: the command goes out and its feedback comes
    /// back, then every datagram the skin sent is taken. A real-time robot
    /// is first waited for until the period is due, never between its
    /// feedback and the datagrams: the skin's latest samples are then of
    /// the same moment as the feedback, where a wait between let the
    /// robot run a further period in some ticks and not in others.
    pub fn tick(&mut self) -> Result<(), RobotError> {
        if !self.link.info.lockstep {
            let period = Duration::from_secs_f64(self.link.info.period_s);
            let now = Instant::now();
            // A host that fell behind by more than a period starts a new
            // schedule rather than firing the missed commands at once.
            let due = self.next_due.map_or(now, |d| (d + period).max(now));
            if let Some(wait) = due.checked_duration_since(now) {
                std::thread::sleep(wait);
            }
            self.next_due = Some(due);
        }
        self.link.tick()?;
        if let Some(session) = &mut self.recording {
            let link = &self.link;
            let command = ToRobot::Command { seq: link.seq, velocities: link.command.iter().copied().collect() };
            let state = FromRobot::State {
                seq: link.seq,
                time_us: link.time_us,
                positions: link.positions.iter().copied().collect(),
            };
            session.robot(link.robot, &command, &state, &link.info.dof_names);
        }
        self.events.clear();
        while self.take_datagrams(Duration::ZERO)? > 0 {}
        self.judge_silence()?;
        if let Some(session) = &mut self.recording {
            session.events(&self.events, self.link.time_s());
        }
        Ok(())
    }

    /// Takes what one poll of the interface brings within `timeout` into
    /// the tick's events (and the recording): the datagrams taken.
    fn take_datagrams(&mut self, timeout: Duration) -> Result<usize, RobotError> {
        match &mut self.recording {
            Some(session) if session.records_datagrams() => {
                self.interface.poll_tapped(timeout, &mut self.events, &mut |from, now_us, bytes| {
                    session.datagram(from, now_us, bytes)
                })
            }
            _ => self.interface.poll(timeout, &mut self.events),
        }
        .map_err(|e| RobotError::Disconnected(format!("skin interface: {e}")))
    }

    /// Fails when a watched port is silent in robot and wall-clock time
    /// alike. A lockstep robot whose clock ran ahead of the datagrams is
    /// waited for here (it waits for the next command anyway); a real-time
    /// robot is not held: its next ticks judge again.
    fn judge_silence(&mut self) -> Result<(), RobotError> {
        let started = Instant::now();
        while let Some(watch) = &mut self.silence {
            let now = Instant::now();
            let heard =
                watch.check(self.interface.ports(), self.link.time_s(), now).map_err(|s| RobotError::SkinSilent {
                    ports: s.ports,
                    silent_s: s.silent_s,
                    silent_wall_s: s.silent_wall_s,
                    spoofed: self.interface.counters().datagrams.rejected(DatagramReject::Spoofed),
                })?;
            let Heard::Behind(until) = heard else { return Ok(()) };
            if !self.link.info.lockstep {
                return Ok(());
            }
            let until = until.min(started + WALL_BOUND);
            if now >= until {
                // Delivering all along, stamped behind all along: another clock.
                let ports = watch.off_clock(self.interface.ports(), self.link.time_s());
                if !ports.is_empty() {
                    tracing::warn!(
                        ?ports,
                        "interface ports stamp their datagrams on another clock than the lockstep robot's: their samples are taken as they come, however late"
                    );
                }
                return Ok(());
            }
            self.take_datagrams((until - now).min(SILENCE_POLL))?;
        }
        Ok(())
    }
}

impl Robot for Remote {
    fn dof_names(&self) -> Vec<String> {
        self.link.dof_names()
    }

    fn dof_kinds(&self) -> Vec<DofKind> {
        self.link.dof_kinds()
    }

    fn command_velocities(&mut self, omega_rad_s: &[f64]) -> Result<(), RobotError> {
        self.link.command_velocities(omega_rad_s)
    }

    fn positions(&self) -> Vec<f64> {
        self.link.positions()
    }
}

impl SampleSource for Remote {
    fn tick_s(&self) -> f64 {
        self.link.info.period_s
    }

    fn next_tick(&mut self, out: &mut Vec<(Address, Sample)>) -> Result<(), RobotError> {
        self.tick()?;
        out.extend(self.events.iter().filter_map(|e| match e.kind {
            EventKind::Sample(s) => Some((e.cell, s)),
            _ => None,
        }));
        Ok(())
    }

    fn robot_time_s(&self) -> Option<f64> {
        Some(self.link.time_s())
    }

    fn grasp_entered(&mut self, transition: &crate::control::grasp::Transition) {
        if let Some(session) = &mut self.recording {
            session.grasp_entered(transition);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A robot of two DoFs that swallows the first command it gets; its
    /// DoF names are `name_bytes` long.
    fn flaky_robot(socket: UdpSocket, claimed_dofs: u16, name_bytes: usize) {
        let mut buf = [0u8; robot_link::MAX_DATAGRAM];
        let mut out = [0u8; robot_link::MAX_DATAGRAM];
        let mut swallowed = false;
        let mut position = 0.0;
        while let Ok((n, from)) = socket.recv_from(&mut buf) {
            let answer = match robot_link::decode::<ToRobot>(&buf[..n]) {
                Ok(ToRobot::Hello) => FromRobot::Info { dofs: claimed_dofs, period_us: 4000, lockstep: true },
                Ok(ToRobot::DofName { index }) if name_bytes > 1 => {
                    socket.send_to(&long_name(index, name_bytes), from).unwrap();
                    continue;
                }
                Ok(ToRobot::DofName { index }) => FromRobot::DofName { index, name: "j".chars().collect() },
                // A robot of the first link version: it does not know kinds.
                Ok(ToRobot::DofKind { .. }) => FromRobot::Refused { seq: 0, reason: robot_link::Refusal::NoSuchDof },
                Ok(ToRobot::Command { seq, velocities }) => {
                    if !std::mem::replace(&mut swallowed, true) {
                        continue;
                    }
                    position += velocities[0] * 0.004;
                    FromRobot::State {
                        seq,
                        time_us: 4000 * u64::from(seq),
                        positions: [position, 0.0].into_iter().collect(),
                    }
                }
                Err(_) => continue,
            };
            let len = robot_link::encode(&answer, &mut out).unwrap();
            socket.send_to(&out[..len], from).unwrap();
        }
    }

    /// A `DofName` answer whose name has `bytes` bytes, past what the
    /// link allows: the one-byte name "j" with its length and bytes swapped.
    fn long_name(index: u16, bytes: usize) -> Vec<u8> {
        assert!((128..16_384).contains(&bytes), "a length of two varint bytes");
        let mut out = [0u8; robot_link::MAX_DATAGRAM];
        let answer = FromRobot::DofName { index, name: "j".chars().collect() };
        let len = robot_link::encode(&answer, &mut out).unwrap();
        assert_eq!(out[len - 2..len], [1, b'j']);
        let mut datagram = out[..len - 2].to_vec();
        datagram.extend([0x80 | (bytes & 0x7f) as u8, (bytes >> 7) as u8]);
        datagram.resize(datagram.len() + bytes, b'x');
        datagram
    }

    fn spawn_robot(claimed_dofs: u16, name_bytes: usize) -> SocketAddr {
        let socket = UdpSocket::bind("127.0.0.1:0").unwrap();
        socket.set_read_timeout(Some(Duration::from_secs(5))).unwrap();
        let addr = socket.local_addr().unwrap();
        std::thread::spawn(move || flaky_robot(socket, claimed_dofs, name_bytes));
        addr
    }

    #[test]
    fn a_lost_answer_is_asked_for_again_and_commands_are_checked() {
        let mut link = RobotLink::connect(spawn_robot(2, 1), Duration::from_millis(100)).unwrap();
        assert_eq!(link.counters().retries, 1, "the first command was swallowed");
        assert_eq!(
            (link.dof_names(), link.info().period_s, link.info().lockstep),
            (vec!["j".into(), "j".into()], 0.004, true)
        );
        // It refused to tell the kinds: revolute, as the paper's robots.
        assert_eq!(link.dof_kinds(), vec![DofKind::Revolute; 2]);
        link.command_velocities(&[1.0, 0.0]).unwrap();
        link.tick().unwrap();
        assert!((link.positions()[0] - 0.004).abs() < 1e-12 && link.time_s() > 0.0);
        assert_eq!(link.command_velocities(&[1.0]), Err(RobotError::WrongLength { expected: 2, got: 1 }));
        assert_eq!(link.command_velocities(&[0.0, f64::INFINITY]), Err(RobotError::NotFinite(1)));
    }

    #[test]
    fn a_robot_with_feedback_of_the_wrong_length_is_refused() {
        // It claims three DoFs but reports two positions.
        let e = RobotLink::connect(spawn_robot(3, 1), Duration::from_millis(100)).unwrap_err();
        assert_eq!(e, RobotError::DofCountChanged { answered: 2, dofs: 3 });
    }

    #[test]
    fn a_robot_without_dofs_or_with_a_name_too_long_is_explained() {
        let e = RobotLink::connect(spawn_robot(0, 1), Duration::from_millis(100)).unwrap_err();
        assert!(e.to_string().ends_with(": claims no DoFs: there is nothing to explore or move"), "{e}");
        let e = RobotLink::connect(spawn_robot(257, 1), Duration::from_millis(100)).unwrap_err();
        assert!(e.to_string().ends_with(": claims 257 DoFs, more than the 256 the robot link carries"), "{e}");
        let e = RobotLink::connect(spawn_robot(2, 200), Duration::from_millis(20)).unwrap_err();
        assert!(
            e.to_string().ends_with(
                ": answered DofName { index: 0 } with a datagram this host cannot read \
                 (robot-link datagram body is not a valid message): a DoF name may be at most 32 bytes of UTF-8"
            ),
            "{e}"
        );
    }

    #[test]
    fn the_link_binds_the_interface_that_routes_to_the_robot() {
        assert!(local_toward("127.0.0.1:9".parse().unwrap()).ip().is_loopback());
        assert!(local_toward("[::1]:9".parse().unwrap()).ip().is_ipv6());
    }

    #[test]
    fn a_robot_serving_another_host_is_named_at_once() {
        let socket = UdpSocket::bind("127.0.0.1:0").unwrap();
        let robot = socket.local_addr().unwrap();
        std::thread::spawn(move || {
            let mut buf = [0u8; robot_link::MAX_DATAGRAM];
            let (_, from) = socket.recv_from(&mut buf).unwrap();
            let busy = FromRobot::Refused { seq: 0, reason: robot_link::Refusal::Busy };
            let n = robot_link::encode(&busy, &mut buf).unwrap();
            socket.send_to(&buf[..n], from).unwrap();
        });
        let e = RobotLink::connect(robot, Duration::from_secs(5)).unwrap_err();
        assert_eq!(e, RobotError::Busy(robot));
        assert!(e.to_string().contains(&robot.to_string()), "{e}");
    }

    #[test]
    fn nobody_listening_is_explained() {
        let nobody = UdpSocket::bind("127.0.0.1:0").unwrap().local_addr().unwrap();
        let e = RobotLink::connect(nobody, Duration::from_millis(50)).unwrap_err();
        assert!(e.to_string().contains(&nobody.to_string()), "{e}");
    }
}
