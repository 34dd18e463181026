//! The simulated robot and its skin served over UDP, exactly as a real
//! robot and skin are reached: the robot on the robot link
//! ([`skin_protocol::robot_link`]), each interface port of the skin
//! network on a socket of its own speaking interface datagrams. A host
//! cannot tell it from the real thing.
//!
//! The [`World`] moves the robot and feels gravity and motion in every
//! cell's accelerometer; its readings are the raw samples of the cells of
//! a [`Network`], which process, route and deliver them as the firmware
//! does. With [`Pacing::Lockstep`] the endpoint advances one control period
//! per new velocity command, world and network together, so simulated time
//! runs as fast as the host can go; with [`Pacing::RealTime`] it advances
//! on the wall clock, answering commands at once and stopping the arms when
//! commands cease, as a real robot does.
//!
//! [`Endpoint::experiment`] serves the grasping experiment's world, where
//! a simulated person ([`Operator`]) teaches, pats and puts objects in
//! front of the robot. The experimenter gives them orders over an
//! in-process side channel of [`Running`] ([`Running::order`],
//! [`Running::notes`]), not over the robot's or the skin's wires: on a real
//! robot a real person stands there. Orders are carried out at the next
//! control period's start and notes sent before that period's feedback, so
//! a lockstep run stays the same for a seed.

mod batch;
mod rig;
mod running;

use std::io::ErrorKind;
use std::net::{SocketAddr, UdpSocket};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use skin_protocol::interface::MAX_DATAGRAM;
use skin_protocol::message::Neighbour;
use skin_protocol::robot_link::{self, FromRobot, Refusal, ToRobot, MAX_DOFS};
use skin_protocol::Address;

use crate::network::{Network, NetworkConfig, NetworkError, Topology};
use crate::scene::experiment::Setup;
use crate::scene::operator::Operator;
use crate::scene::stage::Stage;
use crate::world::{World, WorldConfig};
use skin_model::robot::hrp2;
use skin_model::skin::Skin;
use skin_model::spin_recv::SpinRecv;

pub use batch::Batching;
pub use rig::Rig;
pub use running::Running;

/// How long one wait for a request lasts before the stop flag is looked at.
const STOP_CHECK: Duration = Duration::from_millis(50);

/// How long the host served must be silent before another host may take
/// the robot (a new `skin run` after the last one ended).
const HOST_RELEASE: Duration = Duration::from_secs(2);

/// How simulated time advances.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Pacing {
    /// One control period per new velocity command: as fast as the host goes.
    Lockstep,
    /// On the wall clock: commands are answered at once and held.
    RealTime,
}

/// Where the endpoint listens and whom it talks to.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EndpointConfig {
    /// The robot-link socket (port 0 picks one).
    pub robot: SocketAddr,
    /// The host's interface socket, where every interface port sends.
    pub host: SocketAddr,
    /// How time advances.
    pub pacing: Pacing,
    /// How the interface ports gather frames into datagrams.
    pub batching: Batching,
    /// The skin network's settings (its stimulus is replaced by the world).
    pub network: NetworkConfig,
}

/// What was served.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Served {
    /// Control periods simulated.
    pub ticks: u64,
    /// Robot-link datagrams that were not requests.
    pub rejected: u64,
    /// Robot-link requests from hosts other than the first, refused as
    /// busy: the endpoint obeys one host.
    pub other_hosts: u64,
    /// Commands refused (wrong length, not finite).
    pub refused: u64,
    /// Datagrams sent to the host's interface socket.
    pub datagrams_up: u64,
    /// Datagrams from the host the skin network refused.
    pub datagrams_refused: u64,
    /// Wall time spent in the world: its engine and its sensor models.
    pub world_time: Duration,
    /// Of `world_time`, the engine's: the built-in kinematics, or MuJoCo's
    /// steps and its sensors' readings ([`World::engine_time`]).
    pub engine_time: Duration,
    /// Wall time spent running the cell network up to each period's end.
    pub network_time: Duration,
    /// Wall time spent on the sockets: the host's datagrams taken, the
    /// skin's sent, the robot link's answers.
    pub socket_time: Duration,
    /// Wall time from each answer on the robot link to the next request:
    /// the host's own work on the period, and the link's way there and back.
    pub host_time: Duration,
    /// Wall time from the first request served to the last answer.
    pub serving_time: Duration,
}

/// What only the simulator knows after a run, for checking the host.
#[derive(Clone, Debug, PartialEq)]
pub struct Truth {
    /// What was served.
    pub served: Served,
    /// The ID of each of the world's skin cells ([`Address::UNASSIGNED`]
    /// where it has none), in the world's skin order.
    pub ids: Vec<Address>,
    /// Every cell's true neighbour table on the live wiring, by cell ID.
    pub neighbours: Vec<(Address, [Option<Neighbour>; 4])>,
    /// Latency of every sensor frame from its making to the host's
    /// socket: (microseconds, frames), smallest first.
    pub latency_us: Vec<(u64, u64)>,
    /// Sensor frames lost in the network.
    pub sensor_frames_lost: u64,
}

/// The simulated robot and skin behind their sockets.
pub struct Endpoint {
    rig: Rig,
    robot_socket: UdpSocket,
    ports: Vec<UdpSocket>,
    host: SocketAddr,
    /// The robot-link address of the host served (the first to ask) and
    /// when it last asked.
    robot_host: Option<(SocketAddr, Instant)>,
    /// Datagrams for the host, by interface port, not sent yet.
    up: Vec<(usize, Vec<u8>)>,
}

impl Endpoint {
    /// The paper's robot and skin: the built-in HRP-2-like upper body
    /// (seeded as [`World::hrp2`]) wired as [`Topology::hrp2`], each arm's
    /// two patches on that arm's links from shoulder to gripper and the
    /// chest patch on the chest.
    pub fn hrp2(seed: u64, config: EndpointConfig) -> Result<Endpoint, NetworkError> {
        let world = World::hrp2(seed);
        let world_cell = hrp2_wiring(&world);
        Endpoint::new(world, &Topology::hrp2(), world_cell, config)
    }

    /// The paper's robot and skin, as [`Endpoint::hrp2`], moved by MuJoCo:
    /// `model` (an MJCF of the built-in robot; none: the built-in robot
    /// written as one) wearing the same 74 cells on the same five
    /// interface ports.
    #[cfg(feature = "mujoco")]
    pub fn hrp2_mujoco(
        model: Option<&std::path::Path>,
        seed: u64,
        config: EndpointConfig,
    ) -> Result<Endpoint, NetworkError> {
        let robot = hrp2::robot();
        let skin = Skin::with_counts(&robot, &hrp2::SKIN, seed).map_err(|e| NetworkError::Topology(e.to_string()))?;
        let cfg = crate::world::WorldConfig { seed, ..crate::world::WorldConfig::default() };
        let world = crate::mujoco::Model::built_in(model, seed)?.world(skin, cfg)?;
        let world_cell = hrp2_wiring(&world);
        Endpoint::new(world, &Topology::hrp2(), world_cell, config)
    }

    /// The built-in robot wearing its skin laid in wired patches
    /// ([`Skin::patches`], seeded), wired as laid: each group of cells
    /// wired together on its own interface port, so the neighbour tables
    /// the cells report follow the skin's geometry (for `skin run --urdf
    /// --cell-pitch`).
    pub fn patches(seed: u64, config: EndpointConfig) -> Result<Endpoint, NetworkError> {
        let robot = hrp2::robot();
        let skin = Skin::patches(&robot, |l| hrp2::skin_cells_on(&l.name), seed)
            .map_err(|e| NetworkError::Topology(e.to_string()))?;
        Endpoint::wired(World::new(robot, skin, WorldConfig { seed, ..WorldConfig::default() }), config)
    }

    /// `world` with its skin wired as it was laid ([`Skin::patches`]): each
    /// group of cells wired together on its own interface port. A world of
    /// any engine, the built-in one or MuJoCo.
    pub fn wired(world: World, config: EndpointConfig) -> Result<Endpoint, NetworkError> {
        let topology = Topology::from_wires(world.skin().wires())?;
        let world_cell = (0..world.skin().cells().len()).collect();
        Endpoint::new(world, &topology, world_cell, config)
    }

    /// The grasping experiment (section 6.5): the built-in robot wearing
    /// the experiment's skin ([`Setup`], seeded; 30 cells per arm and 14
    /// on the chest, wired as [`Topology::hrp2`]), feeling a scene where a
    /// person ([`Operator`]) acts on the experimenter's orders.
    pub fn experiment(seed: u64, config: EndpointConfig) -> Result<Endpoint, NetworkError> {
        let robot = hrp2::robot();
        let setup = Setup::new(&robot, seed).map_err(|e| NetworkError::Topology(e.to_string()))?;
        let (world, scene) = setup.world(robot, seed);
        Endpoint::experiment_on(world, setup, Box::new(scene), config)
    }

    /// The grasping experiment in MuJoCo: the built-in robot as `model`
    /// (an MJCF of it; none: the built-in robot written as one) wearing
    /// the experiment's skin, in a lab of MuJoCo bodies
    /// ([`crate::mujoco::SharedStage`]) where the person acts.
    #[cfg(feature = "mujoco")]
    pub fn experiment_mujoco(
        model: Option<&std::path::Path>,
        seed: u64,
        config: EndpointConfig,
    ) -> Result<Endpoint, NetworkError> {
        let setup = Setup::new(&hrp2::robot(), seed).map_err(|e| NetworkError::Topology(e.to_string()))?;
        let (world, stage) = crate::mujoco::experiment_world(model, &setup, seed)?;
        Endpoint::experiment_on(world, setup, Box::new(stage), config)
    }

    /// The grasping experiment in `world` (the built-in robot, moved by any
    /// engine) wearing `setup`'s skin, wired as [`Topology::hrp2`], the
    /// person acting on `stage`.
    pub fn experiment_on(
        world: World,
        setup: Setup,
        stage: Box<dyn Stage>,
        config: EndpointConfig,
    ) -> Result<Endpoint, NetworkError> {
        let world_cell = hrp2_wiring(&world);
        let mut endpoint = Endpoint::new(world, &Topology::hrp2(), world_cell, config)?;
        endpoint.rig.operator = Some(Operator::new(hrp2::robot(), setup, stage));
        Ok(endpoint)
    }

    /// `world` with its skin wired as `topology`; network cell `n` is the
    /// world's skin cell `world_cell[n]`, and every skin cell is one
    /// network cell.
    pub fn new(
        world: World,
        topology: &Topology,
        world_cell: Vec<usize>,
        config: EndpointConfig,
    ) -> Result<Endpoint, NetworkError> {
        for (what, addr) in [("robot link", config.robot), ("host", config.host)] {
            if !addr.ip().is_loopback() {
                return Err(NetworkError::Flag(format!(
                    "{what} address {addr}: the simulated robot only talks to this machine; use 127.0.0.1:PORT"
                )));
            }
        }
        // The skin sends to the host: port 0 would be nowhere.
        if config.host.port() == 0 {
            return Err(NetworkError::Flag(format!(
                "host address {}: port 0 is nowhere to send to; give the port the host listens on",
                config.host
            )));
        }
        // The robot link would answer its own skin's datagrams, and the host
        // could not bind the address the skin sends to.
        if config.host == config.robot {
            return Err(NetworkError::Flag(format!(
                "the host address and the robot-link address are both {}: the skin's datagrams and the robot's \
                 answers need an address each",
                config.host
            )));
        }
        let cells = world.skin().cells().len();
        let mut seen = vec![false; cells];
        let one_to_one = world_cell.len() == cells
            && topology.cells() == cells
            && world_cell.iter().all(|&i| i < cells && !std::mem::replace(&mut seen[i], true));
        if !one_to_one {
            return Err(NetworkError::Topology(format!(
                "the wiring must map the {} network cells one to one onto the {cells} skin cells",
                topology.cells()
            )));
        }
        if world.robot().dofs().len() > MAX_DOFS {
            return Err(NetworkError::TooManyDofs(world.robot().dofs().len()));
        }
        let batching = config.batching.checked().map_err(NetworkError::Flag)?;
        let network = Network::new(topology, config.network)?;
        let local = SocketAddr::new(config.robot.ip(), 0);
        let ports = (0..network.interfaces()).map(|_| bind(local)).collect::<Result<Vec<_>, _>>()?;
        let robot_socket =
            UdpSocket::bind(config.robot).map_err(|source| NetworkError::Bind { addr: config.robot, source })?;
        robot_socket.set_read_timeout(Some(STOP_CHECK))?;
        Ok(Endpoint {
            rig: Rig::new(world, network, world_cell, config.pacing, batching),
            robot_socket,
            ports,
            host: config.host,
            robot_host: None,
            up: Vec::new(),
        })
    }

    /// Breaks a sensor of one skin cell (see [`crate::network::sensor_fault`]).
    pub fn break_sensor(&mut self, fault: crate::network::sensor_fault::SensorFault) -> Result<(), NetworkError> {
        self.rig.network.break_sensor(fault)
    }

    /// The robot-link address.
    pub fn robot_addr(&self) -> Result<SocketAddr, NetworkError> {
        Ok(self.robot_socket.local_addr()?)
    }

    /// The address each interface port sends from, by port number.
    pub fn interface_addrs(&self) -> Result<Vec<SocketAddr>, NetworkError> {
        Ok(self.ports.iter().map(UdpSocket::local_addr).collect::<Result<_, _>>()?)
    }

    /// What only the simulator knows, now.
    pub fn truth(&self) -> Truth {
        self.rig.truth()
    }

    /// Serves the host until `stop` is set.
    pub fn serve(&mut self, stop: &AtomicBool) -> Result<Served, NetworkError> {
        let tick_s = self.rig.world.config().tick_s;
        let start = Instant::now();
        let mut buf = [0u8; robot_link::MAX_DATAGRAM + 1];
        // In lockstep the host's next command follows within microseconds.
        let mut spin = SpinRecv::for_peer(self.rig.pacing == Pacing::Lockstep);
        // When the first request came and when the last answer went.
        let mut first: Option<Instant> = None;
        let mut answered: Option<Instant> = None;
        while !stop.load(Ordering::Relaxed) {
            if self.rig.pacing == Pacing::RealTime {
                let due = start + Duration::from_secs_f64(tick_s * (self.rig.served.ticks + 1) as f64);
                match due.checked_duration_since(Instant::now()) {
                    None => {
                        self.advance()?;
                        continue;
                    }
                    Some(wait) => self.robot_socket.set_read_timeout(Some(wait.clamp(MIN_WAIT, STOP_CHECK)))?,
                }
            }
            let (n, from) = match spin.recv_from(&self.robot_socket, &mut buf) {
                Ok(got) => got,
                Err(e) if matches!(e.kind(), ErrorKind::WouldBlock | ErrorKind::TimedOut) => continue,
                // An ICMP error from an earlier answer to a host that went away.
                Err(e) if e.kind() == ErrorKind::ConnectionRefused => continue,
                Err(e) => return Err(e.into()),
            };
            let Ok(request) = robot_link::decode::<ToRobot>(&buf[..n]) else {
                self.rig.rejected();
                continue;
            };
            let mut out = [0u8; robot_link::MAX_DATAGRAM];
            let now = Instant::now();
            let busy = self.robot_host.is_some_and(|(host, last)| host != from && now - last < HOST_RELEASE);
            if busy {
                // Another host: told so, counted, and nothing of the
                // served host's state touched.
                self.rig.other_host(from);
                let len = robot_link::encode(&FromRobot::Refused { seq: 0, reason: Refusal::Busy }, &mut out)
                    .expect("a refusal fits a robot-link datagram");
                self.robot_socket.send_to(&out[..len], from)?;
                continue;
            }
            self.robot_host = Some((from, now));
            let first = *first.get_or_insert(now);
            if let Some(answered) = answered.take() {
                self.rig.served.host_time += now - answered;
            }
            self.take_from_host()?;
            let taken = Instant::now();
            let answer = self.rig.answer(request, from, taken, &mut self.up)?;
            let advanced = Instant::now();
            self.send_up()?;
            let len = robot_link::encode(&answer, &mut out).expect("answers fit a robot-link datagram");
            self.robot_socket.send_to(&out[..len], from)?;
            let sent = Instant::now();
            self.rig.served.socket_time += (taken - now) + (sent - advanced);
            self.rig.served.serving_time = sent - first;
            answered = Some(sent);
        }
        Ok(self.rig.served)
    }

    /// One control period on the wall clock.
    fn advance(&mut self) -> Result<(), NetworkError> {
        self.take_from_host()?;
        self.rig.advance(Instant::now(), &mut self.up)?;
        self.send_up()
    }

    /// Sends the datagrams for the host, each from its interface port.
    fn send_up(&mut self) -> Result<(), NetworkError> {
        for (port, bytes) in self.up.drain(..) {
            self.ports[port].send_to(&bytes, self.host)?;
        }
        Ok(())
    }

    /// Hands every datagram the host sent to an interface port to the network.
    fn take_from_host(&mut self) -> Result<(), NetworkError> {
        if !any_readable(&self.ports)? {
            return Ok(());
        }
        let mut buf = [0u8; MAX_DATAGRAM + 1];
        for k in 0..self.ports.len() {
            loop {
                match self.ports[k].recv_from(&mut buf) {
                    // Only the host's datagrams (the rig checks the port).
                    Ok((n, from)) if from == self.host => self.rig.from_host(k, &buf[..n]),
                    Ok(_) => self.rig.served.datagrams_refused += 1,
                    Err(e) if e.kind() == ErrorKind::WouldBlock => break,
                    Err(e) if e.kind() == ErrorKind::ConnectionRefused => {}
                    Err(e) => return Err(e.into()),
                }
            }
        }
        Ok(())
    }
}

/// The network cell order of [`Topology::hrp2`]: the right arm's cells,
/// the left arm's, then the chest's, each in the skin's order.
fn hrp2_wiring(world: &World) -> Vec<usize> {
    let cells = world.skin().cells();
    let by_link = |prefix: &'static str| (0..cells.len()).filter(move |&i| cells[i].link.starts_with(prefix));
    ["RARM", "LARM", "CHEST"].into_iter().flat_map(by_link).collect()
}

/// Whether any of `sockets` has a datagram (or an error) waiting: one
/// system call for all the interface ports, which the host seldom writes
/// to, instead of a try on each in every control period.
#[cfg(target_os = "linux")]
#[allow(unsafe_code)]
fn any_readable(sockets: &[UdpSocket]) -> std::io::Result<bool> {
    use std::os::fd::AsRawFd;
    let mut fds: Vec<libc::pollfd> =
        sockets.iter().map(|s| libc::pollfd { fd: s.as_raw_fd(), events: libc::POLLIN, revents: 0 }).collect();
    // SAFETY: `fds` holds `fds.len()` initialized entries, each an open
    // socket's descriptor borrowed for the call; a zero timeout never blocks.
    let ready = unsafe { libc::poll(fds.as_mut_ptr(), fds.len() as libc::nfds_t, 0) };
    if ready < 0 {
        return Err(std::io::Error::last_os_error());
    }
    Ok(ready > 0)
}

/// Elsewhere every port is tried.
#[cfg(not(target_os = "linux"))]
fn any_readable(_: &[UdpSocket]) -> std::io::Result<bool> {
    Ok(true)
}

/// Shortest wait on the robot socket (a zero timeout would block forever).
const MIN_WAIT: Duration = Duration::from_micros(100);

fn bind(addr: SocketAddr) -> Result<UdpSocket, NetworkError> {
    let socket = UdpSocket::bind(addr).map_err(|source| NetworkError::Bind { addr, source })?;
    socket.set_nonblocking(true)?;
    Ok(socket)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::object::Object;
    use crate::scene::operator::{Note, Order};
    use crate::scene::placement::{ObjectAt, Placement};

    /// One period with the robot held still, as a bare host asks for it.
    fn period(link: &UdpSocket, robot: SocketAddr, seq: u32) {
        let request = ToRobot::Command { seq, velocities: [0.0; 14].into_iter().collect() };
        let mut buf = [0u8; robot_link::MAX_DATAGRAM];
        let n = robot_link::encode(&request, &mut buf).unwrap();
        link.send_to(&buf[..n], robot).unwrap();
        let (n, _) = link.recv_from(&mut buf).expect("the endpoint answers");
        assert!(matches!(robot_link::decode(&buf[..n]), Ok(FromRobot::State { .. })));
    }

    /// A lockstep endpoint on loopback sending to `host`.
    fn lockstep(host: &UdpSocket) -> EndpointConfig {
        EndpointConfig {
            robot: "127.0.0.1:0".parse().unwrap(),
            host: host.local_addr().unwrap(),
            pacing: Pacing::Lockstep,
            batching: Batching::default(),
            network: NetworkConfig::default(),
        }
    }

    #[test]
    fn orders_are_carried_out_in_the_next_period_and_answered_before_its_feedback() {
        let host = UdpSocket::bind("127.0.0.1:0").unwrap();
        let config = lockstep(&host);
        let link = UdpSocket::bind("127.0.0.1:0").unwrap();
        link.set_read_timeout(Some(Duration::from_secs(5))).unwrap();

        let running = Running::spawn(move || Endpoint::experiment(5, config)).unwrap();
        let sponge = Object::by_name("sponge_rock").map(|object| ObjectAt { object, placement: Placement::default() });
        running.order(Order::Place(sponge)).unwrap();
        assert_eq!(running.notes().count(), 0, "nothing happens between periods");
        period(&link, running.robot, 1);
        let notes: Vec<Note> = running.notes().collect();
        assert!(matches!(notes[..], [Note::Seen { object: Some(_), .. }]), "{notes:?}");
        // No host has organized the skin: its cells have no IDs to name.
        running.order(Order::Areas).unwrap();
        period(&link, running.robot, 2);
        let notes: Vec<Note> = running.notes().collect();
        assert!(matches!(notes[..], [Note::Refused(_), Note::Seen { .. }]), "{notes:?}");
        running.stop().unwrap();

        let running = Running::spawn(move || Endpoint::hrp2(5, config)).unwrap();
        running.order(Order::Pat).unwrap();
        period(&link, running.robot, 1);
        let notes: Vec<Note> = running.notes().collect();
        assert!(matches!(&notes[..], [Note::Refused(why)] if why.contains("nobody")), "{notes:?}");
        running.stop().unwrap();
    }

    #[test]
    fn a_second_host_is_refused_as_busy_and_the_first_is_served_on() {
        let host = UdpSocket::bind("127.0.0.1:0").unwrap();
        let config = lockstep(&host);
        let (first, second) = (UdpSocket::bind("127.0.0.1:0").unwrap(), UdpSocket::bind("127.0.0.1:0").unwrap());
        for s in [&first, &second] {
            s.set_read_timeout(Some(Duration::from_secs(5))).unwrap();
        }
        let running = Running::spawn(move || Endpoint::hrp2(5, config)).unwrap();
        period(&first, running.robot, 1);
        let mut buf = [0u8; robot_link::MAX_DATAGRAM];
        let n = robot_link::encode(&ToRobot::Command { seq: 9, velocities: [0.0; 14].into_iter().collect() }, &mut buf)
            .unwrap();
        second.send_to(&buf[..n], running.robot).unwrap();
        let (n, _) = second.recv_from(&mut buf).expect("the second host is told");
        assert_eq!(robot_link::decode(&buf[..n]), Ok(FromRobot::Refused { seq: 0, reason: Refusal::Busy }));
        period(&first, running.robot, 2);
        let truth = running.stop().unwrap();
        assert_eq!((truth.served.ticks, truth.served.other_hosts), (2, 1));
    }
}
