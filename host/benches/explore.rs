//! Run time against error of the structural exploration on the built-in
//! HRP-2-like robot (14 DoF, 74 cells, BMA250 noise).
//!
//! For each setting of step size, settling and averaging windows, this
//! explores `SKIN_BENCH_SEEDS` seeds (default 200) and prints the robot time
//! (mean and worst), the wall time per exploration, the tree error rate and
//! the sensory-motor map error; criterion then times one exploration per
//! setting. `cargo bench -p skin-host --bench explore`.

use std::hint::black_box;

use criterion::{criterion_group, criterion_main, Criterion};
use skin_host::explore::check::Trial;
use skin_host::explore::{ExploreConfig, StructureConfig};
use skin_sim::robot::hrp2;

/// The swept settings: (step rad, settle s, average s, postural runs).
const SETTINGS: [(f64, f64, f64, usize); 10] = [
    (0.1, 0.5, 1.0, 2),
    (0.1, 0.5, 1.0, 1),
    (0.1, 0.2, 0.5, 1),
    (0.1, 0.1, 0.3, 1),
    (0.1, 0.1, 0.2, 1),
    (0.1, 0.05, 0.1, 1),
    (0.2, 0.1, 0.2, 1),
    (0.2, 0.05, 0.1, 1),
    (0.05, 0.1, 0.3, 1),
    (0.05, 0.2, 0.5, 1),
];

fn config(&(step_rad, settle_s, average_s, runs): &(f64, f64, f64, usize)) -> ExploreConfig {
    let structure = StructureConfig { step_rad, settle_s, average_s, runs, ..StructureConfig::default() };
    ExploreConfig { structure, ..ExploreConfig::default() }
}

fn sweep(c: &mut Criterion) {
    let seeds: u64 = std::env::var("SKIN_BENCH_SEEDS").ok().and_then(|s| s.parse().ok()).unwrap_or(200);
    println!(
        "{:>6} {:>7} {:>7} {:>4} | {:>13} {:>13} {:>9} | {:>10} {:>9}",
        "step", "settle", "average", "runs", "robot s mean", "robot s worst", "wall ms", "tree error", "smm error"
    );
    for setting in &SETTINGS {
        let cfg = config(setting);
        let (mut time, mut worst, mut wall, mut wrong, mut smm, mut ok) = (0.0, 0.0f64, 0.0, 0usize, 0.0, 0u32);
        for seed in 0..seeds {
            let trial = Trial::run(hrp2::world(seed), &cfg);
            wall += trial.wall_time_s;
            match &trial.outcome {
                Ok((found, truth)) => {
                    time += found.structure_time_s;
                    worst = worst.max(found.structure_time_s);
                    smm += truth.smm_mean_abs_error_moved;
                    ok += 1;
                    wrong += usize::from(!truth.tree_correct);
                }
                Err(_) => wrong += 1,
            }
        }
        let (step, settle, average, runs) = setting;
        println!(
            "{step:>6.2} {settle:>7.2} {average:>7.2} {runs:>4} | {:>13.2} {worst:>13.2} {:>9.1} | {:>4}/{seeds:<5} {:>9.3}",
            time / f64::from(ok.max(1)),
            1e3 * wall / seeds as f64,
            wrong,
            smm / f64::from(ok.max(1)),
        );
        c.bench_function(&format!("explore step {step} settle {settle} average {average} runs {runs}"), |b| {
            b.iter(|| black_box(Trial::run(hrp2::world(0), &cfg).tree_correct()))
        });
    }
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(10);
    targets = sweep
}
criterion_main!(benches);
