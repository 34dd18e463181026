//! Grasping objects nobody tuned the parameters for: generated objects,
//! grasped with the unchanged Table 4 parameters and judged by the
//! simulator's truth, in the built-in scene and (in a build with the
//! `mujoco` feature) in MuJoCo, side by side; and objects that cannot be
//! held (too wide for the arms, too heavy to pull) end without pain in
//! every world, and not held where gravity says what the arms carry.
//!
//! Seeded: the same objects and placements every run. Each world's 100
//! objects take about 10 min in release, so ignored:
//! `cargo test --release -p skin-host --features mujoco --test grasp_generalization -- --ignored --nocapture`.

use std::collections::BTreeMap;
use std::fmt::Write;
use std::path::Path;
use std::process::Command;
use std::time::Instant;

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use serde_json::Value;
use skin_model::robot::hrp2;
use skin_sim::scene::experiment::Setup;
use skin_sim::scene::generated::{object_file, placement_keys, Reach};
use skin_sim::scene::object_file::parse;
use skin_sim::scene::SkinModel;

/// Seed of the generated objects.
const OBJECT_SEED: u64 = 19;
/// Seed of their placements (`skin grasp --jitter`).
const PLACEMENT_SEED: u64 = 19;
/// How many objects.
const COUNT: usize = 100;
/// The generator's seeds for the side-by-side set, each drawing an equal
/// share of [`COUNT`] objects and their placements.
const SIDE_BY_SIDE_SEEDS: [u64; 4] = [1, 2, 3, 4];

/// The worlds the experiment runs in, with the flags that choose them.
fn worlds() -> Vec<(&'static str, &'static [&'static str])> {
    let mut worlds: Vec<(&'static str, &'static [&'static str])> = vec![("built-in", &[])];
    if cfg!(feature = "mujoco") {
        worlds.push(("MuJoCo", &["--mujoco"]));
    }
    worlds
}

/// `skin grasp --json` on every object file of `dir`, placed by `args`,
/// and the wall time it took, s.
fn grasp_folder(dir: &Path, args: &[&str]) -> (Vec<Value>, f64) {
    let started = Instant::now();
    let out = Command::new(env!("CARGO_BIN_EXE_skin"))
        .args(["grasp", "--json", "--object-file"])
        .arg(dir)
        .args(args)
        .output()
        .expect("the skin binary runs");
    let runs: Value =
        serde_json::from_slice(&out.stdout).unwrap_or_else(|e| panic!("{e}: {}", String::from_utf8_lossy(&out.stderr)));
    (runs.as_array().expect("an array").clone(), started.elapsed().as_secs_f64())
}

/// The object files of `dir` grasped in each world.
fn in_every_world(dir: &Path) -> Vec<Column<'static>> {
    worlds()
        .into_iter()
        .map(|(world, flags)| {
            let (runs, wall_s) = grasp_folder(dir, flags);
            Column { world, runs, wall_s }
        })
        .collect()
}

fn scratch(name: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("skin-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// "median / max" of `v`, or "-" when it is empty.
fn spread(mut v: Vec<f64>, digits: usize) -> String {
    v.sort_by(f64::total_cmp);
    match (v.get(v.len() / 2), v.last()) {
        (Some(median), Some(max)) => format!("{median:.digits$} / {max:.digits$}"),
        _ => "-".to_owned(),
    }
}

/// The grasps of one world: its name, the runs, the wall time of the
/// whole `skin grasp` (exploration and teaching included), s.
struct Column<'a> {
    world: &'a str,
    runs: Vec<Value>,
    wall_s: f64,
}

/// How many of `runs` failed for `reason`.
fn failed_for(runs: &[Value], reason: &str) -> usize {
    runs.iter().filter(|r| r["reason"] == reason).count()
}

/// The worlds side by side, one row each, and every failure with when and why.
fn table(columns: &[Column]) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "| world | objects | held (truth) | slipped | dropped | cancelled | missed | timed out | pain | grip force N, median / max | robot time s, median / max | wall s per grasp, median / max | wall s in all |");
    let _ = writeln!(s, "|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    for Column { world, runs, wall_s } in columns {
        let held: Vec<&Value> = runs.iter().filter(|r| r["succeeded"] == true).collect();
        let f = |rs: &[&Value], key: &str| rs.iter().map(|r| r[key].as_f64().unwrap()).collect::<Vec<f64>>();
        let all: Vec<&Value> = runs.iter().collect();
        let pains = runs.iter().filter(|r| r["reason"] == "pain" || r["pain_events"].as_u64() != Some(0)).count();
        let _ = writeln!(
            s,
            "| {world} | {} | {} ({:.0}%) | {} | {} | {} | {} | {} | {pains} | {} | {} | {} | {wall_s:.0} |",
            runs.len(),
            held.len(),
            100.0 * held.len() as f64 / runs.len().max(1) as f64,
            failed_for(runs, "slipped"),
            failed_for(runs, "dropped"),
            failed_for(runs, "cancelled"),
            failed_for(runs, "missed"),
            failed_for(runs, "time_out"),
            spread(f(&held, "grip_force_max_n"), 2),
            spread(f(&held, "time_s"), 1),
            spread(f(&all, "wall_s"), 1),
        );
    }
    for Column { world, runs, .. } in columns {
        let mut reasons = BTreeMap::new();
        for r in runs.iter().filter(|r| r["succeeded"] != true) {
            *reasons.entry(r["failed"]["why"].to_string()).or_insert(0) += 1;
            let _ = writeln!(
                s,
                "{world}: {} {} at {} s ({}; ended {}) placement {}",
                r["object"],
                r["reason"],
                r["failed"]["time_s"],
                r["failed"]["why"],
                r["controller_state"],
                r["placement"]
            );
        }
        if !reasons.is_empty() {
            let _ = writeln!(s, "{world}, failures by what decided them: {reasons:?}");
        }
    }
    s
}

/// Every grasp of `runs` held, or at least `percent` of them, without pain.
fn check_goal(world: &str, runs: &[Value], percent: usize) {
    let held = runs.iter().filter(|r| r["succeeded"] == true).count();
    let pains: u64 = runs.iter().map(|r| r["pain_events"].as_u64().unwrap()).sum();
    assert!(held * 100 >= percent * runs.len(), "{world}: {held} of {} held", runs.len());
    assert_eq!(pains, 0, "{world}");
    assert_eq!(failed_for(runs, "pain"), 0, "{world}");
}

#[test]
#[ignore]
fn a_hundred_generated_objects_at_random_spots() {
    let dir = scratch("generated-objects");
    let mut rng = ChaCha8Rng::seed_from_u64(OBJECT_SEED);
    for k in 0..COUNT {
        let name = format!("gen_{k:03}");
        std::fs::write(dir.join(format!("{name}.toml")), object_file(&name, &mut rng)).unwrap();
    }
    let (runs, wall_s) = grasp_folder(&dir, &["--jitter", &PLACEMENT_SEED.to_string()]);
    assert_eq!(runs.len(), COUNT);
    let column = Column { world: "built-in", runs, wall_s };
    println!(
        "objects seed {OBJECT_SEED}, placements --jitter {PLACEMENT_SEED}\n{}",
        table(std::slice::from_ref(&column))
    );
    check_goal(column.world, &column.runs, 95);
    std::fs::remove_dir_all(&dir).unwrap();
}

/// 100 objects from several generator seeds, each placed anywhere both
/// arms reach (see [`Reach`]) and turned up to 0.3 rad, in every world.
#[test]
#[ignore]
fn a_hundred_objects_anywhere_the_arms_reach_in_each_world() {
    let dir = scratch("reached-objects");
    let robot = hrp2::robot();
    let reach = Reach::new(&robot, &Setup::new(&robot, 0).unwrap(), SkinModel::default().surface_offset_m);
    let share = COUNT / SIDE_BY_SIDE_SEEDS.len();
    for seed in SIDE_BY_SIDE_SEEDS {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        for k in 0..share {
            let name = format!("gen{seed}_{k:02}");
            let text = object_file(&name, &mut rng);
            let object = parse(&text).unwrap().object;
            let placement =
                reach.placement(&object, &mut rng).unwrap_or_else(|| panic!("{name}: no placement reaches"));
            std::fs::write(dir.join(format!("{name}.toml")), text + &placement_keys(&placement)).unwrap();
        }
    }
    let columns = in_every_world(&dir);
    for c in &columns {
        assert_eq!(c.runs.len(), COUNT, "{}", c.world);
    }
    println!(
        "objects seeds {SIDE_BY_SIDE_SEEDS:?}, {share} each, placed anywhere both arms reach\n{}",
        table(&columns)
    );
    for c in &columns {
        check_goal(c.world, &c.runs, 95);
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Too wide for the arms, too heavy to carry: without pain in every
/// world; not held where gravity acts. The built-in world, which has no
/// gravity, slides the wide box sideways on its support until the arms
/// squeeze its ends, and may call that held; a wider box is in the way of
/// the opening arms (0.7 m: pain while opening).
#[test]
#[ignore]
fn objects_that_cannot_be_held_fail_without_pain() {
    let dir = scratch("impossible-objects");
    let common = "stiffness_n_per_m = 3000.0\nreflectance = 0.7\nfriction = 0.4\n";
    for (name, shape, mass) in [
        ("too_wide", "{ box = { half = [0.10, 0.30, 0.15], round_m = 0.01 } }", 0.5),
        ("too_heavy", "{ box = { half = [0.07, 0.15, 0.13], round_m = 0.01 } }", 40.0),
    ] {
        let text = format!("name = \"{name}\"\nshape = {shape}\nmass_kg = {mass}\n{common}");
        std::fs::write(dir.join(format!("{name}.toml")), text).unwrap();
    }
    let columns = in_every_world(&dir);
    println!("{}", table(&columns));
    for Column { world, runs, .. } in &columns {
        assert_eq!(runs.len(), 2, "{world}");
        for r in runs {
            let what = format!("{world}: {}", r["object"]);
            assert_ne!(r["reason"], "pain", "{what}");
            assert_eq!(r["pain_events"], 0, "{what}");
            if *world == "built-in" && r["object"] == "too_wide" {
                continue;
            }
            assert_eq!(r["succeeded"], false, "{what}");
            // The controller gives up; or it holds on, and the person,
            // feeling the object come down with their hands, never lets
            // go: it ends on their hands, not carried by the robot.
            let gave_up = r["controller_state"] == "cancelled";
            let kept = r["failed"]["why"]["not_held"] == "resting";
            assert!(gave_up || kept, "{what}: the controller gives up or the person keeps it: {r}");
        }
    }
    std::fs::remove_dir_all(&dir).unwrap();
}
