//! `skin demo`: the main job on the built-in default, with no file, no
//! network and no hardware.
//!
//! The simulated HRP-2-like robot and its 74-cell skin run as a separate
//! endpoint on loopback UDP (a thread of their own, in lockstep), reached
//! only through the interface datagrams and the robot link, so the host
//! drives them exactly as it would drive the real ones. The skin organizes
//! itself with IDs from the host, the robot explores its body, and then a
//! simulated person teaches the key poses and the robot grasps the objects
//! of Figure 16 (these run in-process: the person and the objects live in
//! the simulator). Everything the simulator alone knows is used afterwards
//! to check the host's results, and the report folder is written.

use std::io::Write;
use std::net::SocketAddr;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::{Duration, Instant};

use skin_host::config::{CellSettings, InterfaceConfig};
use skin_host::control::params::Params;
use skin_host::explore::check::check;
use skin_host::explore::{Exploration, ExploreConfig};
use skin_host::grasping::{grasp, learn, objects};
use skin_host::interface::Interface;
use skin_host::pipeline::OrganizeConfig;
use skin_host::remote::{Remote, RobotLink};
use skin_host::report::{GraspSection, LatencySection, Report, TruthSection};
use skin_sim::endpoint::{Endpoint, EndpointConfig, Pacing, Running, Truth};
use skin_sim::network::NetworkConfig;
use skin_sim::robot::hrp2;
use skin_sim::world::World;

use super::job::{self, bar, Steps};

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
}

pub fn run(args: Args) -> Result<ExitCode, Box<dyn std::error::Error>> {
    let wall = Instant::now();
    let interface = Interface::bind(&InterfaceConfig { listen: LOOPBACK, ..InterfaceConfig::default() })?;
    let host = interface.local_addr();
    let seed = args.seed;
    let endpoint = Running::spawn(move || {
        let network = NetworkConfig { seed, ..NetworkConfig::default() };
        Endpoint::hrp2(seed, EndpointConfig { robot: LOOPBACK, host, pacing: Pacing::Lockstep, network })
    })?;
    let cells = hrp2::SKIN.iter().map(|(_, n)| n).sum();
    let steps = Steps {
        organize: OrganizeConfig { expected_cells: Some(cells), ..OrganizeConfig::default() },
        settings: CellSettings::default().settings(),
        explore: ExploreConfig::default(),
    };
    let mut remote = Remote::new(RobotLink::connect(endpoint.robot, LINK_TIMEOUT)?, interface);
    let found = job::run(&mut remote, &steps)?;
    let robot_addr = endpoint.robot;
    let truth = endpoint.stop()?;
    let checked = truth_section(&remote, &truth, &found.exploration, seed)?;
    let source = format!(
        "The built-in simulated HRP-2-like robot ({} DoFs) and its {cells}-cell skin (seed {seed}), served on loopback UDP in lockstep: robot link {}, interface ports {}.",
        remote.link().info().dof_names.len(),
        robot_addr,
        remote.interface().ports().iter().filter_map(|p| p.address()).map(|a| a.to_string()).collect::<Vec<_>>().join(", ")
    );
    let exploration_cells = found.exploration.cells.len();
    let mut report = job::report(&remote, source, found);
    report.latency = Some(LatencySection::new(truth.latency_us, truth.sensor_frames_lost));
    report.truth = Some(checked);
    let grasp_wall = Instant::now();
    report.grasps = Some(grasps(seed, args.quick)?);
    report.timing.grasp_wall_s = grasp_wall.elapsed().as_secs_f64();
    report.timing.total_wall_s = wall.elapsed().as_secs_f64();
    let written = report.write(&args.out)?;
    report.timing.total_wall_s = wall.elapsed().as_secs_f64();
    let text = if args.json { serde_json::to_string_pretty(&report)? } else { job::summary(&report, &written) };
    match writeln!(std::io::stdout().lock(), "{text}") {
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => {}
        other => other?,
    }
    Ok(if all_good(&report, exploration_cells) { ExitCode::SUCCESS } else { ExitCode::FAILURE })
}

/// Teaching by a simulated person and the grasps of Figure 16 (one object with `quick`).
fn grasps(seed: u64, quick: bool) -> Result<GraspSection, Box<dyn std::error::Error>> {
    let params = Params::default();
    let chosen = objects(if quick { "trash_bin" } else { "all" })?;
    let progress = bar("{msg:24} [{bar:30}] {pos}/{len} steps");
    progress.set_length((4 + chosen.len()) as u64);
    let taught = learn(seed, &params, &mut |step| {
        progress.set_message(step.chars().take(24).collect::<String>());
        progress.inc(1);
    })?;
    let mut runs = Vec::new();
    for object in &chosen {
        progress.set_message(format!("grasping {}", object.as_ref().map_or("nothing", |o| o.name)));
        runs.push(grasp(&taught, object.as_ref(), &params)?);
        progress.inc(1);
    }
    progress.finish_and_clear();
    Ok(GraspSection {
        how: format!(
            "In-process on the simulator (seed {seed}), where the person and the objects live: the robot explores itself again ({:.1} s robot time), a simulated person teaches the key poses by proximity guidance, and each object is grasped with one parameter set (Table 4), launched and released by a pat on the shoulder. The controller sees only samples and joint positions.",
            taught.exploration_s
        ),
        lessons: taught.lessons,
        runs,
    })
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
    let simulated = hrp2::world(seed);
    let world = World::new(hrp2::robot(), simulated.skin().relabeled(&truth.ids)?, *simulated.config());
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
