//! A run being recorded and published: the raw channels `skin replay`
//! reads go to the file, the ROS 2 topics to the file and to every live
//! [`Outlet`] (each message encoded once), and what a live viewer draws
//! to its [`Feed`] (never to the file: a viewer's own schemas are no ROS 2
//! types, and ROS 2 readers reject them). A failed write (a full disk)
//! does not stop the robot: the session stops writing, says so once, and
//! [`Session::finish`] returns the error.

use std::net::SocketAddr;
use std::path::{Path, PathBuf};
use std::time::{SystemTime, UNIX_EPOCH};

use serde::{Deserialize, Serialize};
use skin_protocol::message::AccelRange;
use skin_protocol::robot_link::{self, DofKind, FromRobot, ToRobot};

use super::writer::McapWriter;
use super::{RecordError, COMMAND, EXPLORE_START, INTERFACE, STATE};
use crate::config::PortConfig;
use crate::explore::Exploration;
use crate::interface::Event;
use crate::ros::msgs::{Datagram, Imu, JointState, MarkerArray, Message, PointCloud2, Stamp, StringMsg, TfMessage};
use crate::ros::outlet::Outlet;
use crate::ros::skin::{self, SkinTopics};
use crate::view::{Feed, Update};

/// Robot time between two `/skin/cells` clouds (and `/skin/imu` rounds), s: 50 Hz.
const CLOUD_PERIOD_S: f64 = 0.02;

/// What the exploration started with: enough to run it again from the
/// recorded datagrams.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ExploreStart {
    /// DoF names, in command order.
    pub dof_names: Vec<String>,
    /// DoF kinds, in command order.
    pub dof_kinds: Vec<DofKind>,
    /// The robot's control period, s.
    pub period_s: f64,
    /// The accelerometer range the cells were set to, g.
    pub accel_range_g: u8,
    /// The interface ports configured.
    pub ports: Vec<PortConfig>,
    /// Cells left out of the exploration for a broken accelerometer
    /// ([`crate::health`]); recordings from before the screening have none.
    #[serde(default)]
    pub left_out_cells: Vec<u16>,
}

impl ExploreStart {
    /// The accelerometer range, if it is one the cells have.
    pub fn accel_range(&self) -> Option<AccelRange> {
        [AccelRange::G2, AccelRange::G8, AccelRange::G16]
            .into_iter()
            .find(|r| r.full_scale_g() == f32::from(self.accel_range_g))
    }
}

#[cfg(test)]
impl ExploreStart {
    /// A one-DoF robot on the default interface ports, for tests.
    pub(crate) fn one_dof() -> ExploreStart {
        ExploreStart {
            dof_names: vec!["j0".into()],
            dof_kinds: vec![DofKind::Revolute],
            period_s: 0.004,
            accel_range_g: 2,
            ports: crate::config::InterfaceConfig::default().ports,
            left_out_cells: Vec::new(),
        }
    }
}

/// A recording (or live publishing) in progress.
#[derive(Debug)]
pub struct Session {
    /// The file, if the run is recorded.
    writer: Option<McapWriter>,
    /// Live destinations of the ROS 2 topics.
    outlets: Vec<Box<dyn Outlet>>,
    /// The last ROS 2 message's CDR: its allocation serves the next.
    scratch: Vec<u8>,
    topics: SkinTopics,
    imu: bool,
    last_cloud_s: Option<f64>,
    failed: Option<RecordError>,
    /// Interface sources and their text.
    sources: Vec<(SocketAddr, String)>,
    /// A live viewer, and whether it has been told the DoF names.
    view: Option<(Feed, bool)>,
}

fn now_ns() -> u64 {
    SystemTime::now().duration_since(UNIX_EPOCH).map_or(0, |d| d.as_nanos() as u64)
}

impl Session {
    /// Starts a recording at `path`; accelerations are read in `range`;
    /// `imu` adds `/skin/imu`.
    pub fn create(path: &Path, range: AccelRange, imu: bool) -> Result<Session, RecordError> {
        let mut session = Session::live(range, imu);
        session.writer = Some(McapWriter::create(path)?);
        Ok(session)
    }

    /// Publishes the ROS 2 topics to outlets only, with no file.
    pub fn live(range: AccelRange, imu: bool) -> Session {
        Session {
            writer: None,
            outlets: Vec::new(),
            scratch: Vec::new(),
            topics: SkinTopics::new(range),
            imu,
            last_cloud_s: None,
            failed: None,
            sources: Vec::new(),
            view: None,
        }
    }

    /// Tells `feed` (a live viewer) what the run hears and learns from now on.
    pub fn add_view(&mut self, feed: Feed) {
        self.view = Some((feed, false));
    }

    fn tell(&mut self, update: impl FnOnce() -> Update) {
        if let Some((feed, _)) = &mut self.view {
            feed.send(update());
        }
    }

    /// The robot's own description (`--urdf`), for the viewer to draw its links.
    pub fn described(&mut self, model: &skin_model::robot::Robot) {
        self.tell(|| Update::Description(Box::new(model.clone())));
    }

    /// The grasp entered a state: the viewer shows it (no ROS 2 topic carries it).
    pub fn grasp_entered(&mut self, transition: &crate::control::grasp::Transition) {
        self.tell(|| Update::Grasp(*transition));
    }

    /// Publishes the ROS 2 topics to `outlet` too from now on, declaring
    /// each first.
    pub fn add_outlet(&mut self, mut outlet: Box<dyn Outlet>) {
        let imu = self.imu.then_some((skin::IMU, <Imu as Message>::TYPE));
        for (topic, ty) in [
            (skin::CELLS, <PointCloud2 as Message>::TYPE),
            (skin::EVENTS, <MarkerArray as Message>::TYPE),
            (skin::JOINT_STATES, <JointState as Message>::TYPE),
            (skin::TF_STATIC, <TfMessage as Message>::TYPE),
            (skin::ROBOT_DESCRIPTION, <StringMsg as Message>::TYPE),
        ]
        .into_iter()
        .chain(imu)
        {
            outlet.declare(topic, ty);
        }
        self.outlets.push(outlet);
    }

    /// Whether interface datagrams are written (a file is being recorded).
    pub fn records_datagrams(&self) -> bool {
        self.writer.is_some()
    }

    /// A raw channel: to the file only.
    fn put<M: Message>(&mut self, topic: &'static str, time_ns: u64, message: &M) {
        if self.failed.is_some() {
            return;
        }
        if let Some(Err(e)) = self.writer.as_mut().map(|w| w.write(topic, time_ns, message)) {
            tracing::error!("recording stopped: {e}");
            self.failed = Some(e);
        }
    }

    /// A ROS 2 topic: encoded once, to the file and every outlet.
    fn publish<M: Message>(&mut self, topic: &'static str, time_ns: u64, message: &M) {
        if self.writer.is_none() && self.outlets.is_empty() {
            return;
        }
        message.encode_into(&mut self.scratch);
        for outlet in &mut self.outlets {
            outlet.publish(topic, M::TYPE, time_ns, &self.scratch);
        }
        if self.failed.is_some() {
            return;
        }
        if let Some(Err(e)) = self.writer.as_mut().map(|w| w.write_cdr(topic, M::TYPE, time_ns, &self.scratch)) {
            tracing::error!("recording stopped: {e}");
            self.failed = Some(e);
        }
    }

    /// One exchange on the robot link: the command sent, the state that
    /// answered it, and the robot's positions on `/joint_states`.
    pub fn robot(&mut self, robot: SocketAddr, command: &ToRobot, state: &FromRobot, dof_names: &[String]) {
        let t = now_ns();
        let mut buf = [0u8; robot_link::MAX_DATAGRAM];
        let topics = if self.writer.is_some() { [COMMAND, STATE].as_slice() } else { &[] };
        for &topic in topics {
            let bytes = match topic {
                COMMAND => robot_link::encode(command, &mut buf),
                _ => robot_link::encode(state, &mut buf),
            };
            match bytes {
                Ok(n) => {
                    let source = robot.to_string();
                    self.put(topic, t, &Datagram { stamp: Stamp::from_nanos(t), source: &source, data: &buf[..n] });
                }
                Err(e) => tracing::warn!("a robot-link message that does not encode is not recorded: {e}"),
            }
        }
        if let FromRobot::State { positions, .. } = state {
            if let Some((feed, told)) = &mut self.view {
                if !std::mem::replace(told, true) {
                    feed.send(Update::Dofs(dof_names.to_vec()));
                }
                feed.positions(positions);
            }
            self.publish(skin::JOINT_STATES, t, &skin::joint_state(Stamp::from_nanos(t), dof_names, positions));
        }
    }

    /// One interface datagram as received, at `now_us` of the interface's clock.
    pub fn datagram(&mut self, from: SocketAddr, now_us: u64, bytes: &[u8]) {
        if self.writer.is_none() {
            return;
        }
        // The interface's sources are a handful of ports: their text is kept.
        let i = match self.sources.iter().position(|(a, _)| *a == from) {
            Some(i) => i,
            None => {
                self.sources.push((from, from.to_string()));
                self.sources.len() - 1
            }
        };
        let source = std::mem::take(&mut self.sources[i].1);
        self.put(
            INTERFACE,
            now_ns(),
            &Datagram { stamp: Stamp::from_nanos(now_us * 1000), source: &source, data: bytes },
        );
        self.sources[i].1 = source;
    }

    /// What the skin said in one tick at robot time `robot_s`: contacts at
    /// once, the cloud (and IMUs) at 50 Hz of robot time.
    pub fn events(&mut self, events: &[Event], robot_s: f64) {
        if let Some((feed, _)) = &mut self.view {
            feed.events(events);
        }
        let t = now_ns();
        let stamp = Stamp::from_nanos(t);
        self.topics.take(events, stamp);
        if let Some(markers) = self.topics.take_contacts() {
            self.publish(skin::EVENTS, t, &markers);
        }
        // A session for a viewer alone (`--foxglove` only) builds no cloud nobody reads.
        let ros_readers = self.writer.is_some() || !self.outlets.is_empty();
        if !ros_readers || self.last_cloud_s.is_some_and(|last| robot_s - last < CLOUD_PERIOD_S) {
            return;
        }
        self.last_cloud_s = Some(robot_s);
        let cloud = self.topics.cloud(stamp);
        self.publish(skin::CELLS, t, &cloud);
        if self.imu {
            for imu in self.topics.imus(stamp) {
                self.publish(skin::IMU, t, &imu);
            }
        }
    }

    /// The exploration starts: what it needs to be run again.
    pub fn explore_start(&mut self, start: &ExploreStart) {
        match serde_json::to_string(start) {
            Ok(json) => self.put(EXPLORE_START, now_ns(), &StringMsg(json)),
            Err(e) => tracing::error!("the exploration's start is not recorded: {e}"),
        }
    }

    /// The body is explored: the cells' frames and the learned tree.
    pub fn explored(&mut self, exploration: &Exploration) {
        self.tell(|| Update::Tree(Box::new(exploration.tree.clone()), exploration.dof_kinds.clone()));
        let poses = skin::poses_on_parts(exploration);
        let description = skin::robot_description(exploration, &poses);
        self.topics.set_poses(poses);
        let t = now_ns();
        let tf = self.topics.tf_static(Stamp::from_nanos(t));
        self.publish(skin::TF_STATIC, t, &tf);
        self.publish(skin::ROBOT_DESCRIPTION, t, &description);
    }

    /// The skin is calibrated on the robot's description: every cell's
    /// frame on its link, and that description with the skin's frames.
    pub fn calibrated(&mut self, poses: Vec<skin::CellPose>, description: String) {
        self.tell(|| Update::Poses(poses.clone()));
        self.topics.set_poses(poses);
        let t = now_ns();
        let tf = self.topics.tf_static(Stamp::from_nanos(t));
        self.put(skin::TF_STATIC, t, &tf);
        self.put(skin::ROBOT_DESCRIPTION, t, &StringMsg(description));
    }

    /// Messages written to the file so far.
    pub fn written(&self) -> u32 {
        self.writer.as_ref().map_or(0, McapWriter::written)
    }

    /// Closes the file, if any, and the outlets; the first write that
    /// failed, if any, is the error.
    pub fn finish(self) -> Result<Option<PathBuf>, RecordError> {
        match self.failed {
            Some(e) => Err(e),
            None => self.writer.map(McapWriter::finish).transpose(),
        }
    }
}
