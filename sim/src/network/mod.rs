//! A discrete-event simulator of skin networks (section 2.2).
//!
//! Every simulated cell runs the firmware's own cell application
//! ([`skin_protocol::app::CellApp`]),
//! every interface port a [`skin_protocol::organize::Sink`], on a virtual
//! clock, over links timed as on the real skin (4 Mbit/s UART, 20-byte
//! frames, round-robin routing; 1 Gbit/s UDP at the interface).
//!
//! - [`topology`]: hexagonal patches, cables, graph files, interface ports.
//! - [`link`]: frame timing and bit errors.
//! - [`scheduler`]: the event queue.
//! - [`stimulus`]: raw sensor samples of a quiet, touched or grasping skin.
//! - [`fault`]: cut links, dead and rebooting cells, dead interface ports.
//! - [`sensor_fault`]: broken sensors of a cell (stuck, saturated, at a rail).
//! - [`ledger`]: where every frame went; latency histograms.
//! - [`simulator`]: the [`Network`] itself: build, step, datagrams out and in.
//! - [`host`]: a minimal host (ID allocation, neighbour table) for runs
//!   without the real one.
//! - [`transport`]: datagrams in memory or over a loopback UDP socket.
//! - [`model`]: the paper's capacity figures from the link model.
//! - [`scenario`]: one whole run (organize, traffic, faults) and its [`NetworkReport`].

pub mod fault;
pub mod host;
pub mod ledger;
pub mod link;
pub mod model;
pub mod scenario;
pub mod scheduler;
pub mod sensor_fault;
pub mod simulator;
pub mod stimulus;
pub mod topology;
pub mod transport;
pub mod update;

pub use scenario::{NetworkReport, Scenario};
pub use simulator::{Firmware, HostDatagram, Network, NetworkConfig, SimCell, Stamper, Trace, UpdateSetup, TRIAL_NS};
pub use topology::Topology;

/// What can go wrong building or running a network simulation.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum NetworkError {
    /// The wiring is not a skin: a port wired twice, a missing cell, no
    /// interface port.
    #[error("topology: {0}")]
    Topology(String),
    /// The MuJoCo world cannot be built.
    #[cfg(feature = "mujoco")]
    #[error(transparent)]
    Mujoco(#[from] crate::mujoco::MujocoError),
    /// A topology file cannot be read or parsed.
    #[error("{path}: {why}")]
    File {
        /// The file.
        path: String,
        /// What is wrong with it.
        why: String,
    },
    /// A topology file cannot be read.
    #[error("cannot read {}: {source}", path.display())]
    Read {
        /// The file.
        path: std::path::PathBuf,
        /// What the OS said.
        #[source]
        source: std::io::Error,
    },
    /// A command-line value is out of range or malformed.
    #[error("{0}")]
    Flag(String),
    /// Bytes from the host are not a datagram.
    #[error("datagram from the host: {0}")]
    Datagram(skin_protocol::interface::DatagramError),
    /// A UDP socket could not be bound to its address.
    #[error("cannot bind {addr}: {source} (is another endpoint running there? choose another port)")]
    Bind {
        /// The address.
        addr: std::net::SocketAddr,
        /// What the OS said.
        #[source]
        source: std::io::Error,
    },
    /// The UDP socket failed.
    #[error("udp: {0}")]
    Udp(#[from] std::io::Error),
    /// A datagram from the host names an interface port the skin lacks.
    #[error("datagram for interface port {0}, which this skin does not have")]
    NoSuchInterface(u8),
    /// The simulated world refused a command.
    #[error("the simulated world: {0}")]
    World(#[from] crate::world::WorldError),
    /// The robot has more DoFs than the robot link carries.
    #[error("the robot has {0} DoFs; the robot link carries at most {max}", max = skin_protocol::robot_link::MAX_DOFS)]
    TooManyDofs(usize),
    /// The simulated robot's thread ended (stopped or failed to start);
    /// what it reported, if anything, came first.
    #[error("the simulated robot has stopped")]
    Stopped,
    /// The simulated robot's thread panicked.
    #[error("the simulated robot's thread panicked")]
    Panicked,
}
