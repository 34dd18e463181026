//! Robot time against error of the skin calibration.
//!
//! For each setting (still postures, excitation periods, accelerometer
//! noise) this explores and calibrates `SKIN_BENCH_SEEDS` seeds (default 5)
//! of the built-in HRP-2-like robot and prints the calibration's robot
//! time, its wall time, and the position and frame errors against the
//! simulator's truth. Then the published setting: a Panda arm with one cell
//! on each of links 2-7 (and one on the base, the exploration's root, and
//! one on a finger, which the exploration needs to see the finger DoF),
//! without noise and with the datasheet's, beside the Panda with 4 cells on
//! every link. Criterion then times one calibration.
//! `cargo bench -p skin-host --bench calibrate`.

use std::hint::black_box;
use std::path::Path;
use std::time::Instant;

use criterion::{criterion_group, criterion_main, Criterion};
use skin_host::calibrate::check::{check, CalibrationTruth};
use skin_host::calibrate::{calibrate, CalibrateConfig};
use skin_host::explore::{explore, ExploreConfig, StructureConfig};
use skin_host::robot::SimRobot;
use skin_model::robot::{hrp2, Robot};
use skin_model::skin::Skin;
use skin_sim::accel::Bma250Config;
use skin_sim::world::{World, WorldConfig};

/// One exploration and calibration: the truth, the calibration's robot time and wall time.
fn once(
    robot: &Robot,
    skin: Skin,
    accel: Bma250Config,
    seed: u64,
    cfg: CalibrateConfig,
) -> (CalibrationTruth, f64, f64) {
    let clearance = skin.min_axis_clearance_m().min(0.02) * 0.9;
    let world = World::new(robot.clone(), skin, WorldConfig { accel, seed, ..WorldConfig::default() });
    let mut rig = SimRobot::new(world);
    let explore_cfg = ExploreConfig {
        structure: StructureConfig { axis_clearance_m: clearance, ..StructureConfig::default() },
        ..ExploreConfig::default()
    };
    let found = explore(&mut rig, &explore_cfg, &mut |_| {}).expect("explored");
    let wall = Instant::now();
    let c = calibrate(&mut rig, robot, &found, &CalibrateConfig { seed, ..cfg }, &mut |_| {}).expect("calibrated");
    let wall_s = wall.elapsed().as_secs_f64();
    (check(&c, rig.world()), c.robot_time_s, wall_s)
}

fn seeds() -> u64 {
    std::env::var("SKIN_BENCH_SEEDS").ok().and_then(|s| s.parse().ok()).unwrap_or(5)
}

/// Prints one row: the means over seeds and the worst p95 and max.
fn row(label: &str, runs: &[(CalibrationTruth, f64, f64)]) {
    let n = runs.len() as f64;
    let mean = |f: &dyn Fn(&(CalibrationTruth, f64, f64)) -> f64| runs.iter().map(f).sum::<f64>() / n;
    let worst = |f: &dyn Fn(&(CalibrationTruth, f64, f64)) -> f64| runs.iter().map(f).fold(0.0, f64::max);
    println!(
        "{label:<44} {:>7.1} {:>7.2} {:>6} {:>7.2} {:>7.2} {:>7.2} {:>7.2} {:>7.2} {:>6}",
        mean(&|r| r.1),
        mean(&|r| r.2),
        runs.iter().map(|r| r.0.position_m.cells).sum::<usize>() / runs.len(),
        mean(&|r| r.0.position_m.mean * 1e3),
        worst(&|r| r.0.position_m.p95 * 1e3),
        worst(&|r| r.0.position_m.max * 1e3),
        mean(&|r| r.0.orientation_deg.mean),
        worst(&|r| r.0.orientation_deg.max),
        runs.iter().map(|r| r.0.wrong_link).sum::<usize>(),
    );
}

fn header(title: &str) {
    println!("\n{title}");
    println!(
        "{:<44} {:>7} {:>7} {:>6} {:>7} {:>7} {:>7} {:>7} {:>7} {:>6}",
        "setting", "robot s", "wall s", "cells", "mean mm", "p95 mm", "max mm", "mean °", "max °", "wrong"
    );
}

fn sweep() {
    let robot = hrp2::robot();
    let seeds = seeds();
    header(&format!("HRP-2-like robot, 74 cells, {seeds} seeds (position errors over cells with an observable part)"));
    let settings: Vec<(String, f64, CalibrateConfig)> = [(6, 1), (6, 3), (12, 1), (12, 3), (24, 3), (12, 6)]
        .into_iter()
        .map(|(postures, periods)| {
            let cfg = CalibrateConfig { postures, excitation_periods: periods, ..CalibrateConfig::default() };
            (format!("{postures} postures, {periods} periods, noise x1"), 1.0, cfg)
        })
        .chain(
            [3.0, 10.0]
                .into_iter()
                .map(|noise| (format!("12 postures, 3 periods, noise x{noise}"), noise, CalibrateConfig::default())),
        )
        .collect();
    for (label, noise, cfg) in settings {
        let runs: Vec<_> = (0..seeds)
            .map(|seed| {
                let skin = Skin::with_counts(&robot, &hrp2::SKIN, seed).unwrap();
                once(&robot, skin, Bma250Config::default().with_noise_scale(noise), seed, cfg)
            })
            .collect();
        row(&label, &runs);
    }

    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../model/tests/fixtures/robots/panda.urdf");
    let panda = Robot::from_urdf_file(&path).expect("the Panda fixture");
    header(&format!("Panda (the published setting), {seeds} seeds"));
    // The exploration needs a cell on the base (its root) and one moved by the finger DoF.
    let six: Vec<(&str, usize)> = [
        "panda_link0",
        "panda_link2",
        "panda_link3",
        "panda_link4",
        "panda_link5",
        "panda_link6",
        "panda_link7",
        "panda_leftfinger",
    ]
    .into_iter()
    .map(|l| (l, 1))
    .collect();
    let no_noise = Bma250Config::default().with_noise_scale(0.0);
    let cases: [(&str, Bma250Config, bool); 3] = [
        ("6 cells, no noise (offsets, gains, tilt kept)", no_noise, true),
        ("6 cells, datasheet noise and errors", Bma250Config::default(), true),
        ("4 cells per link, datasheet noise and errors", Bma250Config::default(), false),
    ];
    for (label, accel, published) in cases {
        let runs: Vec<_> = (0..seeds)
            .map(|seed| {
                let skin = if published {
                    Skin::with_counts(&panda, &six, seed).unwrap()
                } else {
                    Skin::per_link(&panda, 4, seed).unwrap()
                };
                once(&panda, skin, accel, seed, CalibrateConfig::default())
            })
            .collect();
        row(label, &runs);
    }
}

fn bench(c: &mut Criterion) {
    sweep();
    let robot = hrp2::robot();
    c.bench_function("explore and calibrate the HRP-2-like robot (74 cells)", |b| {
        b.iter(|| {
            let skin = Skin::with_counts(&robot, &hrp2::SKIN, 0).unwrap();
            black_box(once(&robot, skin, Bma250Config::default(), 0, CalibrateConfig::default()))
        })
    });
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(10);
    targets = bench
}
criterion_main!(benches);
