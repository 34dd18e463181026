//! `skin run`: the main job against a real skin and a real robot (or an
//! external simulator such as `skin sim-endpoint`): wait for the skin to
//! organize, write the configured cell settings, explore the body and
//! write the report folder.
//!
//! The robot is reached on the robot link (`skin_protocol::robot_link`):
//! it must publish its number of revolute DoFs, accept velocity commands
//! and give position feedback (section 3.2). The skin's interface ports
//! send their datagrams to `--interface`.

use std::cell::RefCell;
use std::io::Write;
use std::net::SocketAddr;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::{Duration, Instant};

use skin_host::calibrate::export::{picture, ros_poses, skin_toml, urdf_with_skin};
use skin_host::calibrate::neighbours::{resolve, NeighbourConfig};
use skin_host::calibrate::{calibrate, CalibrateConfig};
use skin_host::config::{Config, Traffic};
use skin_host::explore::{ExploreConfig, StructureConfig};
use skin_host::health::Screened;
use skin_host::interface::Interface;
use skin_host::pipeline::OrganizeConfig;
use skin_host::remote::{Remote, RobotLink};
use skin_host::report::{check_folder, CalibrationSection};
use skin_model::robot::Robot;
use skin_protocol::message::AccelRange;

use super::job::{self, Steps};
use super::live::{LiveArgs, RobotTarget, Ros2Setup};
use super::progress::Progress;
use super::seconds;
use super::structure_args::StructureArgs;

/// Arguments of `skin run`.
#[derive(clap::Args)]
pub struct Args {
    /// Address to listen on for the skin's interface ports [default: the configuration's `interface.listen`].
    #[arg(long, value_name = "ADDR")]
    interface: Option<SocketAddr>,
    /// The robot: its robot-link address, or `ros2[:CONTROLLER]` for a ros2_control robot over DDS
    /// (velocities to CONTROLLER, default forward_velocity_controller; positions from /joint_states).
    #[arg(long, value_name = "ADDR|ros2[:CONTROLLER]")]
    robot: RobotTarget,
    /// With `--robot ros2`: the controller's joints in command order, for a controller whose `joints`
    /// parameter cannot be read (no parameter service); checked against /joint_states and, where the
    /// parameter answers, against it.
    #[arg(long, value_name = "JOINT,...", value_delimiter = ',')]
    robot_joints: Vec<String>,
    /// Configuration file (interface ports, cell settings) [default: the built-in defaults, see `skin config --default`].
    #[arg(long, value_name = "FILE")]
    config: Option<PathBuf>,
    /// Cells the skin has: wait until that many have organized [default: whatever reports and stays unchanged].
    #[arg(long, value_name = "N", value_parser = clap::builder::RangedU64ValueParser::<usize>::new().range(1..=super::MAX_CELLS))]
    cells: Option<usize>,
    /// Longest time the skin may take to organize, s, in robot time and in wall-clock time (whichever ends first).
    #[arg(long, value_name = "S", default_value_t = 30.0)]
    organize_timeout: f64,
    /// Longest wait for one answer of the robot, milliseconds.
    #[arg(long, value_name = "MS", default_value_t = 1000, value_parser = clap::value_parser!(u64).range(1..=60_000))]
    robot_timeout_ms: u64,
    /// The report folder (created if missing).
    #[arg(long, value_name = "DIR", default_value = "report")]
    out: PathBuf,
    /// Print report.json on stdout instead of the human summary.
    #[arg(long)]
    json: bool,
    /// The robot's description: after the exploration, calibrate every cell's pose on it and write
    /// skin.toml and robot_with_skin.urdf (one frame per cell) into the report folder.
    #[arg(long, value_name = "FILE")]
    urdf: Option<PathBuf>,
    /// With `--urdf`: the skin is laid in patches whose wired neighbours sit this far apart, m (centre to
    /// centre); their neighbour tables then place what the motion leaves blind (a cell's position along
    /// its link's only joint axis). Without it the tables say nothing about distance and are not used.
    /// The default mounting clearance of the exploration is 1/25 of it (of 0.025 m without it).
    #[arg(long, value_name = "M")]
    cell_pitch: Option<f64>,
    #[command(flatten)]
    structure: StructureArgs,
    /// Record the run into this MCAP file: interface datagrams, robot link, ROS 2 topics (`skin replay` reads it).
    #[arg(long, value_name = "FILE.mcap")]
    record: Option<PathBuf>,
    /// Also record (and with `--ros2` publish) every cell's acceleration as `sensor_msgs/Imu` on `/skin/imu`.
    #[arg(long)]
    imu: bool,
    #[command(flatten)]
    live: LiveArgs,
}

/// Why `skin run` could not start.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// The interface and the robot link given one address.
    #[error("the interface and the robot are both at {0}: the skin's datagrams and the robot's answers need an address each")]
    SameAddress(std::net::SocketAddr),
    /// A cell pitch no skin has.
    #[error("--cell-pitch must lie in [0.005, 0.2] m, not {0}")]
    CellPitch(f64),
}

pub fn run(args: Args) -> Result<ExitCode, Box<dyn std::error::Error>> {
    let wall = Instant::now();
    let organize_timeout_s = seconds::positive("--organize-timeout", args.organize_timeout)?;
    let pitch_m = match args.cell_pitch {
        Some(p) if !(0.005..=0.2).contains(&p) => return Err(Error::CellPitch(p).into()),
        p => p,
    };
    // The default mounting clearance follows from the skin's pitch.
    let structure = args.structure.apply(StructureConfig {
        cell_pitch_m: pitch_m.unwrap_or(StructureConfig::default().cell_pitch_m),
        ..StructureConfig::default()
    })?;
    // A description that cannot be used is refused before the robot moves.
    let description = match &args.urdf {
        Some(path) => {
            let text = skin_model::file::read_text_capped(path, skin_model::robot::limits::MAX_BYTES)
                .map_err(|e| format!("cannot read {}: {e}", path.display()))?;
            let model = Robot::from_urdf_str(&text).map_err(|e| format!("{}: {e}", path.display()))?;
            Some((text, model))
        }
        None => None,
    };
    let ros_domain = args.live.ros_domain(args.robot.is_ros2())?;
    let robot_joints = robot_joints(&args.robot, &args.robot_joints)?;
    let mut config = match &args.config {
        Some(path) => Config::load(path)?,
        None => Config::default(),
    };
    if let Some(listen) = args.interface {
        config.interface.listen = listen;
    }
    if args.robot == RobotTarget::Link(config.interface.listen) {
        return Err(Error::SameAddress(config.interface.listen).into());
    }
    // Only once every input is accepted: a refused one leaves no folder behind.
    check_folder(&args.out)?;
    let interface = Interface::bind(&config.interface)?;
    // A ros2_control robot is served on a loopback robot link; dropping
    // `_robot` (also on an error or a panic) sends it the zero command.
    let ros = Ros2Setup {
        domain: ros_domain,
        joints: robot_joints,
        description: description.as_ref().map(|(text, _)| text.as_str()),
    };
    let (robot, _robot) = args.robot.serve(ros)?;
    let link = RobotLink::connect(robot, Duration::from_millis(args.robot_timeout_ms))?;
    let source = format!(
        "The robot at {} ({} DoFs, {}) and the skin heard on {}.",
        args.robot,
        link.info().dof_names.len(),
        if link.info().lockstep { "lockstep" } else { "real time" },
        interface.local_addr()
    );
    let mut remote = Remote::new(link, interface);
    // The exploration averages every sample: event-driven cells would fall
    // silent while they rest.
    let mut cells = config.cells.clone();
    if cells.traffic == Traffic::Event {
        tracing::info!(
            "cells send every sample while the robot explores itself (the configuration asks for event-driven traffic)"
        );
        cells.traffic = Traffic::Clock;
    }
    // The range the accelerometers are set to is the one their counts are read in.
    let range = match cells.accel_range_g {
        8 => AccelRange::G8,
        16 => AccelRange::G16,
        _ => AccelRange::G2,
    };
    let steps = Steps {
        organize: OrganizeConfig {
            expected_cells: args.cells,
            timeout_s: organize_timeout_s,
            ..OrganizeConfig::default()
        },
        settings: cells.settings(),
        explore: ExploreConfig { range, structure, ..ExploreConfig::default() },
        ports: config.interface.ports.clone(),
    };
    if let Some(path) = &args.record {
        job::record(&mut remote, path, &steps, args.imu)?;
    }
    let live = args.live.start(&mut remote, range, args.imu)?;
    if let (Some((_, model)), Some(session)) = (&description, remote.recording_mut()) {
        session.described(model);
    }
    let found = job::run(&mut remote, &steps).map_err(Box::<dyn std::error::Error>::from).and_then(|found| {
        let calibration = match &description {
            Some((text, model)) => Some(calibrate_skin(&mut remote, text, model, &found, range, pitch_m, &args.out)?),
            None => None,
        };
        Ok((found, calibration))
    });
    let recorded = job::finish_recording(&mut remote);
    live.finish();
    let recorded = recorded?;
    let (found, calibration) = found?;
    let mut report = job::report(&remote, source, found);
    report.calibration = calibration;
    report.timing.total_wall_s = wall.elapsed().as_secs_f64();
    let written = report.write(&args.out)?;
    let mut text = if args.json { serde_json::to_string_pretty(&report)? } else { job::summary(&report, &written) };
    if let Some(line) = recorded.filter(|_| !args.json) {
        text = format!("{text}\n{line}");
    }
    match writeln!(std::io::stdout().lock(), "{text}") {
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => {}
        other => other?,
    }
    Ok(ExitCode::SUCCESS)
}

/// `--robot-joints`, refused where no ros2_control robot takes it, or
/// with a blank or repeated name.
fn robot_joints(robot: &RobotTarget, joints: &[String]) -> Result<Option<Vec<String>>, String> {
    if joints.is_empty() {
        return Ok(None);
    }
    if !robot.is_ros2() {
        return Err("--robot-joints names a ros2_control controller's joints: it needs --robot ros2".to_owned());
    }
    for (i, joint) in joints.iter().enumerate() {
        if joint.trim().is_empty() || joints[..i].contains(joint) {
            return Err(format!("--robot-joints: {joint:?} is blank or named twice"));
        }
    }
    Ok(Some(joints.to_vec()))
}

/// Calibrates the skin on the robot's description `text` (parsed into
/// `model`), with the neighbour tables where the skin's `pitch_m` is
/// declared, writes skin.toml and robot_with_skin.urdf into `out`, and
/// gives the recording, if any, the calibrated frames.
fn calibrate_skin(
    remote: &mut Remote,
    text: &str,
    model: &Robot,
    found: &job::Found,
    range: AccelRange,
    pitch_m: Option<f64>,
    out: &Path,
) -> Result<CalibrationSection, Box<dyn std::error::Error>> {
    let bar = RefCell::new(Progress::new("skin calibration", "postures and excitations"));
    let cfg = CalibrateConfig { range, ..CalibrateConfig::default() };
    // The cells left out of the exploration stay out of the calibration.
    let mut clock = |robot_s| bar.borrow_mut().robot_time(robot_s, None);
    let mut rig = Screened::new(remote, &found.sensor_faults).on_tick(&mut clock);
    let mut c = calibrate(&mut rig, model, &found.exploration, &cfg, &mut |p| {
        bar.borrow_mut().set(p.done as u64, p.total as u64)
    })?;
    bar.into_inner().finish();
    // Wires a declared pitch long place what the motion left blind; a
    // skin wired without regard to where its cells sit would place them wrong.
    if let Some(pitch_m) = pitch_m {
        let tables = job::neighbour_tables(remote);
        let cfg = NeighbourConfig { pitch_m, ..NeighbourConfig::default() };
        resolve(&mut c.cells, model, &c.description_start, &tables, &cfg);
    }
    let with_skin = urdf_with_skin(text, model, &c)?;
    let mut files = Vec::new();
    for (file, content) in [("skin.toml", skin_toml(model, &c)), ("robot_with_skin.urdf", with_skin.clone())] {
        let path = out.join(file);
        std::fs::write(&path, content).map_err(|e| format!("cannot write {}: {e}", path.display()))?;
        files.push(file.to_owned());
    }
    if let Some(session) = remote.recording_mut() {
        session.calibrated(ros_poses(model, &c), with_skin);
    }
    Ok(CalibrationSection::new(&c, picture(model, &c, &c.description_start), files))
}
