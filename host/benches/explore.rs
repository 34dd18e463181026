//! Run time against error of the structural exploration on the built-in
//! HRP-2-like robot (14 DoF, 74 cells, BMA250 noise).
//!
//! For each setting of step size, settling and averaging windows, this
//! explores `SKIN_BENCH_SEEDS` seeds (default 200) and prints the robot time
//! (mean and worst), the wall time per exploration, the tree error rate and
//! the sensory-motor map error; criterion then times one exploration per
//! setting. Then a noise sweep: the default setting at 1, 3, 10 and 30
//! times the datasheet's accelerometer noise over `SKIN_BENCH_NOISE_SEEDS`
//! seeds (default 20), robot time and wrong trees against noise. Last, the
//! smallest lever decided: a UR5 on a rigid base, whose first axis is
//! vertical and untiltable, at 1, 3 and 10 times the noise over
//! `SKIN_BENCH_LEVER_SEEDS` seeds (default 5): the smallest lever the
//! evidence decides near that axis (a lever this large or larger would
//! have been decided at every entry there) and the lever bound the pooled
//! steps reached on the cells the default clearance then settles, against
//! robot time. `cargo bench -p skin-host --bench explore`.

use std::hint::black_box;

use criterion::{criterion_group, criterion_main, Criterion};
use skin_host::explore::check::Trial;
use skin_host::explore::{ExploreConfig, StructureConfig};
use skin_model::robot::hrp2;
use skin_model::skin::Skin;
use skin_sim::accel::Bma250Config;
use skin_sim::world::{BaseConfig, World, WorldConfig};

/// The paper's setting, then the sweep of (step rad, settle s, average s)
/// with one postural run and the default 0.2 s per step.
fn settings() -> Vec<StructureConfig> {
    let sweep = [
        (0.1, 0.5, 1.0),
        (0.1, 0.2, 0.5),
        (0.1, 0.1, 0.3),
        (0.1, 0.1, 0.2),
        (0.1, 0.05, 0.1),
        (0.2, 0.1, 0.2),
        (0.2, 0.05, 0.1),
        (0.2, 0.0, 0.1),
        (0.2, 0.05, 0.05),
        (0.3, 0.05, 0.1),
        (0.3, 0.0, 0.05),
    ];
    std::iter::once(StructureConfig::paper())
        .chain(sweep.into_iter().map(|(step_rad, settle_s, average_s)| StructureConfig {
            step_rad,
            settle_s,
            average_s,
            runs: 1,
            ..StructureConfig::default()
        }))
        .collect()
}

/// What `seeds` explorations with one setting gave.
#[derive(Default)]
struct Tally {
    /// Robot time of the structural exploration, summed and worst, s.
    time_s: f64,
    worst_s: f64,
    /// Wall time, summed, s.
    wall_s: f64,
    /// Trees returned that are wrong.
    wrong: usize,
    /// Explorations that ended with a diagnostic.
    failed: usize,
    /// Sensory-motor map error over moved entries, summed.
    smm: f64,
    /// Largest lever bound reached on the entries assumed, summed and worst, m.
    lever_m: f64,
    worst_lever_m: f64,
    /// The smallest lever decided near an axis, summed and worst, m.
    smallest_m: f64,
    worst_smallest_m: f64,
    ok: u32,
}

impl Tally {
    /// Counts one exploration in.
    fn add(&mut self, trial: &Trial) {
        self.wall_s += trial.wall_time_s;
        match &trial.outcome {
            Ok((found, truth)) => {
                self.time_s += found.structure_time_s;
                self.worst_s = self.worst_s.max(found.structure_time_s);
                self.smm += truth.smm_mean_abs_error_moved;
                let reached = found.assumed.iter().map(|a| a.lever_bound_m).fold(0.0, f64::max);
                self.lever_m += reached;
                self.worst_lever_m = self.worst_lever_m.max(reached);
                let smallest = found.levers.smallest_decided_m().unwrap_or(0.0);
                self.smallest_m += smallest;
                self.worst_smallest_m = self.worst_smallest_m.max(smallest);
                self.ok += 1;
                self.wrong += usize::from(!truth.tree_correct);
            }
            Err(_) => self.failed += 1,
        }
    }
}

fn sweep(c: &mut Criterion) {
    let seeds: u64 = std::env::var("SKIN_BENCH_SEEDS").ok().and_then(|s| s.parse().ok()).unwrap_or(200);
    println!(
        "{:>5} {:>6} {:>7} {:>4} | {:>12} {:>13} {:>8} | {:>10} {:>10} {:>9}",
        "step",
        "settle",
        "average",
        "runs",
        "robot s mean",
        "robot s worst",
        "wall ms",
        "wrong tree",
        "diagnostic",
        "smm error"
    );
    for structure in settings() {
        let cfg = ExploreConfig { structure, ..ExploreConfig::default() };
        let mut t = Tally::default();
        for seed in 0..seeds {
            t.add(&Trial::run(World::hrp2(seed), &cfg));
        }
        let StructureConfig { step_rad: step, settle_s: settle, average_s: average, runs, .. } = structure;
        let ok = f64::from(t.ok.max(1));
        println!(
            "{step:>5.2} {settle:>6.2} {average:>7.2} {runs:>4} | {:>12.2} {:>13.2} {:>8.1} | {:>4}/{seeds:<5} {:>4}/{seeds:<5} {:>9.3}",
            t.time_s / ok,
            t.worst_s,
            1e3 * t.wall_s / seeds as f64,
            t.wrong,
            t.failed,
            t.smm / ok,
        );
        c.bench_function(&format!("explore step {step} settle {settle} average {average} runs {runs}"), |b| {
            b.iter(|| black_box(Trial::run(World::hrp2(0), &cfg).tree_correct()))
        });
    }
}

/// The built-in robot and skin with `scale` times the datasheet's noise.
fn noisy_world(seed: u64, scale: f64) -> World {
    let robot = hrp2::robot();
    let skin = Skin::with_counts(&robot, &hrp2::SKIN, seed).expect("the built-in skin fits");
    let accel = Bma250Config::default().with_noise_scale(scale);
    World::new(robot, skin, WorldConfig { accel, seed, ..WorldConfig::default() })
}

fn noise_sweep(c: &mut Criterion) {
    let seeds: u64 = std::env::var("SKIN_BENCH_NOISE_SEEDS").ok().and_then(|s| s.parse().ok()).unwrap_or(20);
    println!(
        "\n{:>5} | {:>12} {:>13} {:>8} | {:>10} {:>10}",
        "noise", "robot s mean", "robot s worst", "wall ms", "wrong tree", "diagnostic"
    );
    let cfg = ExploreConfig::default();
    for scale in [1.0, 3.0, 10.0, 30.0] {
        let mut t = Tally::default();
        for seed in 0..seeds {
            t.add(&Trial::run(noisy_world(seed, scale), &cfg));
        }
        println!(
            "{scale:>5} | {:>12.2} {:>13.2} {:>8.1} | {:>4}/{seeds:<5} {:>4}/{seeds:<5}",
            t.time_s / f64::from(t.ok.max(1)),
            t.worst_s,
            1e3 * t.wall_s / seeds as f64,
            t.wrong,
            t.failed,
        );
        c.bench_function(&format!("explore at {scale} x datasheet noise"), |b| {
            b.iter(|| black_box(Trial::run(noisy_world(0, scale), &cfg).tree_correct()))
        });
    }
}

/// The UR5 of the simulator's fixtures on a rigid base, four cells a link,
/// `scale` times the datasheet's noise.
fn ur5_world(seed: u64, scale: f64) -> World {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../model/tests/fixtures/robots/ur5_robot.urdf");
    let robot = skin_model::robot::Robot::from_urdf_file(&path).expect("the fixture reads");
    let skin = Skin::per_link(&robot, 4, seed).expect("the skin fits");
    let accel = Bma250Config::default().with_noise_scale(scale);
    World::new(robot, skin, WorldConfig { accel, seed, base: BaseConfig::rigid(), ..WorldConfig::default() })
}

fn lever_sweep(c: &mut Criterion) {
    let seeds: u64 = std::env::var("SKIN_BENCH_LEVER_SEEDS").ok().and_then(|s| s.parse().ok()).unwrap_or(5);
    println!(
        "\n{:>5} | {:>12} {:>13} | {:>17} {:>18} | {:>14} {:>15} | {:>10} {:>10}",
        "noise",
        "robot s mean",
        "robot s worst",
        "smallest mm mean",
        "smallest mm worst",
        "bound mm mean",
        "bound mm worst",
        "wrong tree",
        "diagnostic"
    );
    let cfg = ExploreConfig::default();
    for scale in [1.0, 3.0, 10.0] {
        let mut t = Tally::default();
        for seed in 0..seeds {
            t.add(&Trial::run(ur5_world(seed, scale), &cfg));
        }
        let ok = f64::from(t.ok.max(1));
        println!(
            "{scale:>5} | {:>12.2} {:>13.2} | {:>17.3} {:>18.3} | {:>14.3} {:>15.3} | {:>4}/{seeds:<5} {:>4}/{seeds:<5}",
            t.time_s / ok,
            t.worst_s,
            1e3 * t.smallest_m / ok,
            1e3 * t.worst_smallest_m,
            1e3 * t.lever_m / ok,
            1e3 * t.worst_lever_m,
            t.wrong,
            t.failed,
        );
        c.bench_function(&format!("explore a rigid UR5 at {scale} x datasheet noise"), |b| {
            b.iter(|| black_box(Trial::run(ur5_world(0, scale), &cfg).tree_correct()))
        });
    }
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(10);
    targets = sweep, noise_sweep, lever_sweep
}
criterion_main!(benches);
