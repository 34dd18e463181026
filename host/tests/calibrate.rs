//! Skin self-calibration against the simulator's truth: the built-in robot
//! and descriptions written by others, datasheet noise and worse, and the
//! files it writes read back by the readers that will use them.

use std::path::Path;

use skin_host::calibrate::check::{check, CalibrationTruth};
use skin_host::calibrate::export::{skin_toml, urdf_with_skin};
use skin_host::calibrate::neighbours::{resolve, NeighbourConfig};
use skin_host::calibrate::{calibrate, CalibrateConfig, CalibrateError, Calibration};
use skin_host::explore::{explore, ExploreConfig, StructureConfig};
use skin_host::robot::SimRobot;
use skin_model::robot::{hrp2, Robot};
use skin_model::skin::Skin;
use skin_sim::accel::Bma250Config;
use skin_sim::world::{BaseConfig, World, WorldConfig};

fn fixture(name: &str) -> Robot {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../model/tests/fixtures/robots").join(name);
    Robot::from_urdf_file(&path).expect("a valid fixture")
}

/// Explores and calibrates `robot` standing, with `noise` times the
/// datasheet noise; the declared mounting clearance is the truth's own
/// (never more), so the exploration can settle cells by it honestly.
fn run(robot: Robot, skin: Skin, noise: f64, seed: u64, cfg: CalibrateConfig) -> (Calibration, CalibrationTruth) {
    let clearance = skin.min_axis_clearance_m().min(0.02) * 0.9;
    run_declaring(robot, skin, noise, seed, cfg, clearance)
}

/// As [`run`], the user declaring `clearance`, m.
fn run_declaring(
    robot: Robot,
    skin: Skin,
    noise: f64,
    seed: u64,
    cfg: CalibrateConfig,
    clearance: f64,
) -> (Calibration, CalibrationTruth) {
    let world = World::new(
        robot.clone(),
        skin,
        WorldConfig { accel: Bma250Config::default().with_noise_scale(noise), seed, ..WorldConfig::default() },
    );
    let mut rig = SimRobot::new(world);
    let explore_cfg = ExploreConfig {
        structure: StructureConfig { axis_clearance_m: clearance, ..StructureConfig::default() },
        ..ExploreConfig::default()
    };
    let found = explore(&mut rig, &explore_cfg, &mut |_| {}).expect("the exploration succeeds");
    let c = calibrate(&mut rig, &robot, &found, &CalibrateConfig { seed, ..cfg }, &mut |_| {}).expect("calibrated");
    let t = check(&c, rig.world());
    (c, t)
}

fn hrp2_run(noise: f64, seed: u64, cfg: CalibrateConfig) -> (Calibration, CalibrationTruth) {
    let robot = hrp2::robot();
    let skin = Skin::with_counts(&robot, &hrp2::SKIN, seed).unwrap();
    run(robot, skin, noise, seed, cfg)
}

fn assert_goals(name: &str, t: &CalibrationTruth) {
    assert_eq!(t.wrong_link, 0, "{name}: {t:?}");
    assert_eq!(t.unknown_cells, 0, "{name}: {t:?}");
    assert_eq!(t.overconfident, 0, "{name}: {t:?}");
    assert!(t.position_m.cells > 0 && t.orientation_deg.cells > 0, "{name}: {t:?}");
    assert!(t.position_m.mean <= 0.005 && t.position_m.p95 <= 0.010, "{name}: {:?}", t.position_m);
    assert!(t.orientation_deg.mean <= 2.0, "{name}: {:?}", t.orientation_deg);
}

fn assert_finite(c: &Calibration) {
    for p in &c.cells {
        assert!(p.position.iter().chain(p.frame.matrix().iter()).all(|x| x.is_finite()), "cell {}", p.id.0);
        assert!(p.gain.iter().chain(p.offset_mps2.iter()).all(|x| x.is_finite()), "cell {}", p.id.0);
        assert!(!p.orientation_sigma_rad.is_nan() && p.position_sigma_m.iter().all(|s| !s.is_nan()));
    }
}

#[test]
fn the_built_in_robot_meets_the_goals_with_datasheet_noise() {
    let (c, t) = hrp2_run(1.0, 0, CalibrateConfig::default());
    assert_goals("hrp2", &t);
    assert_finite(&c);
    // The 14 chest cells are on the fixed base: nothing moves them, so
    // nothing about their place is claimed.
    let chest: Vec<_> = c.cells.iter().filter(|p| p.link == "CHEST").collect();
    assert_eq!(chest.len(), 14);
    assert!(chest.iter().all(|p| p.observable() == [false; 3] && !p.orientation_observable));
    assert_eq!(t.position_unobservable, 14);
    // Sensor errors are estimated, not assumed away: offsets of up to 60 mg
    // come out within 10 mg wherever gravity turns the cell.
    assert!(t.offset_error_max_mps2 < 0.1, "{t:?}");
    assert!(c.warnings.is_empty(), "{:?}", c.warnings);
}

#[test]
fn a_skin_wired_across_the_shoulders_places_the_shoulder_cells_in_3d() {
    // Laid in patches of 20 cells per link, the shoulder links' cells (one
    // joint from the chest: blind along its axis) are wired to each other
    // and to the upper arms' cells, which the motion places in 3D. Each
    // wire across the joint leaves its step's sign open; together with the
    // patch's own wires they settle it for one shoulder.
    let robot = hrp2::robot();
    let seed = 3;
    let skin = Skin::patches(&robot, |_| 20, seed).unwrap();
    let tables = skin.neighbour_tables();
    let world = World::new(robot.clone(), skin, WorldConfig { seed, ..WorldConfig::default() });
    let mut rig = SimRobot::new(world);
    let explore_cfg = ExploreConfig {
        structure: StructureConfig { axis_clearance_m: 0.01, ..StructureConfig::default() },
        ..ExploreConfig::default()
    };
    let found = explore(&mut rig, &explore_cfg, &mut |_| {}).expect("the exploration succeeds");
    let cfg = CalibrateConfig { seed, ..CalibrateConfig::default() };
    let mut c = calibrate(&mut rig, &robot, &found, &cfg, &mut |_| {}).expect("calibrated");
    let partial = |c: &Calibration| c.cells.iter().filter(|p| p.unobservable.len() == 1).count();
    assert_eq!(partial(&c), 40, "20 cells on each shoulder link");
    let r = resolve(&mut c.cells, &robot, &c.description_start, &tables, &NeighbourConfig::default());
    let t = check(&c, rig.world());
    assert!(r.cells >= 20 && partial(&c) == 40 - r.cells, "{r:?}");
    assert!(c.cells.iter().filter(|p| !p.from_neighbours.is_empty()).all(|p| p.link.ends_with("LINK0")));
    assert_eq!(t.from_neighbours_m.cells, r.cells);
    // The goals for the cells placed so, never confidently wrong.
    assert!(t.from_neighbours_m.mean <= 0.005 && t.from_neighbours_m.p95 <= 0.010, "{:?}", t.from_neighbours_m);
    assert_goals("hrp2 in patches", &t);
}

#[test]
fn descriptions_written_by_others_meet_the_goals() {
    for name in ["ur5_robot.urdf", "panda.urdf"] {
        let robot = fixture(name);
        let skin = Skin::per_link(&robot, 4, 1).unwrap();
        let (c, t) = run(robot, skin, 1.0, 1, CalibrateConfig::default());
        assert_goals(name, &t);
        assert_finite(&c);
    }
    // A wrist link that gravity meets in one plane only leaves its cells'
    // gains 1-2 % loose; read through them a 2 g swing once put a cell
    // 16 mm off where 1.2 mm was claimed.
    let robot = fixture("ur5_robot.urdf");
    let skin = Skin::per_link(&robot, 4, 1).unwrap();
    let (_, t) = run_declaring(robot, skin, 1.0, 1, CalibrateConfig::default(), 0.01);
    assert_goals("ur5_robot.urdf, 1 cm declared", &t);
    assert!(t.position_m.max < 0.006, "{:?}", t.position_m);
}

#[test]
fn mimic_fingers_are_told_apart_by_their_motion() {
    // The Panda's fingers slide apart on one DoF: gravity sees them alike,
    // the slide does not.
    let robot = fixture("panda.urdf");
    let skin =
        Skin::with_counts(&robot, &[("panda_link0", 3), ("panda_leftfinger", 3), ("panda_rightfinger", 3)], 2).unwrap();
    let (c, t) = run(robot, skin, 1.0, 2, CalibrateConfig::default());
    assert_eq!(t.wrong_link, 0, "{t:?}");
    assert!(c.cells.iter().all(|p| p.ambiguous_with.is_empty()), "{:?}", c.warnings);
}

#[test]
fn ten_times_the_noise_widens_the_uncertainty_and_never_claims_a_wrong_pose() {
    let quiet = hrp2_run(1.0, 3, CalibrateConfig::default());
    let loud = hrp2_run(10.0, 3, CalibrateConfig::default());
    assert_finite(&loud.0);
    // Frames that gravity shows (not the chest's): their spread grows with
    // the noise (less where the sensor priors carry part of the answer).
    let mut ratios: Vec<f64> = quiet
        .0
        .cells
        .iter()
        .zip(&loud.0.cells)
        .filter(|(q, _)| q.orientation_observable)
        .map(|(q, l)| l.orientation_sigma_rad / q.orientation_sigma_rad)
        .collect();
    ratios.sort_by(f64::total_cmp);
    assert!(ratios[0] > 1.2 && ratios[ratios.len() / 2] > 2.0, "{ratios:?}");
    // Positions: wider where still claimed, and fewer claimed.
    let (mut claimed, mut wider, mut both) = ([0, 0], 0, 0);
    for (q, l) in quiet.0.cells.iter().zip(&loud.0.cells) {
        for k in 0..3 {
            let (qs, ls) = (q.position_sigma_m[k], l.position_sigma_m[k]);
            claimed[0] += usize::from(qs.is_finite());
            claimed[1] += usize::from(ls.is_finite());
            if qs.is_finite() && ls.is_finite() {
                both += 1;
                wider += usize::from(ls > 2.0 * qs);
            }
        }
    }
    assert!(claimed[1] <= claimed[0] && both > 0 && wider * 10 >= both * 9, "{claimed:?} {wider}/{both}");
    assert_eq!(loud.1.wrong_link, 0);
    assert!(loud.1.position_m.max <= 0.02, "{:?}", loud.1.position_m);
}

#[test]
fn saturating_excitations_lose_samples_not_accuracy() {
    // Four times the usual excitation drives far cells past +-2 g; the
    // readings on the rails are left out.
    let cfg =
        CalibrateConfig { excitation_accel_mps2: 20.0, excitation_amplitude_rad: 1.2, ..CalibrateConfig::default() };
    let (c, t) = hrp2_run(1.0, 4, cfg);
    assert_finite(&c);
    assert_goals("hrp2 saturating", &t);
}

#[test]
fn the_skin_file_and_the_urdf_read_back() {
    let (c, _) = hrp2_run(1.0, 5, CalibrateConfig::default());
    let robot = hrp2::robot();
    // The skin file is the simulator's own format, IDs kept.
    let skin = Skin::from_toml_str(&robot, &skin_toml(&robot, &c)).expect("the skin file reads back");
    assert_eq!(skin.cells().len(), c.cells.len());
    for p in &c.cells {
        let cell = skin.cells().iter().find(|s| s.id == p.id).expect("the ID is kept");
        assert_eq!(cell.link, p.link);
        assert!((cell.pose.translation.vector - p.position).norm() < 1e-5);
        assert!((cell.pose.rotation.to_rotation_matrix().inverse() * p.frame).angle() < 1e-5);
    }
    // The URDF with skin frames is still a URDF, with one fixed link per cell.
    let urdf = urdf_with_skin(&hrp2::urdf(), &robot, &c).unwrap();
    let with_skin = Robot::from_urdf_str(&urdf).expect("the URDF with skin frames reads");
    assert_eq!(with_skin.dofs().len(), robot.dofs().len());
    for p in &c.cells {
        let link = with_skin.link(&format!("skin_cell_{}", p.id.0)).expect("a link per cell");
        let parent = with_skin.link(&p.link).unwrap();
        assert_eq!(link.body, parent.body, "fixed to its link");
        assert!(((parent.in_body.inverse() * link.in_body).translation.vector - p.position).norm() < 1e-5);
    }
    // Writing twice is refused: the names are taken.
    assert!(urdf_with_skin(&urdf, &robot, &c).is_err());
}

#[test]
fn a_description_of_another_robot_is_refused_by_name() {
    let robot = hrp2::robot();
    let skin = Skin::with_counts(&robot, &hrp2::SKIN, 0).unwrap();
    let mut rig =
        SimRobot::new(World::new(robot, skin, WorldConfig { base: BaseConfig::rigid(), ..WorldConfig::default() }));
    let found = explore(&mut rig, &ExploreConfig::default(), &mut |_| {}).unwrap();
    let other = fixture("ur5_robot.urdf");
    match calibrate(&mut rig, &other, &found, &CalibrateConfig::default(), &mut |_| {}) {
        Err(CalibrateError::DofMismatch { missing, unused }) => {
            assert!(missing.contains(&"RARM_JOINT0".to_owned()) && unused.contains(&"shoulder_pan_joint".to_owned()));
        }
        other => panic!("expected a DoF mismatch, got {other:?}"),
    }
}

/// The built-in robot over many seeds (the 1000-seed run):
/// `cargo test --release -p skin-host --test calibrate -- --ignored`
/// (`SKIN_CALIBRATE_SEEDS` sets the count).
#[test]
#[ignore = "heavy: 1000 explorations and calibrations"]
fn the_built_in_robot_over_many_seeds() {
    let seeds: u64 = std::env::var("SKIN_CALIBRATE_SEEDS").ok().and_then(|s| s.parse().ok()).unwrap_or(1000);
    let (mut worst_mean, mut worst_p95, mut worst_frame, mut sum_mean) = (0.0f64, 0.0f64, 0.0f64, 0.0);
    for seed in 0..seeds {
        let (_, t) = hrp2_run(1.0, seed, CalibrateConfig::default());
        assert_goals(&format!("seed {seed}"), &t);
        worst_mean = worst_mean.max(t.position_m.mean);
        worst_p95 = worst_p95.max(t.position_m.p95);
        worst_frame = worst_frame.max(t.orientation_deg.mean);
        sum_mean += t.position_m.mean;
        if (seed + 1) % 100 == 0 {
            println!(
                "{} seeds met the goals; worst mean {:.2} mm, worst p95 {:.2} mm, worst frame mean {:.2} deg",
                seed + 1,
                worst_mean * 1e3,
                worst_p95 * 1e3,
                worst_frame
            );
        }
    }
    println!(
        "{seeds} seeds: position mean of means {:.2} mm, worst mean {:.2} mm, worst p95 {:.2} mm; worst frame mean {:.2} deg",
        sum_mean / seeds as f64 * 1e3,
        worst_mean * 1e3,
        worst_p95 * 1e3,
        worst_frame
    );
}

fn skin_cli(args: &[&str]) -> std::process::Output {
    std::process::Command::new(env!("CARGO_BIN_EXE_skin")).args(args).output().unwrap()
}

#[test]
fn skin_calibrate_writes_its_files_and_takes_its_own_skin_file_back() {
    let dir = std::env::temp_dir().join(format!("skin-calibrate-{}", std::process::id()));
    let out = skin_cli(&["calibrate", "--json", "--out", dir.to_str().unwrap()]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let first: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let cells = first["cells"].as_array().unwrap();
    assert_eq!(cells.len(), 74);
    for key in ["id", "link", "xyz", "rpy", "observable", "position_sigma_m", "orientation_sigma_deg"] {
        assert!(cells.iter().all(|c| !c[key].is_null()), "{key}");
    }
    assert!(first["robot_time_s"]["calibration"].as_f64().unwrap() > 10.0 && first["wall_time_s"].as_f64().is_some());
    let saved: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("calibration.json")).unwrap()).unwrap();
    assert_eq!(saved["cells"], first["cells"]);
    let svg = std::fs::read_to_string(dir.join("calibration.svg")).unwrap();
    assert!(svg.contains("<svg") && svg.len() > 10_000);
    assert!(std::fs::read_to_string(dir.join("robot_with_skin.urdf")).unwrap().contains("skin_cell_"));

    // The calibrated skin fed back into the simulator: the same IDs come out.
    let skin = dir.join("skin.toml");
    let out = skin_cli(&["calibrate", "--json", "--seed", "1", "--skin", skin.to_str().unwrap()]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let again: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let ids = |v: &serde_json::Value| {
        let mut ids: Vec<u64> = v["cells"].as_array().unwrap().iter().map(|c| c["id"].as_u64().unwrap()).collect();
        ids.sort_unstable();
        ids
    };
    assert_eq!(ids(&again), ids(&first));
    assert_eq!(again["truth"]["wrong_link"], 0);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn skin_calibrate_refuses_what_it_cannot_do_in_one_line() {
    for (args, says) in [
        (vec!["calibrate", "--base", "lying"], "upright"),
        (vec!["calibrate", "--postures", "1"], "at least 2 postures"),
        (vec!["calibrate", "--axis-clearance", "-1"], "--axis-clearance"),
        (vec!["calibrate", "--urdf", "/nonexistent.urdf"], "nonexistent"),
    ] {
        let out = skin_cli(&args);
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success() && err.contains(says), "{args:?}: {err}");
        assert_eq!(err.trim().lines().count(), 1, "{args:?}: {err}");
    }
}
