//! The main job shared by `skin demo` and `skin run`: organize the skin,
//! write the cell settings, explore the body, each step with a progress
//! bar; and the report's parts that come from it.

use std::cell::RefCell;
use std::path::{Path, PathBuf};
use std::time::Instant;

use skin_host::config::PortConfig;
use skin_host::explore::{explore, Exploration, ExploreConfig};
use skin_host::health::{self, Screened, SensorFault};
use skin_host::pipeline::{organize, silence_bound, write_settings, OrganizeConfig, Organized, PipelineError};
use skin_host::recording::{ExploreStart, RecordError, Session};
use skin_host::remote::Remote;
use skin_host::report::{ExplorationSection, LinkSection, Report, RobotSection, Timing};
use skin_protocol::message::{NeighbourReport, Setting};
use skin_protocol::Address;

use super::progress::Progress;

/// Robot time given to the cells to acknowledge each round of settings, s.
const ACK_WAIT_S: f64 = 0.05;

/// What the job does.
pub struct Steps {
    /// When the skin counts as organized.
    pub organize: OrganizeConfig,
    /// Written into every cell once organized.
    pub settings: Vec<Setting>,
    /// The exploration.
    pub explore: ExploreConfig,
    /// The interface ports configured (a recording keeps them for `skin replay`).
    pub ports: Vec<PortConfig>,
}

/// Starts recording `remote` into the MCAP file `path`; `imu` adds `/skin/imu`.
pub fn record(remote: &mut Remote, path: &Path, steps: &Steps, imu: bool) -> Result<(), RecordError> {
    remote.record(Session::create(path, steps.explore.range, imu)?);
    Ok(())
}

/// Closes the recording, if any, and says where it is.
pub fn finish_recording(remote: &mut Remote) -> Result<Option<String>, RecordError> {
    Ok(remote.finish_recording().transpose()?.map(|p| format!("recording: {}", p.display())))
}

/// What the job found.
pub struct Found {
    pub organized: Organized,
    /// Cells whose sensors read what no working one can.
    pub sensor_faults: Vec<SensorFault>,
    pub exploration: Exploration,
    pub timing: Timing,
}

/// Organizes, configures and explores.
pub fn run(remote: &mut Remote, steps: &Steps) -> Result<Found, PipelineError> {
    let mut timing = Timing::default();
    let wall = Instant::now();
    let mut organizing = Progress::new("self-organization", "cells with neighbour tables");
    let mut organized = organize(remote, &steps.organize, &mut |n, spent_s| {
        organizing.set(n as u64, steps.organize.expected_cells.unwrap_or(n) as u64);
        organizing.robot_time(spent_s, Some(steps.organize.timeout_s));
    })?;
    organized.settings_written = organized.cells.len() * steps.settings.len();
    organized.settings_acknowledged = write_settings(remote, &steps.settings, ACK_WAIT_S)?;
    organizing.finish();
    // From here every cell sends every sample: a port falling silent ends
    // the run instead of leaving gaps in the measurements.
    remote.watch_silence(silence_bound(&steps.settings));
    timing.organize_wall_s = wall.elapsed().as_secs_f64();
    timing.organize_robot_s = organized.time_s;

    let wall = Instant::now();
    // Broken sensors are named, and broken accelerometers left out, before
    // the exploration spends its budget on cells that can never settle.
    let sensor_faults = health::listen(remote, steps.explore.range)?;
    for fault in &sensor_faults {
        let left_out = if fault.left_out { ": left out of the exploration and the map" } else { "" };
        eprintln!("warning: {fault}{left_out}");
    }
    let info = remote.link().info().clone();
    if let Some(session) = remote.recording_mut() {
        session.explore_start(&ExploreStart {
            dof_names: info.dof_names,
            dof_kinds: info.dof_kinds,
            period_s: info.period_s,
            accel_range_g: steps.explore.range.full_scale_g() as u8,
            ports: steps.ports.clone(),
            left_out_cells: sensor_faults.iter().filter(|f| f.left_out).map(|f| f.cell).collect(),
        });
    }
    tracing::info!(cells = organized.cells.len(), "the skin organized; exploring the body");
    let exploring = RefCell::new(Progress::new("self-exploration", "DoF measurements"));
    let budget_s = steps.explore.structure.budget_s;
    let mut clock = |robot_s| exploring.borrow_mut().robot_time(robot_s, Some(budget_s));
    let mut rig = Screened::new(remote, &sensor_faults).on_tick(&mut clock);
    let exploration =
        explore(&mut rig, &steps.explore, &mut |p| exploring.borrow_mut().set(p.done as u64, p.total as u64))?;
    exploring.into_inner().finish();
    if let Some(session) = remote.recording_mut() {
        session.explored(&exploration);
    }
    timing.explore_wall_s = wall.elapsed().as_secs_f64();
    timing.structure_robot_s = exploration.structure_time_s;
    timing.smm_robot_s = exploration.smm_time_s;
    Ok(Found { organized, sensor_faults, exploration, timing })
}

/// The organized skin's neighbour tables: IDs and ports, as its
/// self-organization reported them.
pub fn neighbour_tables(remote: &Remote) -> Vec<(Address, NeighbourReport)> {
    remote.interface().registry().cells().filter_map(|r| r.neighbours().map(|n| (r.id(), *n))).collect()
}

/// The report's parts that the job found; the rest is left empty.
pub fn report(remote: &Remote, source: String, found: Found) -> Report {
    let info = remote.link().info();
    let link = remote.link().counters();
    Report {
        robot: RobotSection {
            source,
            dof_names: info.dof_names.clone(),
            period_s: info.period_s,
            lockstep: info.lockstep,
        },
        timing: found.timing,
        organization: found.organized,
        interface: *remote.interface().counters(),
        link: LinkSection { retries: link.retries, ignored: link.ignored },
        exploration: ExplorationSection::new(&found.exploration),
        sensor_faults: found.sensor_faults,
        #[cfg(feature = "sim")]
        latency: None,
        calibration: None,
        #[cfg(feature = "sim")]
        grasps: None,
        #[cfg(feature = "sim")]
        truth: None,
        figures: Vec::new(),
    }
}

/// The short human summary.
pub fn summary(r: &Report, written: &[PathBuf]) -> String {
    let t = &r.timing;
    let e = &r.exploration;
    let mut s = format!("{}\n", r.robot.source);
    s += &format!(
        "self-organization: {} cells in {:.2} s robot time, {} of {} settings acknowledged\n",
        r.organization.cells.len(),
        t.organize_robot_s,
        r.organization.settings_acknowledged,
        r.organization.settings_written
    );
    s += &format!(
        "self-exploration: {} body parts, {} joints, {} limbs; {:.1} s + {:.1} s robot time (structure + sensory-motor map)\n",
        e.body_parts.len(),
        e.joints.len(),
        e.limbs.len(),
        t.structure_robot_s,
        t.smm_robot_s
    );
    #[cfg(feature = "sim")]
    s.push_str(&r.simulation_summary());
    for f in &r.sensor_faults {
        s += &format!("sensor fault: {f}\n");
    }
    for w in &e.warnings {
        s += &format!("warning: {w}\n");
    }
    s += &format!(
        "wall time {:.1} s (organize {:.1} s, explore {:.1} s",
        t.total_wall_s, t.organize_wall_s, t.explore_wall_s
    );
    s += &if t.grasp_wall_s > 0.0 { format!(", teach and grasp {:.1} s)\n", t.grasp_wall_s) } else { ")\n".to_owned() };
    if let Some(index) = written.iter().find(|p| p.ends_with("index.html")) {
        s += &format!("report: {} ({} files)", index.display(), written.len());
    }
    s.trim_end().to_owned()
}
