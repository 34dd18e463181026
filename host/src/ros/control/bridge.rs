//! The robot-link server in front of a ros2_control robot.

use std::net::{Ipv4Addr, SocketAddr, UdpSocket};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use ros2_client::dds::{Client, Node as RosNode, ServiceMapping, Subscription};
use ros2_client::qos::{Durability, History, Reliability, WhenFull};
use ros2_client::rcl_interfaces::{GetParametersRequest, GetParametersResponse};
use ros2_client::{MessageTypeName, Name, ParameterValue, QosProfile, ServiceTypeName};
use rustdds::no_key::DataWriter;
use rustdds::CDRSerializerAdapter;
use skin_protocol::robot_link::{self, DofKind, FromRobot, Refusal, ToRobot, MAX_DOFS, MAX_NAME};

use super::msgs::{Float64MultiArray, JointState};
use super::{signals, ControlConfig, ControlError, PERIOD_US, SILENCE};
use crate::ros::dds::node::{context, ros_node};
use crate::ros::dds::DdsError;

/// How long a zero command waits for the controller's acknowledgment.
const ZERO_ACK: Duration = Duration::from_millis(100);
/// A host silent this long has stopped commanding (done, or stuck): the
/// robot is stopped, as a real-time robot on the link stops by itself.
const HOST_SILENCE: Duration = Duration::from_millis(50);

type CommandWriter = DataWriter<Float64MultiArray, CDRSerializerAdapter<Float64MultiArray>>;

/// The DDS side: the node, `/joint_states` in, commands out.
struct Ros {
    joints: Vec<String>,
    states: Subscription<JointState>,
    commands: CommandWriter,
    /// The last positions, in the controller's joint order.
    positions: Vec<f64>,
    /// The stamp of the `/joint_states` they came in, s since the epoch.
    stamp_s: f64,
    /// The stamp of the positions the host was last answered with.
    answered_s: Option<f64>,
    /// The first stamp: the robot's clock on the link counts from it.
    first_stamp_s: Option<f64>,
    /// The robot's clock last told the host, µs (never backwards).
    time_us: u64,
    /// Per new command: how old the `/joint_states` behind it was, ms
    /// (from its stamp to the command's sending, on this host's clock).
    latencies_ms: Vec<f32>,
    heard: Instant,
    _node: RosNode,
}

impl Ros {
    /// Sends one velocity per joint.
    fn command(&self, velocities: Vec<f64>) {
        if let Err(e) = self.commands.write(Float64MultiArray::flat(velocities), None) {
            tracing::warn!("ros2_control: a command was not sent: {e:?}");
        }
    }

    /// Sends the zero command and waits for the controller to acknowledge it.
    fn zero(&self) {
        self.command(vec![0.0; self.joints.len()]);
        if !matches!(self.commands.wait_for_acknowledgments(ZERO_ACK), Ok(true)) {
            tracing::warn!("ros2_control: the zero command was not acknowledged within {ZERO_ACK:?}");
        }
    }

    /// Says how old the `/joint_states` behind the commands were.
    fn report(&mut self) {
        let l = &mut self.latencies_ms;
        if l.is_empty() {
            return;
        }
        l.sort_by(f32::total_cmp);
        let at = |q: f64| l[((l.len() - 1) as f64 * q).round() as usize];
        eprintln!(
            "ros2_control: {} commands; from a /joint_states stamp to the command it caused: median {:.2} ms, p99 {:.2} ms, max {:.2} ms",
            l.len(),
            at(0.5),
            at(0.99),
            at(1.0)
        );
    }

    /// Takes every `/joint_states` that arrived; the positions of the last
    /// one that reports every joint.
    fn take_states(&mut self) {
        loop {
            match self.states.take() {
                Ok(Some((state, _))) => {
                    if let Ok(p) = state.positions_of(&self.joints) {
                        self.positions = p;
                        self.stamp_s = f64::from(state.header.stamp.sec) + f64::from(state.header.stamp.nanosec) * 1e-9;
                        self.heard = Instant::now();
                    }
                }
                Ok(None) => return,
                Err(e) => tracing::debug!("ros2_control: a /joint_states message was unreadable: {e:?}"),
            }
        }
    }
}

/// A ros2_control robot served on the robot link at [`Ros2Robot::addr`],
/// in real time. Dropping it stops the robot.
pub struct Ros2Robot {
    addr: SocketAddr,
    joints: Vec<String>,
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
}

impl std::fmt::Debug for Ros2Robot {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Ros2Robot").field("addr", &self.addr).field("joints", &self.joints).finish()
    }
}

impl Ros2Robot {
    /// Joins the ROS graph, learns the controller's joints, checks them
    /// against `/joint_states`, and serves the robot link. Nothing is
    /// commanded before this returns.
    pub fn start(config: &ControlConfig) -> Result<Ros2Robot, ControlError> {
        let context = context(config.domain, config.localhost_only)?;
        let mut node = ros_node(&context, "skin_control")?;
        let reliable = QosProfile::publisher_default()
            .reliability(Reliability::Reliable { when_full: WhenFull::Wait(Duration::from_millis(10)) })
            .durability(Durability::Volatile)
            .history(History::KeepLast { depth: 10 });
        let name = |topic: &str| Name::parse(topic).map_err(|e| DdsError::create(topic, format!("{e:?}")));
        let states_topic = name("/joint_states")?;
        let topic = node
            .create_topic(&states_topic, MessageTypeName::new("sensor_msgs", "JointState"), &reliable)
            .map_err(|e| DdsError::create("/joint_states", e))?;
        let states =
            node.create_subscription::<JointState>(&topic, None).map_err(|e| DdsError::create("/joint_states", e))?;
        let joints = match &config.joints {
            Some(j) => j.clone(),
            None => joints_parameter(&mut node, config)?,
        };
        if joints.is_empty() || joints.len() > MAX_DOFS || joints.iter().any(|j| j.len() > MAX_NAME) {
            return Err(ControlError::TooMany {
                controller: config.controller.clone(),
                joints: joints.len(),
                max_joints: MAX_DOFS,
                max_name: MAX_NAME,
            });
        }
        let commands_name = format!("/{}/commands", config.controller);
        let topic = node
            .create_topic(&name(&commands_name)?, MessageTypeName::new("std_msgs", "Float64MultiArray"), &reliable)
            .map_err(|e| DdsError::create(&commands_name, e))?;
        let commands = context
            .domain_participant()
            .create_publisher(&(&reliable).into())
            .and_then(|p| p.create_datawriter_no_key::<Float64MultiArray, CDRSerializerAdapter<_>>(&topic, None))
            .map_err(|e| DdsError::create(&commands_name, e))?;
        let mut ros = Ros {
            joints: joints.clone(),
            states,
            commands,
            positions: Vec::new(),
            stamp_s: 0.0,
            answered_s: None,
            first_stamp_s: None,
            time_us: 0,
            latencies_ms: Vec::new(),
            heard: Instant::now(),
            _node: node,
        };
        first_state(&mut ros, config)?;
        let socket = UdpSocket::bind((Ipv4Addr::LOCALHOST, 0))?;
        socket.set_read_timeout(Some(Duration::from_millis(1)))?;
        let addr = socket.local_addr()?;
        signals::install()?;
        let stop = Arc::new(AtomicBool::new(false));
        let thread = {
            let stop = stop.clone();
            std::thread::Builder::new().name("ros2_control".to_owned()).spawn(move || {
                let _context = context;
                if let Err(e) = signals::unblock() {
                    tracing::warn!("ros2_control: SIGINT and SIGTERM stay blocked: {e}");
                }
                serve(&mut ros, &socket, &stop);
            })?
        };
        Ok(Ros2Robot { addr, joints, stop, thread: Some(thread) })
    }

    /// Where the robot link answers (`RobotLink::connect` here).
    pub fn addr(&self) -> SocketAddr {
        self.addr
    }

    /// The controller's joints, in command order.
    pub fn joints(&self) -> &[String] {
        &self.joints
    }
}

impl Drop for Ros2Robot {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::SeqCst);
        if let Some(thread) = self.thread.take() {
            let _ = thread.join();
        }
    }
}

/// The controller's `joints` parameter, asked until it answers or the
/// configuration's timeout passes (the request is resent: a request sent
/// before the service is discovered is lost).
fn joints_parameter(node: &mut RosNode, config: &ControlConfig) -> Result<Vec<String>, ControlError> {
    let service = format!("/{}/get_parameters", config.controller);
    let qos = QosProfile::publisher_default().history(History::KeepLast { depth: 10 });
    let name = Name::new(&format!("/{}", config.controller), "get_parameters")
        .map_err(|e| DdsError::create(&service, format!("{e:?}")))?;
    let client: Client<GetParametersRequest, GetParametersResponse> = node
        .create_client(
            ServiceMapping::Enhanced,
            &name,
            &ServiceTypeName::new("rcl_interfaces", "GetParameters"),
            qos.clone(),
            qos,
        )
        .map_err(|e| DdsError::create(&service, e))?;
    let start = Instant::now();
    let mut asked = None::<Instant>;
    while start.elapsed() < config.timeout {
        if asked.is_none_or(|t| t.elapsed() > Duration::from_millis(250)) {
            let _ = client.send_request(GetParametersRequest { names: vec!["joints".to_owned()] });
            asked = Some(Instant::now());
        }
        match client.receive_response() {
            Ok(Some((_, response))) => {
                let values: Vec<ParameterValue> = response.values.into_iter().map(ParameterValue::from).collect();
                return match &values[..] {
                    [ParameterValue::StringArray(joints)] if !joints.is_empty() => Ok(joints.clone()),
                    other => Err(ControlError::BadJoints {
                        controller: config.controller.clone(),
                        got: format!("{other:?}"),
                    }),
                };
            }
            Ok(None) => std::thread::sleep(Duration::from_millis(5)),
            Err(e) => tracing::debug!("{service}: an unreadable answer: {e:?}"),
        }
    }
    Err(ControlError::NoParameters { controller: config.controller.clone(), waited: config.timeout })
}

/// Waits for the first `/joint_states` and checks that it reports every
/// joint the controller commands.
fn first_state(ros: &mut Ros, config: &ControlConfig) -> Result<(), ControlError> {
    let start = Instant::now();
    while start.elapsed() < config.timeout {
        match ros.states.take() {
            Ok(Some((state, _))) => {
                return match state.positions_of(&ros.joints) {
                    Ok(p) => {
                        ros.positions = p;
                        ros.heard = Instant::now();
                        Ok(())
                    }
                    Err(joint) => Err(ControlError::WrongJoints {
                        controller: config.controller.clone(),
                        joint: joint.to_owned(),
                        reported: state.name,
                    }),
                };
            }
            Ok(None) => std::thread::sleep(Duration::from_millis(2)),
            Err(e) => tracing::debug!("ros2_control: a /joint_states message was unreadable: {e:?}"),
        }
    }
    Err(ControlError::NoJointStates(config.timeout))
}

/// Answers the robot link until stopped; ends the process on a signal or
/// a silent `/joint_states`, after the zero command.
fn serve(ros: &mut Ros, socket: &UdpSocket, stop: &AtomicBool) {
    let mut buf = [0u8; robot_link::MAX_DATAGRAM + 1];
    let mut out = [0u8; robot_link::MAX_DATAGRAM];
    let mut last_seq = None;
    let mut commanding = false;
    let mut host = None;
    let mut commanded = Instant::now();
    loop {
        ros.take_states();
        if stop.load(Ordering::SeqCst) {
            ros.zero();
            ros.report();
            return;
        }
        if let Some(signal) = signals::received() {
            ros.zero();
            eprintln!("skin: stopped by signal {signal}; the robot was sent a zero command");
            std::process::exit(128 + signal);
        }
        if commanding && commanded.elapsed() > HOST_SILENCE {
            ros.zero();
            commanding = false;
        }
        if commanding && ros.heard.elapsed() > SILENCE {
            ros.zero();
            eprintln!(
                "error: /joint_states fell silent for {:?} while the robot moved: stopped commanding it (a zero command sent) and ended",
                ros.heard.elapsed()
            );
            std::process::exit(1);
        }
        let (n, from) = match socket.recv_from(&mut buf) {
            Ok(got) => got,
            Err(e)
                if matches!(
                    e.kind(),
                    std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut | std::io::ErrorKind::Interrupted
                ) =>
            {
                continue
            }
            Err(e) => {
                tracing::warn!("ros2_control: the robot link failed: {e}");
                continue;
            }
        };
        // The first host that speaks is the only one obeyed.
        let host = *host.get_or_insert(from);
        let answer = match robot_link::decode::<ToRobot>(&buf[..n]) {
            Ok(_) if from != host => FromRobot::Refused { seq: 0, reason: Refusal::Busy },
            Ok(request) => {
                if matches!(request, ToRobot::Command { .. }) {
                    commanded = Instant::now();
                }
                answer(ros, request, &mut last_seq, &mut commanding)
            }
            Err(e) => {
                tracing::debug!("ros2_control: an unreadable robot-link datagram from {from}: {e:?}");
                continue;
            }
        };
        if let Ok(len) = robot_link::encode(&answer, &mut out) {
            let _ = socket.send_to(&out[..len], from);
        }
    }
}

/// The answer to one robot-link request.
fn answer(ros: &mut Ros, request: ToRobot, last_seq: &mut Option<u32>, commanding: &mut bool) -> FromRobot {
    let dofs = ros.joints.len();
    match request {
        ToRobot::Hello => FromRobot::Info { dofs: dofs as u16, period_us: PERIOD_US, lockstep: false },
        ToRobot::DofName { index } => match ros.joints.get(usize::from(index)).and_then(|j| j.as_str().try_into().ok())
        {
            Some(name) => FromRobot::DofName { index, name },
            None => FromRobot::Refused { seq: 0, reason: Refusal::NoSuchDof },
        },
        // Joint kinds are not read from /robot_description yet: revolute, as the paper's robots.
        ToRobot::DofKind { index } if usize::from(index) < dofs => {
            FromRobot::DofKind { index, kind: DofKind::Revolute }
        }
        ToRobot::DofKind { .. } => FromRobot::Refused { seq: 0, reason: Refusal::NoSuchDof },
        ToRobot::Command { seq, velocities } => {
            if let Some(reason) = Refusal::of_command(&velocities, dofs) {
                ros.zero();
                return FromRobot::Refused { seq, reason };
            }
            if *last_seq != Some(seq) {
                ros.command(velocities.to_vec());
                if let (Some(stamp), Ok(now)) = (ros.answered_s, SystemTime::now().duration_since(UNIX_EPOCH)) {
                    ros.latencies_ms.push(((now.as_secs_f64() - stamp) * 1e3) as f32);
                }
                *last_seq = Some(seq);
                *commanding = true;
            }
            ros.answered_s = Some(ros.stamp_s);
            // The robot's time is that of its /joint_states, so a robot
            // (or simulator) that runs slow is seen slow, as on the link.
            let first = *ros.first_stamp_s.get_or_insert(ros.stamp_s);
            ros.time_us = ros.time_us.max(((ros.stamp_s - first).max(0.0) * 1e6) as u64);
            FromRobot::State { seq, time_us: ros.time_us, positions: ros.positions.iter().copied().collect() }
        }
    }
}
