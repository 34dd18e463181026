//! The live 3D view in Foxglove (`--foxglove`): the Foxglove SDK's
//! WebSocket server (protocol `foxglove.websocket.v1`, no remote access)
//! serving the robot, the cells coloured by what they feel, contacts and
//! tactile events, and the grasp state, in Foxglove's own schemas.
//!
//! Why a thread of its own: the receive thread only hands [`Update`]s to a
//! bounded [`Feed`] (dropping and counting when it is full); this thread
//! drains them into the [`scene::Scene`] and, [`PUBLISH_PERIOD`] apart,
//! builds and encodes the messages of the channels some client subscribed
//! to. The SDK sends each client's messages from its own tokio tasks
//! through a queue of [`CLIENT_BACKLOG`] messages that drops the oldest
//! when a client falls behind, so no client can block this thread either.
//!
//! These channels never go into the ROS 2 recording: ROS 2 readers reject
//! Foxglove's schemas.
//!
//! | topic | schema | what |
//! |---|---|---|
//! | `/skin/scene` | `foxglove.SceneUpdate` | cells (cubes; metadata `ids`, `force`, `proximity`) and contacts (spheres) |
//! | `/skin/robot` | `foxglove.SceneUpdate` | the robot's bones and frames |
//! | `/tf` | `foxglove.FrameTransforms` | every link (or learned body part) in `world` |
//! | `/skin/log` | `foxglove.Log` | tactile events and grasp states as they happen |
//! | `/skin/grasp` | JSON (`skin.GraspState`) | every grasp state entered |

pub mod layout;
pub mod scene;

use std::net::SocketAddr;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::mpsc::{Receiver, RecvTimeoutError};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use foxglove::messages::{FrameTransforms, Log, SceneUpdate};
use foxglove::{Channel, Context, RawChannel, Schema, WebSocketServerHandle};

use self::scene::Scene;
use crate::view::{self, Feed, Update, FEED_CAPACITY};

/// Time between two scenes sent (20 Hz of wall-clock time, whatever the robot's clock does).
pub const PUBLISH_PERIOD: Duration = Duration::from_millis(50);
/// Messages queued per client before the oldest are dropped: five seconds of every channel.
pub const CLIENT_BACKLOG: usize = 500;
/// The default address of `--foxglove`: Foxglove's usual port, on loopback.
pub const DEFAULT_ADDR: &str = "127.0.0.1:8765";

/// The JSON schema of `/skin/grasp`.
const GRASP_SCHEMA: &str = r#"{"type":"object","properties":{"state":{"type":"string"},"from":{"type":"string"},"cause":{"type":"string"},"time_s":{"type":"number"}}}"#;

/// Why the view did not start.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum FoxgloveError {
    /// The server could not listen (the port taken, the address not this machine's).
    #[error("the Foxglove view cannot listen on {addr}: {source} (pick another with --foxglove HOST:PORT)")]
    Listen {
        /// The address asked for.
        addr: SocketAddr,
        /// What the SDK said.
        #[source]
        source: foxglove::FoxgloveError,
    },
    /// A channel could not be made.
    #[error("the Foxglove view cannot open channel {topic}: {source}")]
    Channel {
        /// The topic.
        topic: &'static str,
        /// What the SDK said.
        #[source]
        source: foxglove::FoxgloveError,
    },
    /// The publishing thread could not be started.
    #[error("the Foxglove view's thread did not start: {0}")]
    Thread(#[source] std::io::Error),
}

/// What the view did, for the run's last words.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ViewStats {
    /// Scenes built and sent to at least one client.
    pub scenes: u64,
    /// Updates the receive thread dropped because the view was behind.
    pub updates_dropped: u64,
    /// Log lines dropped because too many came between two scenes.
    pub log_lines_dropped: u64,
}

/// The view's channels on its own SDK context (kept alive with them).
struct Channels {
    _ctx: Arc<Context>,
    scene: Channel<SceneUpdate>,
    robot: Channel<SceneUpdate>,
    tf: Channel<FrameTransforms>,
    log: Channel<Log>,
    grasp: Arc<RawChannel>,
}

impl Channels {
    fn new(ctx: &Arc<Context>) -> Result<Channels, FoxgloveError> {
        let grasp = ctx
            .channel_builder("/skin/grasp")
            .message_encoding("json")
            .schema(Schema::new("skin.GraspState", "jsonschema", GRASP_SCHEMA.as_bytes()))
            .build_raw()
            .map_err(|source| FoxgloveError::Channel { topic: "/skin/grasp", source })?;
        Ok(Channels {
            _ctx: ctx.clone(),
            scene: ctx.channel_builder("/skin/scene").build(),
            robot: ctx.channel_builder("/skin/robot").build(),
            tf: ctx.channel_builder("/tf").build(),
            log: ctx.channel_builder("/skin/log").build(),
            grasp,
        })
    }

    /// Sends what changed since the last call; builds only what a client subscribed to.
    fn publish(&self, scene: &mut Scene) -> bool {
        for line in scene.take_logs() {
            self.log.log(&line);
        }
        for state in scene.take_grasp() {
            match serde_json::to_vec(&state) {
                Ok(json) => self.grasp.log(&json),
                Err(e) => tracing::warn!("a grasp state did not encode: {e}"),
            }
        }
        let wanted = [self.scene.has_sinks(), self.robot.has_sinks(), self.tf.has_sinks()];
        if !wanted.contains(&true) {
            return false;
        }
        let skeleton = scene.skeleton();
        if wanted[0] {
            self.scene.log(&scene.cells(&skeleton));
        }
        if wanted[1] {
            self.robot.log(&Scene::robot(&skeleton));
        }
        if wanted[2] {
            self.tf.log(&Scene::transforms(&skeleton));
        }
        true
    }
}

/// The running view: the server and its publishing thread.
#[derive(Debug)]
pub struct FoxgloveView {
    server: WebSocketServerHandle,
    addr: SocketAddr,
    thread: JoinHandle<ViewStats>,
    dropped: Arc<AtomicU64>,
}

impl FoxgloveView {
    /// Listens on `addr` (port 0: one the OS picks) and starts publishing
    /// what the returned [`Feed`] is told; the view stops when the feed is dropped.
    pub fn start(addr: SocketAddr) -> Result<(FoxgloveView, Feed), FoxgloveError> {
        let ctx = Context::new();
        let channels = Channels::new(&ctx)?;
        let server = ctx
            .websocket_server()
            .name("skin")
            .bind(addr.ip().to_string(), addr.port())
            .message_backlog_size(CLIENT_BACKLOG)
            .start_blocking()
            .map_err(|source| FoxgloveError::Listen { addr, source })?;
        let addr = SocketAddr::new(addr.ip(), server.port());
        let (feed, rx, dropped) = view::feed(FEED_CAPACITY);
        let counter = dropped.clone();
        let thread = std::thread::Builder::new()
            .name("foxglove view".into())
            .spawn(move || run(&rx, &channels, &counter))
            .map_err(FoxgloveError::Thread)?;
        Ok((FoxgloveView { server, addr, thread, dropped }, feed))
    }

    /// Where clients connect (`ws://` this).
    pub fn local_addr(&self) -> SocketAddr {
        self.addr
    }

    /// Updates dropped so far.
    pub fn dropped(&self) -> u64 {
        self.dropped.load(Ordering::Relaxed)
    }

    /// Waits for the feed to close (the run's session finished) and the
    /// last scene to go out, then stops the server.
    pub fn finish(self) -> ViewStats {
        let stats = self.thread.join().unwrap_or_else(|_| {
            tracing::error!("the Foxglove view's thread panicked");
            ViewStats::default()
        });
        drop(self.server.stop());
        stats
    }
}

/// The publishing loop: drains the feed, publishes every period, ends when the feed is gone.
fn run(rx: &Receiver<Update>, channels: &Channels, dropped: &AtomicU64) -> ViewStats {
    let mut scene = Scene::new();
    let mut stats = ViewStats::default();
    let mut next = Instant::now() + PUBLISH_PERIOD;
    loop {
        let wait = next.saturating_duration_since(Instant::now());
        let open = match rx.recv_timeout(wait) {
            Ok(update) => {
                scene.take(update);
                true
            }
            Err(RecvTimeoutError::Timeout) => true,
            Err(RecvTimeoutError::Disconnected) => false,
        };
        if !open || Instant::now() >= next {
            stats.scenes += u64::from(channels.publish(&mut scene));
            next = Instant::now() + PUBLISH_PERIOD;
        }
        if !open {
            break;
        }
    }
    stats.updates_dropped = dropped.load(Ordering::Relaxed);
    stats.log_lines_dropped = scene.logs_dropped();
    stats
}
