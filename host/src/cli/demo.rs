//! `skin demo`: the main job on the built-in default, with no file, no
//! network and no hardware.
//!
//! The simulated HRP-2-like robot and the 74-cell skin of the grasping
//! experiment run as a separate endpoint on loopback UDP (a thread of
//! their own, in lockstep), reached only through the interface datagrams
//! and the robot link, so the host drives them exactly as it would drive
//! the real ones. The skin organizes itself with IDs from the host, the
//! robot explores its body, a simulated person teaches the key poses and
//! the robot grasps the objects of Figure 16, going home between grasps:
//! one robot, one skin, one run. The person and the objects live in the
//! endpoint, which alone knows where every cell is; the experimenter
//! speaks with the person over an in-process side channel
//! ([`Running::order`]), as with a person standing by a real robot.
//! Everything the simulator alone knows is used afterwards to check the
//! host's results, and the report folder is written.

use std::io::Write;
use std::net::SocketAddr;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::{Duration, Instant};

use skin_host::config::{CellSettings, InterfaceConfig};
use skin_host::control::params::Params;
use skin_host::explore::check::check;
use skin_host::explore::{Exploration, ExploreConfig, SensoryMotorMap};
use skin_host::grasping::{grasp, learn, Experimenter, GraspError, GraspRun, Taught};
use skin_host::interface::Interface;
use skin_host::pipeline::OrganizeConfig;
use skin_host::remote::{Remote, RobotLink};
use skin_host::report::{check_folder, GraspSection, LatencySection, Report, TruthSection};
use skin_model::robot::hrp2;
use skin_sim::endpoint::{Batching, EndpointConfig, Pacing, Running, Truth};
use skin_sim::network::NetworkConfig;
use skin_sim::scene::experiment::Setup;
use skin_sim::scene::operator::{Note, Order};
use skin_sim::scene::placement::{ObjectAt, Placement};
use skin_sim::world::{World, WorldConfig};

use super::job::{self, Steps};
use super::lab::LabArgs;
use super::live::LiveArgs;
use super::objects::built_in;

/// The loopback address with a port the OS picks.
const LOOPBACK: SocketAddr = SocketAddr::new(std::net::IpAddr::V4(std::net::Ipv4Addr::LOCALHOST), 0);
/// Longest wait for one answer of the simulated robot.
const LINK_TIMEOUT: Duration = Duration::from_secs(2);

/// Arguments of `skin demo`.
#[derive(clap::Args)]
pub struct Args {
    /// The report folder (created if missing).
    #[arg(long, value_name = "DIR", default_value = "report")]
    out: PathBuf,
    /// Seed of everything random: skin placement, boot order, sensor errors, noise, sway.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// The short setting for tests: one object to grasp instead of five.
    #[arg(long)]
    quick: bool,
    /// Print report.json on stdout instead of the human summary.
    #[arg(long)]
    json: bool,
    /// Also record (and with `--ros2` publish) every cell's acceleration as `sensor_msgs/Imu` on `/skin/imu`.
    #[arg(long)]
    imu: bool,
    /// Do not write `recording.mcap` (about 400 MB for the whole demo).
    #[arg(long)]
    no_record: bool,
    #[command(flatten)]
    live: LiveArgs,
    #[command(flatten)]
    lab: LabArgs,
}

/// The demo's recording, in its report folder.
pub const RECORDING: &str = "recording.mcap";

pub fn run(args: Args) -> Result<ExitCode, Box<dyn std::error::Error>> {
    let wall = Instant::now();
    let seed = args.seed;
    // Refused before anything starts: --ros-domain without --ros2.
    args.live.ros_domain(false)?;
    check_folder(&args.out)?;
    let (mut endpoint, mut remote, steps) = serve_experiment(seed, &args.lab)?;
    if !args.no_record {
        job::record(&mut remote, &args.out.join(RECORDING), &steps, args.imu)?;
    }
    let live = args.live.start(&mut remote, steps.explore.range, args.imu)?;
    let found = job::run(&mut remote, &steps)?;
    let exploration = found.exploration.clone();
    let grasp_wall = Instant::now();
    let chosen: Vec<Option<ObjectAt>> = built_in(if args.quick { "trash_bin" } else { "all" })?
        .into_iter()
        .map(|o| o.map(|object| ObjectAt { object, placement: Placement::default() }))
        .collect();
    let (taught, runs) =
        teach_and_grasp(&mut remote, &mut endpoint, exploration.smm.clone(), &Params::default(), &chosen)?;
    let grasp_wall_s = grasp_wall.elapsed().as_secs_f64();
    let robot_addr = endpoint.robot;
    let recorded = job::finish_recording(&mut remote);
    live.finish();
    let recorded = recorded?;
    let truth = endpoint.stop()?;
    let checked = truth_section(&remote, &truth, &exploration, seed)?;
    let cells = truth.ids.len();
    let source = format!(
        "The built-in simulated HRP-2-like robot ({} DoFs) and the {cells}-cell skin of the grasping experiment (seed {seed}) in {}, served on loopback UDP in lockstep: robot link {}, interface ports {}.",
        remote.link().info().dof_names.len(),
        args.lab.describe(),
        robot_addr,
        remote.interface().ports().iter().filter_map(|p| p.address()).map(|a| a.to_string()).collect::<Vec<_>>().join(", ")
    );
    let mut report = job::report(&remote, source, found);
    report.latency = Some(LatencySection::new(truth.latency_us, truth.sensor_frames_lost));
    report.truth = Some(checked);
    report.grasps = Some(GraspSection {
        how: format!(
            "Over the same loopback UDP link and skin, on the map explored above (seed {seed}): a simulated person at the robot's endpoint names the cells of each touch area by the IDs the host assigned (on a real robot the operator writes them into the configuration after touching them in `skin monitor`), teaches the key poses by proximity guidance, then puts each object in front of the robot at home; the robot grasps it with one parameter set (Table 4), launched and released by a pat on the shoulder, and goes home before the next. The person gets orders and tells ground truth (forces, the object's gap) over an in-process side channel, as a person standing by a real robot would; the controller sees only the skin's datagrams and the robot link's feedback."
        ),
        lessons: taught.lessons,
        runs,
    });
    report.timing.grasp_wall_s = grasp_wall_s;
    report.timing.total_wall_s = wall.elapsed().as_secs_f64();
    let written = report.write(&args.out)?;
    report.timing.total_wall_s = wall.elapsed().as_secs_f64();
    let mut text = if args.json { serde_json::to_string_pretty(&report)? } else { job::summary(&report, &written) };
    if let Some(line) = recorded.filter(|_| !args.json) {
        text = format!("{text}\n{line}");
    }
    match writeln!(std::io::stdout().lock(), "{text}") {
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => {}
        other => other?,
    }
    Ok(if all_good(&report, exploration.cells.len()) { ExitCode::SUCCESS } else { ExitCode::FAILURE })
}

/// The grasping experiment's robot, skin and person served on loopback
/// UDP in lockstep (in the world `lab` says), the host's link to them, and
/// the main job's steps.
pub(super) fn serve_experiment(
    seed: u64,
    lab: &LabArgs,
) -> Result<(Running, Remote, Steps), Box<dyn std::error::Error>> {
    lab.check()?;
    let interface = Interface::bind(&InterfaceConfig { listen: LOOPBACK, ..InterfaceConfig::default() })?;
    let host = interface.local_addr();
    let recipe = lab.recipe();
    let endpoint = Running::spawn(move || {
        let network = NetworkConfig { seed, ..NetworkConfig::default() };
        let config =
            EndpointConfig { robot: LOOPBACK, host, pacing: Pacing::Lockstep, batching: Batching::default(), network };
        recipe.build(seed, config)
    })?;
    let steps = Steps {
        organize: OrganizeConfig {
            expected_cells: Some(Setup::new(&hrp2::robot(), seed)?.skin.cells().len()),
            ..OrganizeConfig::default()
        },
        settings: CellSettings::default().settings(),
        explore: ExploreConfig::default(),
        ports: InterfaceConfig::default().ports,
    };
    let remote = Remote::new(RobotLink::connect(endpoint.robot, LINK_TIMEOUT)?, interface);
    Ok((endpoint, remote, steps))
}

/// The simulated person of the robot's endpoint, over its side channel.
struct Person<'a>(&'a mut Running);

impl Experimenter for Person<'_> {
    fn order(&mut self, order: Order) -> Result<(), GraspError> {
        self.0.order(order).map_err(|e| GraspError::Person(e.to_string()))
    }

    fn heard(&mut self, out: &mut Vec<Note>) {
        out.extend(self.0.notes());
    }
}

/// Teaching by the person at the robot, then a grasp of each of `objects`.
pub(super) fn teach_and_grasp(
    remote: &mut Remote,
    person: &mut Running,
    map: SensoryMotorMap,
    params: &Params,
    objects: &[Option<ObjectAt>],
) -> Result<(Taught, Vec<GraspRun>), GraspError> {
    let style = indicatif::ProgressStyle::with_template("{msg:32} [{bar:30}] {pos}/{len} steps")
        .expect("a valid template")
        .progress_chars("=> ");
    let progress = indicatif::ProgressBar::new(0).with_style(style);
    progress.set_length((6 + objects.len()) as u64);
    let person = &mut Person(person);
    let taught = learn(remote, person, map, params, &mut |step| {
        progress.set_message(step.to_owned());
        progress.inc(1);
    })?;
    let mut runs = Vec::new();
    for object in objects {
        progress.set_message(format!("grasping {}", object.as_ref().map_or("nothing", |o| &o.object.name)));
        runs.push(grasp(remote, person, &taught, object.as_ref(), params)?);
        progress.inc(1);
    }
    progress.finish_and_clear();
    Ok((taught, runs))
}

/// The host's results checked against the simulator's truth.
fn truth_section(
    remote: &Remote,
    truth: &Truth,
    found: &Exploration,
    seed: u64,
) -> Result<TruthSection, Box<dyn std::error::Error>> {
    let mut ids = truth.ids.clone();
    let cells_with_id = ids.iter().filter(|a| a.is_cell()).count();
    ids.sort_unstable();
    ids.dedup();
    let ids_unique = ids.len() == truth.ids.len();
    let registry = remote.interface().registry();
    let neighbours_correct = truth.neighbours.len() == truth.ids.len()
        && truth
            .neighbours
            .iter()
            .all(|(id, table)| registry.get(*id).and_then(|c| c.neighbours()).is_some_and(|r| r.neighbours == *table));
    let setup = Setup::new(&hrp2::robot(), seed)?;
    let world =
        World::new(hrp2::robot(), setup.skin.relabeled(&truth.ids)?, WorldConfig { seed, ..WorldConfig::default() });
    let t = check(found, &world);
    Ok(TruthSection {
        cells_in_skin: truth.ids.len(),
        cells_with_id,
        ids_unique,
        neighbours_correct,
        tree_correct: t.tree_correct,
        wrong_activity_entries: t.wrong_entries,
        smm_mean_abs_error: t.smm_mean_abs_error,
        smm_mean_abs_error_moved: t.smm_mean_abs_error_moved,
    })
}

/// Every cell organized and explored, the truth matched, every object held.
fn all_good(r: &Report, explored: usize) -> bool {
    let truth_ok = r
        .truth
        .as_ref()
        .is_some_and(|t| t.ids_unique && t.cells_with_id == t.cells_in_skin && t.neighbours_correct && t.tree_correct);
    let grasps_ok = r.grasps.as_ref().is_some_and(|g| g.runs.iter().all(|run| run.succeeded));
    truth_ok && grasps_ok && explored == r.organization.cells.len()
}
