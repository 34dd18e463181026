//! `--ros2` on `skin run` and `skin demo`: the ROS 2 topics published
//! live over Zenoh in rmw_zenoh's format (the `ros2` feature), besides or
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

/// The live-output flags.
#[derive(clap::Args, Debug, Default)]
pub struct LiveArgs {
    /// Publish the ROS 2 topics live over Zenoh as rmw_zenoh does (`ros2 topic list` on a ROS 2 machine sees them).
    #[arg(long)]
    ros2: bool,
    /// A Zenoh router or peer to connect to, e.g. `tcp/192.168.1.10:7447` (the robot PC's `rmw_zenohd`); repeatable.
    #[arg(long, value_name = "ENDPOINT", requires = "ros2")]
    zenoh_connect: Vec<String>,
    /// A Zenoh endpoint to listen on [default: tcp/127.0.0.1:0]; repeatable.
    #[arg(long, value_name = "ENDPOINT", requires = "ros2")]
    zenoh_listen: Vec<String>,
    /// The ROS domain ID.
    #[arg(long, value_name = "ID", default_value_t = 0, requires = "ros2", value_parser = clap::value_parser!(u32).range(0..=232))]
    ros_domain: u32,
    /// Speak to Humble (no type hashes: `TypeHashNotSupported`) instead of Jazzy and later (RIHS01).
    #[arg(long, requires = "ros2")]
    ros_humble: bool,
    #[command(flatten)]
    foxglove: FoxgloveArgs,
}

/// Why the live outputs did not start.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum LiveError {
    /// `--ros2` on a binary built without Zenoh.
    #[cfg(not(feature = "ros2"))]
    #[error("this `skin` was built without ROS 2 over Zenoh; build it with `cargo build --release -p skin-host --features ros2`")]
    NotBuilt,
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
        use skin_host::ros::rmw_zenoh::{Node, TypeHashes, ZenohConfig};
        let node = Node::open(ZenohConfig {
            connect: self.zenoh_connect.clone(),
            listen: self.zenoh_listen.clone(),
            domain: self.ros_domain,
            hashes: if self.ros_humble { TypeHashes::NotSupported } else { TypeHashes::Rihs01 },
            ..ZenohConfig::default()
        })?;
        eprintln!(
            "ROS 2 over Zenoh: node /skin in domain {}, zenoh peer {} listening on {}",
            self.ros_domain,
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
