//! `--ros2` on `skin run` and `skin demo`: the ROS 2 topics published
//! live over DDS as the default RMWs speak it, or over Zenoh in
//! rmw_zenoh's format (the `ros2` feature), besides or
//! instead of a recording; and `--foxglove` on those and `skin monitor`:
//! the live 3D view in Foxglove (the `foxglove` feature, which `ros2`
//! includes).

use std::net::SocketAddr;

use skin_host::recording::Session;
use skin_host::remote::Remote;
use skin_host::view::Feed;
use skin_protocol::message::AccelRange;

/// The `--foxglove` flag, shared by `run`, `demo` and `monitor`.
#[derive(clap::Args, Debug, Default)]
pub struct FoxgloveArgs {
    /// Serve a live 3D view to Foxglove (open ws://ADDR in Foxglove) on this address [default: 127.0.0.1:8765].
    #[arg(long, value_name = "ADDR", num_args = 0..=1, default_missing_value = "127.0.0.1:8765")]
    foxglove: Option<SocketAddr>,
}

/// The running live view, if any: [`Live::finish`] waits for its last scene.
#[derive(Debug, Default)]
pub struct Live {
    #[cfg(feature = "foxglove")]
    view: Option<skin_host::foxglove::FoxgloveView>,
}

impl Live {
    /// Once the feed is closed (the run's session finished, or the
    /// monitor's feed dropped): waits for the view's last scene, stops its
    /// server and says what it dropped.
    pub fn finish(self) {
        #[cfg(feature = "foxglove")]
        if let Some(view) = self.view {
            let s = view.finish();
            eprintln!(
                "Foxglove view: {} scenes sent; dropped: {} updates (the view fell behind the host), {} log lines",
                s.scenes, s.updates_dropped, s.log_lines_dropped
            );
        }
    }
}

impl FoxgloveArgs {
    /// Starts the view if asked for: the handle and the feed to tell it through.
    pub fn open(&self) -> Result<(Live, Option<Feed>), LiveError> {
        match self.foxglove {
            None => Ok((Live::default(), None)),
            Some(addr) => self.serve(addr),
        }
    }

    #[cfg(feature = "foxglove")]
    fn serve(&self, addr: SocketAddr) -> Result<(Live, Option<Feed>), LiveError> {
        let (view, feed) = skin_host::foxglove::FoxgloveView::start(addr)?;
        eprintln!(
            "Foxglove: live view on ws://{} (in Foxglove: Open connection > Foxglove WebSocket)",
            view.local_addr()
        );
        Ok((Live { view: Some(view) }, Some(feed)))
    }

    #[cfg(not(feature = "foxglove"))]
    fn serve(&self, _addr: SocketAddr) -> Result<(Live, Option<Feed>), LiveError> {
        Err(LiveError::FoxgloveNotBuilt)
    }
}

/// The ROS 2 middleware `--ros2` publishes on.
#[derive(clap::ValueEnum, Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Middleware {
    /// DDS/RTPS, the default RMW's middleware (Fast DDS, Cyclone DDS).
    #[default]
    Dds,
    /// Zenoh, as rmw_zenoh speaks it.
    Zenoh,
}

/// The live-output flags.
#[derive(clap::Args, Debug, Default)]
pub struct LiveArgs {
    /// Publish the ROS 2 topics live (`ros2 topic list` on a ROS 2 machine sees them), over DDS unless `--ros2-middleware zenoh`.
    #[arg(long)]
    ros2: bool,
    /// The middleware of `--ros2`: DDS as the default RMW (rmw_fastrtps_cpp) speaks it, or Zenoh as rmw_zenoh does.
    #[arg(long, value_enum, value_name = "MIDDLEWARE", default_value_t = Middleware::Dds, requires = "ros2")]
    ros2_middleware: Middleware,
    /// With `--ros2-middleware zenoh`: a Zenoh router or peer to connect to, e.g. `tcp/192.168.1.10:7447` (the robot PC's `rmw_zenohd`); repeatable.
    #[arg(long, value_name = "ENDPOINT", requires = "ros2")]
    zenoh_connect: Vec<String>,
    /// With `--ros2-middleware zenoh`: a Zenoh endpoint to listen on [default: tcp/127.0.0.1:0]; repeatable.
    #[arg(long, value_name = "ENDPOINT", requires = "ros2")]
    zenoh_listen: Vec<String>,
    /// The ROS domain ID of `--ros2` and of `--robot ros2` [default: `ROS_DOMAIN_ID`, else 0] (over DDS,
    /// `ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST` or `ROS_LOCALHOST_ONLY=1` keep it on this host).
    #[arg(long, value_name = "ID", value_parser = clap::value_parser!(u32).range(0..=232))]
    ros_domain: Option<u32>,
    /// With `--ros2-middleware zenoh`: speak to Humble (no type hashes: `TypeHashNotSupported`) instead of Jazzy and later (RIHS01).
    #[arg(long, requires = "ros2")]
    ros_humble: bool,
    #[command(flatten)]
    foxglove: FoxgloveArgs,
}

/// Why the live outputs did not start.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum LiveError {
    /// `--ros-domain` where nothing speaks ROS 2.
    #[error("--ros-domain is the domain of --ros2 or of --robot ros2, and neither was given")]
    DomainUnused,
    /// `ROS_DOMAIN_ID` is not a domain ID.
    #[error("ROS_DOMAIN_ID={0:?} is not a ROS domain ID (0 to 232)")]
    DomainEnv(String),
    /// `--ros2` on a binary built without ROS 2.
    #[cfg(not(feature = "ros2"))]
    #[error(
        "this `skin` was built without live ROS 2; build it with `cargo build --release -p skin-host --features ros2`"
    )]
    NotBuilt,
    /// The DDS participant or node did not start.
    #[cfg(feature = "ros2")]
    #[error(transparent)]
    Dds(#[from] skin_host::ros::dds::DdsError),
    /// The ros2_control robot could not be driven.
    #[cfg(feature = "ros2")]
    #[error(transparent)]
    Control(#[from] skin_host::ros::control::ControlError),
    /// The Zenoh session did not start.
    #[cfg(feature = "ros2")]
    #[error(transparent)]
    Zenoh(#[from] skin_host::ros::rmw_zenoh::ZenohError),
    /// `--foxglove` on a binary built without the view.
    #[cfg(not(feature = "foxglove"))]
    #[error("this `skin` was built without the Foxglove view; build it with `cargo build --release -p skin-host --features foxglove` (or `ros2`)")]
    FoxgloveNotBuilt,
    /// The Foxglove view did not start.
    #[cfg(feature = "foxglove")]
    #[error(transparent)]
    Foxglove(#[from] skin_host::foxglove::FoxgloveError),
}

impl LiveArgs {
    /// The ROS domain: `--ros-domain`, else `ROS_DOMAIN_ID`, else 0.
    /// `robot_on_ros`: `--robot ros2` uses it too; a flag nothing uses is refused.
    pub fn ros_domain(&self, robot_on_ros: bool) -> Result<u32, LiveError> {
        match self.ros_domain {
            Some(_) if !self.ros2 && !robot_on_ros => Err(LiveError::DomainUnused),
            Some(id) => Ok(id),
            None => domain_from_env(std::env::var("ROS_DOMAIN_ID").ok().as_deref()),
        }
    }

    /// Whether anything is published live.
    pub fn any(&self) -> bool {
        self.ros2 || self.foxglove.foxglove.is_some()
    }

    /// Starts what was asked for on `remote`'s session (a recording, or
    /// one of its own); accelerations are read in `range`, `imu` adds `/skin/imu`.
    pub fn start(&self, remote: &mut Remote, range: AccelRange, imu: bool) -> Result<Live, LiveError> {
        if !self.any() {
            return Ok(Live::default());
        }
        if remote.recording_mut().is_none() {
            remote.record(Session::live(range, imu));
        }
        let Some(session) = remote.recording_mut() else { return Ok(Live::default()) };
        if self.ros2 {
            self.start_ros2(session)?;
        }
        let (live, feed) = self.foxglove.open()?;
        if let Some(feed) = feed {
            session.add_view(feed);
        }
        Ok(live)
    }

    #[cfg(feature = "ros2")]
    fn start_ros2(&self, session: &mut Session) -> Result<(), LiveError> {
        match self.ros2_middleware {
            Middleware::Dds => self.start_dds(session),
            Middleware::Zenoh => self.start_zenoh(session),
        }
    }

    #[cfg(feature = "ros2")]
    fn start_dds(&self, session: &mut Session) -> Result<(), LiveError> {
        use skin_host::ros::dds::{DdsConfig, DdsError, Node};
        let id = self.ros_domain(true)?;
        let domain = u16::try_from(id).map_err(|_| DdsError::Domain(id))?;
        let config = DdsConfig::new(domain);
        let node = Node::open(&config)?;
        eprintln!(
            "ROS 2 over DDS: node {} in domain {}{}",
            node.name(),
            node.domain(),
            if config.localhost_only { ", on this host only" } else { "" }
        );
        session.add_outlet(Box::new(node));
        Ok(())
    }

    #[cfg(feature = "ros2")]
    fn start_zenoh(&self, session: &mut Session) -> Result<(), LiveError> {
        use skin_host::ros::rmw_zenoh::{Node, TypeHashes, ZenohConfig};
        let domain = self.ros_domain(true)?;
        let node = Node::open(ZenohConfig {
            connect: self.zenoh_connect.clone(),
            listen: self.zenoh_listen.clone(),
            domain,
            hashes: if self.ros_humble { TypeHashes::NotSupported } else { TypeHashes::Rihs01 },
            ..ZenohConfig::default()
        })?;
        eprintln!(
            "ROS 2 over Zenoh: node /skin in domain {}, zenoh peer {} listening on {}",
            domain,
            node.zid(),
            node.locators().join(" ")
        );
        session.add_outlet(Box::new(node));
        Ok(())
    }

    #[cfg(not(feature = "ros2"))]
    fn start_ros2(&self, _session: &mut Session) -> Result<(), LiveError> {
        Err(LiveError::NotBuilt)
    }
}

/// `--robot` of `skin run`: a robot-link address, or `ros2[:CONTROLLER]`,
/// a ros2_control robot over DDS (the `ros2` feature).
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum RobotTarget {
    /// A robot-link server.
    Link(SocketAddr),
    /// A ros2_control robot: what followed `ros2` (empty or `:CONTROLLER`).
    Ros2(String),
}

impl std::str::FromStr for RobotTarget {
    type Err = String;

    fn from_str(s: &str) -> Result<RobotTarget, String> {
        match s.strip_prefix("ros2") {
            Some(rest) if rest.is_empty() || rest.starts_with(':') => Ok(RobotTarget::Ros2(rest.to_owned())),
            _ => s
                .parse()
                .map(RobotTarget::Link)
                .map_err(|e| format!("{e}: --robot is a robot-link address (127.0.0.1:7800) or ros2[:CONTROLLER]")),
        }
    }
}

impl std::fmt::Display for RobotTarget {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            RobotTarget::Link(addr) => write!(f, "{addr}"),
            RobotTarget::Ros2(spec) => write!(f, "ros2{spec}"),
        }
    }
}

/// What keeps a ros2_control robot served: dropping it sends the zero command.
#[derive(Debug)]
pub struct RobotServer {
    #[cfg(feature = "ros2")]
    _robot: Option<skin_host::ros::control::Ros2Robot>,
}

/// What `--robot ros2` is told besides the controller (read by the
/// ros2_control bridge only, which a build without ROS 2 lacks).
#[derive(Debug, Default)]
#[cfg_attr(not(feature = "ros2"), allow(dead_code))]
pub struct Ros2Setup<'a> {
    /// The ROS domain.
    pub domain: u32,
    /// The controller's joints in command order, for a controller whose
    /// parameter service is absent (`--robot-joints`).
    pub joints: Option<Vec<String>>,
    /// The robot's description (`--urdf`), for joint kinds and limits
    /// when `/robot_description` is not published.
    pub description: Option<&'a str>,
}

impl RobotTarget {
    /// Whether the robot is reached over ROS 2.
    pub fn is_ros2(&self) -> bool {
        matches!(self, RobotTarget::Ros2(_))
    }

    /// The robot-link address to connect to: the one given, or that of a
    /// ros2_control bridge started here as `ros` says, with what keeps it
    /// running.
    pub fn serve(&self, ros: Ros2Setup<'_>) -> Result<(SocketAddr, RobotServer), LiveError> {
        match self {
            RobotTarget::Link(addr) => Ok((
                *addr,
                RobotServer {
                    #[cfg(feature = "ros2")]
                    _robot: None,
                },
            )),
            RobotTarget::Ros2(spec) => self.serve_ros2(spec, ros),
        }
    }

    #[cfg(feature = "ros2")]
    fn serve_ros2(&self, spec: &str, ros: Ros2Setup<'_>) -> Result<(SocketAddr, RobotServer), LiveError> {
        use skin_host::ros::control::{ControlConfig, Ros2Robot};
        use skin_host::ros::dds::DdsError;
        let domain = u16::try_from(ros.domain).map_err(|_| DdsError::Domain(ros.domain))?;
        let config = ControlConfig {
            joints: ros.joints,
            description: ros.description.map(str::to_owned),
            ..ControlConfig::parse(spec, domain)?
        };
        let robot = Ros2Robot::start(&config)?;
        eprintln!(
            "ROS 2 robot: controller /{} with joints {} (domain {domain}), /joint_states heard; {}",
            config.controller,
            robot.joints().join(" "),
            robot.summary()
        );
        Ok((robot.addr(), RobotServer { _robot: Some(robot) }))
    }

    #[cfg(not(feature = "ros2"))]
    fn serve_ros2(&self, _spec: &str, _ros: Ros2Setup<'_>) -> Result<(SocketAddr, RobotServer), LiveError> {
        Err(LiveError::NotBuilt)
    }
}

/// `ROS_DOMAIN_ID` as the RMWs read it: unset or blank is 0.
fn domain_from_env(value: Option<&str>) -> Result<u32, LiveError> {
    match value.map(str::trim).filter(|v| !v.is_empty()) {
        None => Ok(0),
        Some(v) => v.parse().ok().filter(|d| *d <= 232).ok_or_else(|| LiveError::DomainEnv(v.to_owned())),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ros_domain_id_is_read_as_the_rmws_read_it() {
        assert_eq!(domain_from_env(None).unwrap(), 0);
        assert_eq!(domain_from_env(Some(" ")).unwrap(), 0);
        assert_eq!(domain_from_env(Some(" 42 ")).unwrap(), 42);
        for bad in ["233", "-1", "x"] {
            assert!(matches!(domain_from_env(Some(bad)), Err(LiveError::DomainEnv(_))), "{bad}");
        }
    }
}
