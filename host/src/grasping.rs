//! The simulated grasping experiment (sections 5.3 and 6.5).
//!
//! One run does what the paper did on HRP-2: the robot explores its body
//! (section 4), a person teaches it the four key poses by proximity
//! guidance, each key pose becomes a tile of the sensory-motor map, and
//! then the robot grasps objects of Figure 16, launched and released by a
//! pat on the shoulder, with one parameter set. The controller sees only
//! samples and joint positions; the person and the objects live in the
//! simulator, which alone knows where everything is.
//!
//! [`write_traces`] writes what each grasp felt (Figure 18) as CSV and SVG.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use serde::Serialize;
use skin_protocol::{Address, Sample};
use skin_sim::robot::{hrp2, Robot as Model};
use skin_sim::scene::experiment::{gap_to_chest_m, intended_pose, object_pose, Setup};
use skin_sim::scene::object::Object;
use skin_sim::scene::person::{self, Guiding, Teacher};
use skin_sim::scene::{Scene, SharedScene, SkinModel};
use skin_sim::skin::SkinError;
use skin_sim::world::{World, WorldConfig};
use tracing::{debug, info};

use crate::control::areas::{parse_specs, AreaId, AreaKind, Areas};
use crate::control::cells::CellIndex;
use crate::control::controller::{Controller, Input};
use crate::control::grasp::{Cause, State};
use crate::control::params::Params;
use crate::control::teach::{Guidance, KeyPoses, KEY_POSES};
use crate::control::ControlError;
use crate::explore::{explore, ExploreConfig, ExploreError, Progress, SensoryMotorMap};
use crate::robot::{Robot, RobotError, SampleSource, SimRobot};

/// Longest a person tries to teach one key pose, s.
const TEACH_LIMIT_S: f64 = 60.0;
/// Longest one grasp may take, from the launching pat, s.
const GRASP_LIMIT_S: f64 = 180.0;
/// When the person pats to launch, s after the start.
const LAUNCH_AT_S: f64 = 0.5;
/// How long a pat lasts, s.
const PAT_S: f64 = 0.3;
/// How deep a pat presses, m.
const PAT_DEPTH_M: f64 = 0.0015;
/// How long the robot holds an object before the person pats to release it, s.
const HOLD_S: f64 = 3.0;
/// Trace rows per second (every control period is 250).
const TRACE_HZ: f64 = 50.0;

/// Why the experiment could not run.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum GraspError {
    /// The self-exploration failed.
    #[error("self-exploration failed: {0}")]
    Explore(#[from] ExploreError),
    /// The controller refused its parameters, areas or poses.
    #[error(transparent)]
    Control(#[from] ControlError),
    /// The simulated robot refused a command.
    #[error(transparent)]
    Robot(#[from] RobotError),
    /// The experiment's skin could not be built.
    #[error(transparent)]
    Skin(#[from] SkinError),
    /// An object that is not in Figure 16.
    #[error("no object \"{0}\": choose trash_bin, sponge_rock, moving_box, box_lid, delivery_box, all or none")]
    UnknownObject(String),
    /// A trace file could not be written.
    #[error("cannot write {path}: {message}")]
    Write {
        /// The file.
        path: String,
        /// What went wrong.
        message: String,
    },
}

/// A taught key pose.
#[derive(Clone, Debug, Serialize)]
pub struct Lesson {
    /// The key pose.
    pub pose: String,
    /// Robot time the person guided, s.
    pub time_s: f64,
    /// How far each arm's cells ended from where the person pictured them
    /// (root mean square; right, left), m.
    pub error_m: [f64; 2],
}

/// What the robot knows after exploring and being taught.
#[derive(Clone, Debug)]
pub struct Taught {
    /// The sensory-motor map, with a tile at every key pose.
    pub map: SensoryMotorMap,
    /// The key poses.
    pub poses: KeyPoses,
    /// How the teaching went.
    pub lessons: Vec<Lesson>,
    /// Robot time of the self-exploration, s.
    pub exploration_s: f64,
    setup: Setup,
    seed: u64,
}

/// One transition of the grasp.
#[derive(Clone, Debug, Serialize)]
pub struct Logged {
    /// The state entered.
    pub state: State,
    /// When, s after the launching pat.
    pub time_s: f64,
    /// Why.
    pub cause: Cause,
}

/// One row of a grasp's trace.
#[derive(Clone, Debug, Serialize)]
pub struct TraceRow {
    /// s after the launching pat.
    pub time_s: f64,
    /// The grasp state.
    pub state: State,
    /// Joint positions, rad.
    pub joints_rad: Vec<f64>,
    /// Per touch area (right arm, left arm, chest): summed normalized
    /// force readings of its force cells.
    pub force: [f64; 3],
    /// Per touch area (right arm, left arm, chest): highest proximity.
    pub proximity: [f64; 3],
    /// Ground truth: how far the object is from the chest's skin, m.
    pub object_gap_m: Option<f64>,
}

/// One grasp.
#[derive(Clone, Debug, Serialize)]
pub struct GraspRun {
    /// The object, or "none".
    pub object: String,
    /// Contact made, force applied and the object pulled to the chest (the
    /// paper's criterion): the grasp reached Hold.
    pub succeeded: bool,
    /// The state it ended in.
    pub final_state: State,
    /// From the launching pat to the final state, s.
    pub time_s: f64,
    /// Ground truth: the largest force on any one force cell, N.
    pub max_cell_force_n: f64,
    /// Pain-level touches (each one evaded).
    pub pain_events: usize,
    /// Every transition.
    pub state_log: Vec<Logged>,
    /// What the skin felt, at 50 Hz.
    #[serde(skip)]
    pub trace: Vec<TraceRow>,
}

/// The objects a command-line choice names: one, all of Figure 16, or none.
pub fn objects(choice: &str) -> Result<Vec<Option<Object>>, GraspError> {
    match choice {
        "all" => Ok(Object::figure_16().into_iter().map(Some).collect()),
        "none" => Ok(vec![None]),
        name => Object::by_name(name).map(|o| vec![Some(o)]).ok_or_else(|| GraspError::UnknownObject(name.into())),
    }
}

/// The simulated robot, its skin and the scene, stepped together.
struct Rig {
    robot: SimRobot,
    scene: SharedScene,
    model: Model,
    samples: Vec<(Address, Sample)>,
}

impl Rig {
    fn new(setup: &Setup, seed: u64, object: Option<&Object>) -> Rig {
        let model = hrp2::robot();
        let mut world = World::new(model.clone(), setup.skin.clone(), WorldConfig { seed, ..WorldConfig::default() });
        let mut scene = Scene::new(SkinModel::default());
        if let Some(o) = object {
            scene.place(o.clone(), object_pose(o, scene.skin().surface_offset_m));
        }
        for (cell, points) in &setup.surface {
            scene.add_bare_surface(*cell, points.clone());
        }
        let scene = SharedScene::new(scene);
        world.set_tactile(scene.tactile(seed.wrapping_add(1)));
        Rig { robot: SimRobot::new(world), scene, model, samples: Vec::new() }
    }

    fn time_s(&self) -> f64 {
        self.robot.world().time_s()
    }

    /// One control period: the world advances, the controller takes what
    /// arrived and commands the robot.
    fn tick(&mut self, controller: &mut Controller, map: &SensoryMotorMap) -> Result<(), GraspError> {
        self.samples.clear();
        self.robot.next_tick(&mut self.samples)?;
        for (cell, s) in &self.samples {
            controller.receive(*cell, &Input::Sample(*s));
        }
        let pose = self.robot.positions();
        let command = controller.step(map, &pose, self.time_s())?;
        self.robot.command_velocities(command)?;
        Ok(())
    }
}

fn controller(setup: &Setup, map: &SensoryMotorMap, params: &Params) -> Result<Controller, GraspError> {
    let index = CellIndex::new(map.cells())?;
    let areas = Areas::resolve(&parse_specs(&setup.areas_toml)?, &index, |_| None)?;
    let dofs = map.tiles().first().map_or(0, |t| t.pose().len());
    Ok(Controller::new(index, areas, dofs, params.clone())?)
}

/// Explores the robot and lets a person teach it the key poses by
/// proximity guidance; each key pose becomes a map tile.
pub fn learn(seed: u64, params: &Params, progress: &mut dyn FnMut(&str)) -> Result<Taught, GraspError> {
    let setup = Setup::new(&hrp2::robot(), seed)?;
    let mut rig = Rig::new(&setup, seed, None);
    progress("self-exploration");
    let exploration = explore(&mut rig.robot, &ExploreConfig::default(), &mut |_: Progress| ())?;
    let mut map = exploration.smm;
    let mut c = controller(&setup, &map, params)?;
    c.guide(Guidance::Proximity);
    let mut poses = KeyPoses::new();
    poses.record("home", &rig.robot.positions())?;
    let mut lessons = Vec::new();
    let sensor = rig.scene.get().skin().proximity;
    let offset = rig.scene.get().skin().surface_offset_m;
    for name in KEY_POSES.into_iter().skip(1) {
        progress(&format!("teaching \"{name}\""));
        let picture = intended_pose(&rig.model, name).expect("the person pictures every key pose");
        let mut person =
            Teacher::new(&rig.model, &setup.skin, &picture, setup.guided_cells.clone(), Guiding::default());
        let start = rig.time_s();
        while !person.satisfied(rig.robot.world().cell_poses()) && rig.time_s() - start < TEACH_LIMIT_S {
            let hands = person.hands(rig.time_s(), rig.robot.world().cell_poses(), offset, &sensor);
            rig.scene.get_mut().set_hands(hands);
            rig.tick(&mut c, &map)?;
            if rig.time_s() % 2.0 < rig.robot.tick_s() {
                let error_m = person.error_m(rig.robot.world().cell_poses());
                debug!(pose = name, time_s = rig.time_s() - start, ?error_m, "teaching");
            }
        }
        rig.scene.get_mut().set_hands(Vec::new());
        // Hands away: the robot comes to rest.
        for _ in 0..25 {
            rig.tick(&mut c, &map)?;
        }
        let lesson = Lesson {
            pose: name.to_owned(),
            time_s: rig.time_s() - start,
            error_m: person.error_m(rig.robot.world().cell_poses()),
        };
        info!(pose = name, time_s = lesson.time_s, error_m = ?lesson.error_m, "taught");
        lessons.push(lesson);
        let pose = rig.robot.positions();
        poses.record(name, &pose)?;
        progress(&format!("exploring a map tile at \"{name}\""));
        map.add_tile(&mut rig.robot, &pose)?;
    }
    Ok(Taught {
        map,
        poses,
        lessons,
        exploration_s: exploration.structure_time_s + exploration.smm_time_s,
        setup,
        seed,
    })
}

/// Puts `object` (or nothing) between the arms of a fresh robot that knows
/// what `taught` holds, and lets a person launch a grasp with a pat, and
/// release the object with another once it has been held.
pub fn grasp(taught: &Taught, object: Option<&Object>, params: &Params) -> Result<GraspRun, GraspError> {
    let mut rig = Rig::new(&taught.setup, taught.seed, object);
    let mut c = controller(&taught.setup, &taught.map, params)?;
    c.start_grasp(taught.poses.clone())?;
    let offset = rig.scene.get().skin().surface_offset_m;
    let areas = traced_areas(c.areas());
    let launch = LAUNCH_AT_S;
    let mut release_at: Option<f64> = None;
    let mut trace = Vec::new();
    let mut next_row = 0.0;
    let end = loop {
        let t = rig.time_s();
        let state = c.state().expect("grasp mode");
        if state == State::Hold && release_at.is_none() {
            release_at = Some(t + HOLD_S);
        }
        let patting = |at: f64| t >= at && t < at + PAT_S;
        let pat = patting(launch) || release_at.is_some_and(patting);
        let hands = if pat {
            vec![person::pat(&rig.robot.world().cell_poses()[taught.setup.pat_cell], offset, PAT_DEPTH_M)]
        } else {
            Vec::new()
        };
        rig.scene.get_mut().set_hands(hands);
        rig.tick(&mut c, &taught.map)?;
        let t = rig.time_s();
        if t >= next_row + launch {
            next_row += 1.0 / TRACE_HZ;
            trace.push(row(&c, &areas, &rig, t - launch));
        }
        let state = c.state().expect("grasp mode");
        let over = t > launch + PAT_S && matches!(state, State::Done | State::Cancelled);
        if over || t - launch > GRASP_LIMIT_S {
            break state;
        }
    };
    let state_log: Vec<Logged> =
        c.transitions().iter().map(|tr| Logged { state: tr.to, time_s: tr.time_s - launch, cause: tr.cause }).collect();
    let run = GraspRun {
        object: object.map_or("none", |o| o.name).to_owned(),
        succeeded: state_log.iter().any(|l| l.state == State::Hold),
        final_state: end,
        time_s: state_log.last().map_or(0.0, |l| l.time_s),
        max_cell_force_n: rig.scene.get().max_force_n(),
        pain_events: state_log.iter().filter(|l| l.cause == Cause::Pain).count(),
        state_log,
        trace,
    };
    info!(object = run.object, succeeded = run.succeeded, final_state = ?run.final_state, "grasp");
    Ok(run)
}

/// The traced areas: right arm, left arm and chest (by kind and order).
fn traced_areas(areas: &Areas) -> [Option<AreaId>; 3] {
    let mut contact = areas.of_kind(AreaKind::Contact);
    [contact.next(), contact.next(), areas.of_kind(AreaKind::Chest).next()]
}

fn row(c: &Controller, areas: &[Option<AreaId>; 3], rig: &Rig, time_s: f64) -> TraceRow {
    let mut force = [0.0; 3];
    let mut proximity = [0.0f64; 3];
    for (k, area) in areas.iter().enumerate() {
        for r in area.iter().flat_map(|a| c.areas().rows(*a)) {
            let s = c.reactions().stimulus(r);
            force[k] += s.force.iter().sum::<f64>();
            proximity[k] = proximity[k].max(s.proximity);
        }
    }
    let scene = rig.scene.get();
    let object_gap_m = scene.objects().first().map(|p| gap_to_chest_m(p, scene.skin().surface_offset_m));
    TraceRow {
        time_s,
        state: c.state().expect("grasp mode"),
        joints_rad: rig.robot.positions(),
        force,
        proximity,
        object_gap_m,
    }
}

/// Writes each run's trace as `<object>.csv` and `<object>.svg` into `dir`
/// (created if missing) and returns the files written.
pub fn write_traces(dir: &Path, runs: &[GraspRun]) -> Result<Vec<PathBuf>, GraspError> {
    let fail = |path: &Path, e: &dyn std::fmt::Display| GraspError::Write {
        path: path.display().to_string(),
        message: e.to_string(),
    };
    std::fs::create_dir_all(dir).map_err(|e| fail(dir, &e))?;
    let mut files = Vec::new();
    for run in runs {
        let csv = dir.join(format!("grasp_{}.csv", run.object));
        std::fs::write(&csv, trace_csv(run)).map_err(|e| fail(&csv, &e))?;
        files.push(csv);
        let svg = dir.join(format!("grasp_{}.svg", run.object));
        plot(run, &svg).map_err(|e| fail(&svg, &e))?;
        files.push(svg);
    }
    Ok(files)
}

fn trace_csv(run: &GraspRun) -> String {
    let dofs = run.trace.first().map_or(0, |r| r.joints_rad.len());
    let mut s = String::from("time_s,state");
    for d in 0..dofs {
        let _ = write!(s, ",q{d}_rad");
    }
    s.push_str(",force_right,force_left,force_chest,proximity_right,proximity_left,proximity_chest,object_gap_m\n");
    for r in &run.trace {
        let _ = write!(s, "{:.3},{}", r.time_s, r.state.name());
        for q in &r.joints_rad {
            let _ = write!(s, ",{q:.4}");
        }
        for v in r.force.iter().chain(&r.proximity) {
            let _ = write!(s, ",{v:.4}");
        }
        let _ = writeln!(s, ",{}", r.object_gap_m.map_or(String::new(), |g| format!("{g:.4}")));
    }
    s
}

/// Figure 18: joints, forces and proximity against time, with the states.
fn plot(run: &GraspRun, path: &Path) -> Result<(), Box<dyn std::error::Error>> {
    use plotters::prelude::*;
    let root = SVGBackend::new(path, (900, 720)).into_drawing_area();
    root.fill(&WHITE)?;
    let panels = root.split_evenly((3, 1));
    let end = run.trace.last().map_or(1.0, |r| r.time_s).max(1.0);
    let names = ["right arm", "left arm", "chest"];
    let colours = [RED, BLUE, BLACK];
    // Shoulder pitch and elbow of both arms (DoFs 0, 3, 7, 10 of the built-in robot).
    let joints = [(0, "right shoulder pitch"), (3, "right elbow"), (7, "left shoulder pitch"), (10, "left elbow")];
    type Series<'a> = Vec<(String, RGBColor, Vec<(f64, f64)>)>;
    let mut series: [Series<'_>; 3] = [Vec::new(), Vec::new(), Vec::new()];
    for (k, (d, name)) in joints.into_iter().enumerate() {
        let c = [RED, MAGENTA, BLUE, CYAN][k];
        series[0].push((
            name.to_owned(),
            c,
            run.trace.iter().filter_map(|r| r.joints_rad.get(d).map(|q| (r.time_s, *q))).collect(),
        ));
    }
    for (k, name) in names.into_iter().enumerate() {
        series[1].push((name.to_owned(), colours[k], run.trace.iter().map(|r| (r.time_s, r.force[k])).collect()));
        series[2].push((name.to_owned(), colours[k], run.trace.iter().map(|r| (r.time_s, r.proximity[k])).collect()));
    }
    let titles = [
        format!("{}: joint positions (rad)", run.object),
        "force: summed normalized readings".to_owned(),
        "pre-contact: highest proximity intensity".to_owned(),
    ];
    for ((panel, lines), title) in panels.iter().zip(&series).zip(titles) {
        let (lo, hi) =
            lines.iter().flat_map(|l| l.2.iter().map(|p| p.1)).fold((0.0f64, 0.0f64), |(a, b), v| (a.min(v), b.max(v)));
        let hi = if hi - lo < 1e-6 { lo + 1.0 } else { hi + 0.05 * (hi - lo) };
        let mut chart = ChartBuilder::on(panel)
            .caption(title, ("sans-serif", 16))
            .margin(8)
            .x_label_area_size(28)
            .y_label_area_size(48)
            .build_cartesian_2d(0.0..end, lo..hi)?;
        chart.configure_mesh().x_desc("time after the launching pat (s)").light_line_style(WHITE).draw()?;
        for l in &run.state_log {
            chart.draw_series(LineSeries::new([(l.time_s, lo), (l.time_s, hi)], &RGBColor(180, 180, 180)))?;
            chart.draw_series([Text::new(l.state.name(), (l.time_s, hi), ("sans-serif", 11).into_font())])?;
        }
        for (name, colour, points) in lines {
            let colour = *colour;
            chart
                .draw_series(LineSeries::new(points.iter().copied(), &colour))?
                .label(name.as_str())
                .legend(move |(x, y)| PathElement::new([(x, y), (x + 16, y)], colour));
        }
        chart.configure_series_labels().background_style(WHITE.mix(0.8)).border_style(BLACK).draw()?;
    }
    root.present()?;
    Ok(())
}
