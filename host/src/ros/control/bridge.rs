//! The robot-link server in front of a ros2_control robot.

use std::net::{Ipv4Addr, SocketAddr, UdpSocket};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use ros2_client::dds::{Client, Node as RosNode, ServiceMapping, Subscription};
use ros2_client::qos::{Durability, History, Reliability, WhenFull};
use ros2_client::rcl_interfaces::{GetParametersRequest, GetParametersResponse};
use ros2_client::{MessageTypeName, Name, ParameterValue, QosProfile, ServiceTypeName};
use rustdds::no_key::DataWriter;
use rustdds::CDRSerializerAdapter;
use skin_protocol::robot_link::{self, FromRobot, Refusal, ToRobot, MAX_DOFS, MAX_NAME};

use super::joints::{self, Joint, Source};
use super::msgs::{Float64MultiArray, JointState, Text};
use super::{priority, signals, ControlConfig, ControlError, SILENCE};
use crate::ros::dds::node::{context, ros_node};
use crate::ros::dds::DdsError;

/// How long a zero command waits for the controller's acknowledgment.
const ZERO_ACK: Duration = Duration::from_millis(100);
/// A host silent this long has stopped commanding (done, or stuck): the
/// robot is stopped, as a real-time robot on the link stops by itself.
const HOST_SILENCE: Duration = Duration::from_millis(50);
/// Longest a command waits for the `/joint_states` of the robot's next
/// cycle (two periods, at most this): a robot that skips one is answered
/// with what it last said, and its silence is judged by [`SILENCE`].
const NEXT_STATE_MOST: Duration = Duration::from_millis(20);
/// A turn of the serving loop longer than this means the bridge itself was
/// not running (descheduled on a loaded machine): its turns last a
/// millisecond, or two robot periods while a command awaits the next
/// state, at most [`NEXT_STATE_MOST`].
const AWAY: Duration = Duration::from_millis(25);
/// `/joint_states` messages after the first whose stamps measure the
/// robot's control period.
const PERIOD_SAMPLES: usize = 8;
/// Shortest and longest period the robot link carries sensibly.
const PERIOD_RANGE_US: (u32, u32) = (100, 1_000_000);
/// How long `/robot_description` is awaited once the robot is heard (it is
/// transient local, so a publisher's last one comes with its discovery).
const DESCRIPTION_WAIT: Duration = Duration::from_secs(5);
/// How long the controller's parameter service is asked when joints are
/// configured to fall back on (it answers in milliseconds when present).
const PARAMETER_WAIT_CONFIGURED: Duration = Duration::from_secs(2);

type CommandWriter = DataWriter<Float64MultiArray, CDRSerializerAdapter<Float64MultiArray>>;

/// The DDS side: the node, `/joint_states` in, commands out.
struct Ros {
    joints: Vec<String>,
    states: Subscription<JointState>,
    commands: CommandWriter,
    /// Kinds and limits, in the same order.
    limits: Vec<Joint>,
    /// The robot's control period, measured from `/joint_states`.
    period: Duration,
    /// The last positions, in the controller's joint order.
    positions: Vec<f64>,
    /// The stamp of the `/joint_states` they came in, s.
    stamp_s: f64,
    /// `/joint_states` messages taken so far.
    states_taken: u64,
    /// How many had been taken when the host was last answered.
    states_answered: u64,
    /// The stamp of the positions the host was last answered with.
    answered_stamp_s: f64,
    /// Whether stamps advance every cycle (they measured the period): a
    /// state is then the next cycle's only when its stamp is newer, not a
    /// repetition of the last.
    stamps_advance: bool,
    /// When the positions the host was last answered with arrived.
    answered_arrival: Option<Instant>,
    /// The first stamp: the robot's clock on the link counts from it.
    first_stamp_s: Option<f64>,
    /// The robot's clock last told the host, µs (never backwards).
    time_us: u64,
    /// Per new command while commanding: how long after the
    /// `/joint_states` behind it arrived here it was sent, ms (the host's
    /// reaction and the link's round trip, on this host's clock). The
    /// first command after the robot was stopped starts anew, and is not
    /// counted: the host may have computed for seconds meanwhile.
    latencies_ms: Vec<f32>,
    /// How often the host fell silent while commanding, so the robot was
    /// stopped.
    host_stops: usize,
    /// When the last `/joint_states` arrived.
    heard: Instant,
    _node: RosNode,
}

impl Ros {
    /// Sends one velocity per joint, each within its joint's limits.
    fn command_within_limits(&self, velocities: &[f64]) {
        let period_s = self.period.as_secs_f64();
        let clamped = velocities
            .iter()
            .zip(&self.limits)
            .zip(&self.positions)
            .map(|((&v, joint), &q)| joint.clamp(q, v, period_s))
            .collect();
        self.command(clamped);
    }

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
            "ros2_control: {} commands; from a /joint_states message's arrival to the command it caused: median {:.2} ms, p99 {:.2} ms, max {:.2} ms; the robot stopped {} times for a host silent over {:?}",
            l.len(),
            at(0.5),
            at(0.99),
            at(1.0),
            self.host_stops,
            HOST_SILENCE
        );
    }

    /// Takes every `/joint_states` that arrived; the positions of the last
    /// one that reports every joint.
    fn take_states(&mut self) {
        self.take_states_stamped(None);
    }

    /// [`Ros::take_states`], the stamp of each one taken added to `stamps`
    /// (a loaded machine delivers them in bursts now and then).
    fn take_states_stamped(&mut self, mut stamps: Option<&mut Vec<f64>>) {
        loop {
            match self.states.take() {
                Ok(Some((state, _))) => {
                    if let Ok(p) = state.positions_of(&self.joints) {
                        self.positions = p;
                        self.stamp_s = state.header.stamp_s();
                        self.heard = Instant::now();
                        self.states_taken += 1;
                        if let Some(stamps) = stamps.as_deref_mut() {
                            stamps.push(self.stamp_s);
                        }
                    }
                }
                Ok(None) => return,
                Err(e) => tracing::debug!("ros2_control: a /joint_states message was unreadable: {e:?}"),
            }
        }
    }

    /// Takes `/joint_states` until one newer than those the host was last
    /// answered with arrives (by stamp where stamps advance, else by
    /// arrival), or [`NEXT_STATE_MOST`] (two periods at most) passes.
    fn await_next_state(&mut self) {
        let until = Instant::now() + (2 * self.period).min(NEXT_STATE_MOST);
        loop {
            self.take_states();
            let next = if self.stamps_advance {
                self.stamp_s > self.answered_stamp_s
            } else {
                self.states_taken > self.states_answered
            };
            if next || Instant::now() >= until {
                return;
            }
            std::thread::sleep(Duration::from_micros(100));
        }
    }
}

/// What the bridge learned of the robot before serving it.
#[derive(Debug)]
struct Told {
    joints: Vec<String>,
    period: Duration,
    period_from: &'static str,
    limits_from: Source,
    /// The bridge's scheduling, in words.
    priority: String,
}

/// A ros2_control robot served on the robot link at [`Ros2Robot::addr`],
/// in real time. Dropping it stops the robot.
pub struct Ros2Robot {
    addr: SocketAddr,
    told: Told,
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
}

impl std::fmt::Debug for Ros2Robot {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Ros2Robot").field("addr", &self.addr).field("told", &self.told).finish()
    }
}

impl Ros2Robot {
    /// Joins the ROS graph, learns the controller's joints, checks them
    /// against `/joint_states`, and serves the robot link. Nothing is
    /// commanded before this returns.
    pub fn start(config: &ControlConfig) -> Result<Ros2Robot, ControlError> {
        // The DDS threads the context spawns, and the bridge's, inherit
        // this thread's priority; the host's thread goes back to normal
        // at the end, however this ends.
        let realtime = priority::raise();
        let started = Self::start_raised(config, realtime.as_ref().err());
        if realtime.is_ok() {
            if let Err(e) = priority::lower() {
                tracing::warn!("ros2_control: the host's thread stays at real-time priority: {e}");
            }
        }
        started
    }

    /// [`Ros2Robot::start`] at the priority raised, or not for `refused`.
    fn start_raised(config: &ControlConfig, refused: Option<&std::io::Error>) -> Result<Ros2Robot, ControlError> {
        let (context, mut node) = signals::blocked_while(|| -> Result<_, ControlError> {
            let context = context(config.domain, config.localhost_only)?;
            let node = ros_node(&context, "skin_control")?;
            Ok((context, node))
        })?;
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
        // Subscribed now, so the robot's last description arrives while
        // the parameters and the first states are awaited.
        let latched = QosProfile::publisher_default()
            .reliability(Reliability::Reliable { when_full: WhenFull::Wait(Duration::from_millis(10)) })
            .durability(Durability::TransientLocal)
            .history(History::KeepLast { depth: 1 });
        let topic = node
            .create_topic(&name("/robot_description")?, MessageTypeName::new("std_msgs", "String"), &latched)
            .map_err(|e| DdsError::create("/robot_description", e))?;
        let description = node
            .create_subscription::<Text>(&topic, Some(latched))
            .map_err(|e| DdsError::create("/robot_description", e))?;
        let joints = controller_joints(&mut node, config)?;
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
            limits: vec![Joint::UNLIMITED; joints.len()],
            period: Duration::ZERO,
            states,
            commands,
            positions: Vec::new(),
            stamp_s: 0.0,
            states_taken: 0,
            states_answered: 0,
            answered_stamp_s: f64::NEG_INFINITY,
            stamps_advance: false,
            answered_arrival: None,
            first_stamp_s: None,
            time_us: 0,
            latencies_ms: Vec::new(),
            host_stops: 0,
            heard: Instant::now(),
            _node: node,
        };
        first_state(&mut ros, config)?;
        let measured = measure_period(&mut ros);
        ros.period = measured.period;
        ros.stamps_advance = measured.by_stamps;
        let (limits, source) = kinds_and_limits(&description, &joints, config)?;
        ros.limits = limits;
        let priority = match refused {
            None => format!("SCHED_FIFO {}", priority::PRIORITY),
            Some(e) => format!("normal priority (SCHED_FIFO {} refused: {e})", priority::PRIORITY),
        };
        let told = Told {
            joints: joints.clone(),
            period: ros.period,
            period_from: measured.from,
            limits_from: source,
            priority,
        };
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
        Ok(Ros2Robot { addr, told, stop, thread: Some(thread) })
    }

    /// Where the robot link answers (`RobotLink::connect` here).
    pub fn addr(&self) -> SocketAddr {
        self.addr
    }

    /// The controller's joints, in command order.
    pub fn joints(&self) -> &[String] {
        &self.told.joints
    }

    /// What the bridge found out about the robot, in a sentence.
    pub fn summary(&self) -> String {
        let t = &self.told;
        format!(
            "control period {:.2} ms (measured from {}), joint kinds and limits {}, the bridge at {}",
            t.period.as_secs_f64() * 1e3,
            t.period_from,
            t.limits_from,
            t.priority
        )
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

/// The controller's joints in command order: its `joints` parameter, or
/// the configured ones when its parameter service does not answer; both
/// present, they must agree.
fn controller_joints(node: &mut RosNode, config: &ControlConfig) -> Result<Vec<String>, ControlError> {
    let Some(configured) = &config.joints else { return joints_parameter(node, config, config.timeout) };
    match joints_parameter(node, config, PARAMETER_WAIT_CONFIGURED.min(config.timeout)) {
        Err(ControlError::NoParameters { .. }) => Ok(configured.clone()),
        Ok(parameter) if parameter != *configured => Err(ControlError::JointsDisagree {
            controller: config.controller.clone(),
            parameter,
            configured: configured.clone(),
        }),
        other => other,
    }
}

/// The controller's `joints` parameter, asked until it answers or `wait`
/// passes (the request is resent: a request sent before the service is
/// discovered is lost).
fn joints_parameter(node: &mut RosNode, config: &ControlConfig, wait: Duration) -> Result<Vec<String>, ControlError> {
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
    while start.elapsed() < wait {
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
    Err(ControlError::NoParameters { controller: config.controller.clone(), waited: wait })
}

/// The robot's control period and what measured it.
struct Measured {
    period: Duration,
    from: &'static str,
    by_stamps: bool,
}

/// The robot's control period: the median step between the stamps of the
/// next [`PERIOD_SAMPLES`] `/joint_states`, each message's own (not only
/// the last of a burst delivered at once), or between their arrivals when
/// the stamps do not advance (a broadcaster that leaves them zero).
fn measure_period(ros: &mut Ros) -> Measured {
    let mut stamps = vec![ros.stamp_s];
    let mut arrivals = vec![ros.heard];
    let start = Instant::now();
    while stamps.len() <= PERIOD_SAMPLES && start.elapsed() < SILENCE * 10 {
        let taken = ros.states_taken;
        ros.take_states_stamped(Some(&mut stamps));
        if ros.states_taken > taken {
            arrivals.push(ros.heard);
        } else {
            std::thread::sleep(Duration::from_micros(200));
        }
    }
    let median = |mut steps: Vec<f64>| -> Option<f64> {
        steps.sort_by(f64::total_cmp);
        steps.get(steps.len() / 2).copied().filter(|s| s.is_finite() && *s > 0.0)
    };
    let by_stamps = median(stamps.windows(2).map(|w| w[1] - w[0]).collect());
    let by_arrivals = median(arrivals.windows(2).map(|w| (w[1] - w[0]).as_secs_f64()).collect());
    let (seconds, from) = match (by_stamps, by_arrivals) {
        (Some(s), _) => (s, "/joint_states stamps"),
        (None, Some(s)) => (s, "/joint_states arrivals (their stamps do not advance)"),
        (None, None) => (f64::from(PERIOD_RANGE_US.1) / 1e6, "nothing: /joint_states came too rarely"),
    };
    let us = ((seconds * 1e6).round() as u32).clamp(PERIOD_RANGE_US.0, PERIOD_RANGE_US.1);
    Measured { period: Duration::from_micros(u64::from(us)), from, by_stamps: by_stamps.is_some() }
}

/// The joints' kinds and limits: from `/robot_description` when the robot
/// publishes one within [`DESCRIPTION_WAIT`], else from the configured
/// description, else revolute and unlimited.
fn kinds_and_limits(
    topic: &Subscription<Text>,
    joints: &[String],
    config: &ControlConfig,
) -> Result<(Vec<Joint>, Source), ControlError> {
    let start = Instant::now();
    let mut latest = None;
    while latest.is_none() && start.elapsed() < DESCRIPTION_WAIT {
        match topic.take() {
            Ok(Some((text, _))) => latest = Some(text.data),
            Ok(None) => std::thread::sleep(Duration::from_millis(5)),
            Err(e) => tracing::debug!("ros2_control: a /robot_description message was unreadable: {e:?}"),
        }
    }
    let (text, source) = match (&latest, &config.description) {
        (Some(text), _) => (text, Source::Topic),
        (None, Some(text)) => (text, Source::Configuration),
        (None, None) => return Ok((vec![Joint::UNLIMITED; joints.len()], Source::Assumed)),
    };
    Ok((joints::from_urdf(text, joints, source)?, source))
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
                        ros.stamp_s = state.header.stamp_s();
                        ros.heard = Instant::now();
                        ros.states_taken += 1;
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
    // Silences are judged over the time the bridge was there to hear:
    // while it was descheduled, the robot's states and the host's commands
    // waited in its sockets, and its absence is no evidence that either
    // fell silent (the robot held its command meanwhile, which no judgment
    // made afterwards could change). How long it was away since the last
    // state, and since the last command:
    let (mut away_since_state, mut away_since_command) = (Duration::ZERO, Duration::ZERO);
    let mut last_turn = Instant::now();
    loop {
        let turn = Instant::now();
        let away = turn - last_turn;
        last_turn = turn;
        if away > AWAY {
            away_since_state += away;
            away_since_command += away;
        }
        let taken = ros.states_taken;
        ros.take_states();
        if ros.states_taken != taken {
            away_since_state = Duration::ZERO;
        }
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
        if commanding && commanded.elapsed().saturating_sub(away_since_command) > HOST_SILENCE {
            ros.zero();
            ros.host_stops += 1;
            commanding = false;
        }
        if commanding && ros.heard.elapsed().saturating_sub(away_since_state) > SILENCE {
            ros.zero();
            let away = if away_since_state.is_zero() {
                String::new()
            } else {
                format!(" ({away_since_state:?} of it with this process descheduled, not counted)")
            };
            eprintln!(
                "error: /joint_states fell silent for {:?}{away} while the robot moved: stopped commanding it (a zero command sent) and ended",
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
                    away_since_command = Duration::ZERO;
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

/// A period in the robot link's microseconds.
fn period_us(period: Duration) -> u32 {
    u32::try_from(period.as_micros()).unwrap_or(u32::MAX)
}

/// The answer to one robot-link request.
fn answer(ros: &mut Ros, request: ToRobot, last_seq: &mut Option<u32>, commanding: &mut bool) -> FromRobot {
    let dofs = ros.joints.len();
    match request {
        // Real time: the host keeps its own schedule. Announcing lockstep
        // instead (the robot pacing the host) made the exploration find
        // coupled DoFs after 5 s in every run tried.
        ToRobot::Hello => FromRobot::Info { dofs: dofs as u16, period_us: period_us(ros.period), lockstep: false },
        ToRobot::DofName { index } => match ros.joints.get(usize::from(index)).and_then(|j| j.as_str().try_into().ok())
        {
            Some(name) => FromRobot::DofName { index, name },
            None => FromRobot::Refused { seq: 0, reason: Refusal::NoSuchDof },
        },
        ToRobot::DofKind { index } => match ros.limits.get(usize::from(index)) {
            Some(joint) => FromRobot::DofKind { index, kind: joint.kind },
            None => FromRobot::Refused { seq: 0, reason: Refusal::NoSuchDof },
        },
        ToRobot::Command { seq, velocities } => {
            if let Some(reason) = Refusal::of_command(&velocities, dofs) {
                ros.zero();
                *commanding = false;
                return FromRobot::Refused { seq, reason };
            }
            if *last_seq != Some(seq) {
                ros.command_within_limits(&velocities);
                if let Some(arrived) = ros.answered_arrival.filter(|_| *commanding) {
                    ros.latencies_ms.push(arrived.elapsed().as_secs_f32() * 1e3);
                }
                *last_seq = Some(seq);
                *commanding = true;
                // Answered with the cycle after the command, as a robot
                // on the link answers with the period it commanded.
                ros.await_next_state();
            }
            ros.states_answered = ros.states_taken;
            ros.answered_stamp_s = ros.stamp_s;
            ros.answered_arrival = Some(ros.heard);
            // The robot's time is that of its /joint_states, so a robot
            // (or simulator) that runs slow is seen slow, as on the link.
            let first = *ros.first_stamp_s.get_or_insert(ros.stamp_s);
            ros.time_us = ros.time_us.max(((ros.stamp_s - first).max(0.0) * 1e6).round() as u64);
            FromRobot::State { seq, time_us: ros.time_us, positions: ros.positions.iter().copied().collect() }
        }
    }
}
