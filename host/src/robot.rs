//! The robot and its skin as the host sees them (section 3.2).
//!
//! The control approach needs only three things from a robot: the number of
//! revolute DoFs, velocity commands and position feedback ([`Robot`]); and
//! from the skin only its samples, tick by tick ([`SampleSource`]). Nothing
//! else about the body is known: no model, no cell placement. With the `sim`
//! feature, `SimRobot` puts the simulated world behind both traits, so a
//! simulated and a real robot are driven by the very same code.

#[cfg(feature = "sim")]
mod sim;

use skin_protocol::{Address, Sample};

/// Why the robot or skin did not do what the host asked.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum RobotError {
    /// A command with another number of values than the robot has DoFs.
    #[error("a command of {got} values for a robot with {expected} DoFs")]
    WrongLength {
        /// DoFs of the robot.
        expected: usize,
        /// Values given.
        got: usize,
    },
    /// A NaN or infinite command.
    #[error("the command for DoF {0} is not finite")]
    NotFinite(usize),
    /// The robot obeys another host (a second `skin run` against one
    /// endpoint).
    #[error(
        "the robot at {0} serves another host and refuses this one: stop the other host or restart the robot endpoint"
    )]
    Busy(std::net::SocketAddr),
    /// The host's robot-link socket could not be bound.
    #[error("cannot bind {local} for the link to the robot at {robot}: {message}")]
    Bind {
        /// The local address tried.
        local: std::net::SocketAddr,
        /// The robot.
        robot: std::net::SocketAddr,
        /// What the system said.
        message: String,
    },
    /// Position feedback that is NaN or infinite: a broken encoder or driver.
    #[error(
        "the robot reports a position for DoF {0} that is not finite (NaN or infinite): check its encoder and driver"
    )]
    FeedbackNotFinite(usize),
    /// The robot's clock went back: a restarted robot or a broken clock.
    #[error("the robot's clock ran backwards, from {from_s} s to {to_s} s (was the robot restarted?)")]
    ClockBackwards {
        /// The clock at the feedback before, s.
        from_s: f64,
        /// The clock now, s.
        to_s: f64,
    },
    /// The robot answered but its clock stood still: every wait counted in
    /// robot time would last forever.
    #[error(
        "the robot's clock stood still at {at_s} s for {wall_s:.1} s of wall-clock time while it answered commands (check the robot's clock or simulator)"
    )]
    ClockStopped {
        /// The clock, s.
        at_s: f64,
        /// Wall-clock time it stood still, s.
        wall_s: f64,
    },
    /// The robot answered with positions for another number of DoFs than
    /// it named at the start: its description changed under the run.
    #[error(
        "the robot answered {answered} positions for {dofs} DoFs: its DoF count changed since the start (check its driver and configuration, then start the run again)"
    )]
    DofCountChanged {
        /// Positions in the answer.
        answered: usize,
        /// DoFs the robot named when the link was made.
        dofs: usize,
    },
    /// The robot or skin stopped answering.
    #[error("lost contact: {0}")]
    Disconnected(String),
    /// Interface ports that delivered the skin's samples fell silent while
    /// the robot answered: measurements from then on would be gaps.
    #[error("{}", skin_silent(.ports, *.silent_s, *.silent_wall_s, *.spoofed))]
    SkinSilent {
        /// The silent ports' numbers.
        ports: Vec<u8>,
        /// The longest silence, s of robot time.
        silent_s: f64,
        /// The longest silence, s of wall-clock time.
        silent_wall_s: f64,
        /// Datagrams dropped as spoofed so far (a restarted endpoint sends
        /// from new addresses).
        spoofed: u64,
    },
}

fn skin_silent(ports: &[u8], silent_s: f64, silent_wall_s: f64, spoofed: u64) -> String {
    let list = ports.iter().map(u8::to_string).collect::<Vec<_>>().join(", ");
    let plural = if ports.len() == 1 { "" } else { "s" };
    let spoofed = if spoofed == 0 {
        String::new()
    } else {
        format!("; {spoofed} datagrams from other addresses were dropped as spoofed (a skin endpoint that restarts sends from new ones)")
    };
    format!(
        "the skin stopped sending: interface port{plural} {list} sent nothing for {silent_s:.2} s of robot time ({silent_wall_s:.2} s of wall-clock time) while the robot answered{spoofed} (check the skin's power and cables, then start the run again: its measurements would have gaps)"
    )
}

#[cfg(feature = "sim")]
pub use sim::SimRobot;
pub use skin_protocol::robot_link::DofKind;

/// A robot with DoFs under velocity control.
pub trait Robot {
    /// Names of the DoFs, in the order of commands and feedback.
    fn dof_names(&self) -> Vec<String>;

    /// What kind each DoF is; a robot that does not say has revolute DoFs
    /// only, as the paper's robot interface assumes (section 3.2).
    fn dof_kinds(&self) -> Vec<DofKind> {
        vec![DofKind::Revolute; self.dof_count()]
    }

    /// Each DoF's velocity limit, rad/s (m/s for a prismatic one), where
    /// the robot says: the exploration steps faster within it to see
    /// smaller levers sooner, and keeps its default steps where it is
    /// unknown.
    fn velocity_limits(&self) -> Vec<Option<f64>> {
        vec![None; self.dof_count()]
    }

    /// Number of revolute DoFs.
    fn dof_count(&self) -> usize {
        self.dof_names().len()
    }

    /// Commands a velocity per DoF, rad/s, held until the next command.
    fn command_velocities(&mut self, omega_rad_s: &[f64]) -> Result<(), RobotError>;

    /// Position feedback per DoF, rad.
    fn positions(&self) -> Vec<f64>;
}

/// The skin's sample stream, one control tick at a time.
pub trait SampleSource {
    /// Length of one tick, s.
    fn tick_s(&self) -> f64;

    /// Waits for the next tick (a real skin: the next sampling period; the
    /// simulator: advances its clock) and appends the samples that arrived.
    fn next_tick(&mut self, out: &mut Vec<(Address, Sample)>) -> Result<(), RobotError>;

    /// The robot's clock at the last tick's feedback, s, where the robot
    /// tells it. A real-time robot does not wait for a host that stalls:
    /// its clock shows the ticks that took other than one period, whose
    /// motion between two feedbacks is unknown. `None`: every tick is one
    /// period (a simulator stepped by the host).
    fn robot_time_s(&self) -> Option<f64> {
        None
    }

    /// The grasp controller driving this source entered a state: a source
    /// with live viewers (a [`crate::remote::Remote`] with `--foxglove`)
    /// shows it; the others ignore it.
    fn grasp_entered(&mut self, _transition: &crate::control::grasp::Transition) {}
}
