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
use std::process::{Command, Output};
use std::time::Instant;

use serde_json::Value;

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

/// `skin` with `args`, run to its end.
fn run_skin(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_skin")).args(args).output().expect("the skin binary runs")
}

/// `skin` with `args`, its standard output; panics with its standard
/// error when it fails.
fn skin(args: &[&str]) -> Vec<u8> {
    let out = run_skin(args);
    assert!(out.status.success(), "skin {args:?}: {}", String::from_utf8_lossy(&out.stderr));
    out.stdout
}

/// `skin objects` into `dir`: `count` object files from each of `seeds`,
/// placed anywhere both arms reach unless `unplaced`.
fn generate(dir: &Path, seeds: &[u64], count: usize, unplaced: bool) {
    let count = count.to_string();
    let mut args = vec!["objects", "--out", dir.to_str().unwrap(), "--count", &count];
    let seeds: Vec<String> = seeds.iter().map(u64::to_string).collect();
    seeds.iter().for_each(|s| args.extend(["--seed", s]));
    if unplaced {
        args.push("--unplaced");
    }
    skin(&args);
}

/// `skin grasp --json` on every object file of `dir`, placed by `args`,
/// and the wall time it took, s. Its exit status 1 says an object was not
/// held, which the table reports; any other failure panics.
fn grasp_folder(dir: &Path, args: &[&str]) -> (Vec<Value>, f64) {
    let started = Instant::now();
    let mut all = vec!["grasp", "--json", "--object-file", dir.to_str().unwrap()];
    all.extend(args);
    let out = run_skin(&all);
    assert!(matches!(out.status.code(), Some(0 | 1)), "skin {all:?}: {}", String::from_utf8_lossy(&out.stderr));
    let runs: Value = serde_json::from_slice(&out.stdout).expect("a JSON array");
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

impl Column<'_> {
    /// How many grasps the truth calls held.
    fn held(&self) -> usize {
        self.runs.iter().filter(|r| r["succeeded"] == true).count()
    }

    /// How many grasps were in pain: failed for it, or a pain event in them.
    fn in_pain(&self) -> usize {
        self.runs.iter().filter(|r| r["reason"] == "pain" || r["pain_events"].as_u64() != Some(0)).count()
    }
}

/// How many of `runs` failed for `reason`.
fn failed_for(runs: &[Value], reason: &str) -> usize {
    runs.iter().filter(|r| r["reason"] == reason).count()
}

/// The worlds side by side, one row each, and every failure with when and why.
fn table(columns: &[Column]) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "| world | objects | held (truth) | of them still sliding | slipped | dropped | cancelled | missed | timed out | pain | grip force N, median / max | robot time s, median / max | wall s per grasp, median / max | wall s in all |");
    let _ = writeln!(s, "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    for column @ Column { world, runs, wall_s } in columns {
        let held: Vec<&Value> = runs.iter().filter(|r| r["succeeded"] == true).collect();
        let f = |rs: &[&Value], key: &str| rs.iter().map(|r| r[key].as_f64().unwrap()).collect::<Vec<f64>>();
        let all: Vec<&Value> = runs.iter().collect();
        let _ = writeln!(
            s,
            "| {world} | {} | {} ({:.0}%) | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {wall_s:.0} |",
            runs.len(),
            held.len(),
            100.0 * held.len() as f64 / runs.len().max(1) as f64,
            held.iter().filter(|r| r["settled"] == false).count(),
            failed_for(runs, "slipped"),
            failed_for(runs, "dropped"),
            failed_for(runs, "cancelled"),
            failed_for(runs, "missed"),
            failed_for(runs, "time_out"),
            column.in_pain(),
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

/// Each world that misses the goal (at least `percent` of its grasps
/// held, none in pain), with what it missed by; all of them are said
/// before the test fails, so one world missing does not hide the others.
fn check_goal(columns: &[Column], percent: usize) {
    let missed: Vec<String> = columns
        .iter()
        .filter(|c| c.held() * 100 < percent * c.runs.len() || c.in_pain() > 0)
        .map(|c| format!("{}: {} of {} held, {} grasps in pain", c.world, c.held(), c.runs.len(), c.in_pain()))
        .collect();
    assert!(missed.is_empty(), "goal {percent}% held without pain missed by {}", missed.join("; "));
}

#[test]
#[ignore]
fn a_hundred_generated_objects_at_random_spots() {
    let dir = scratch("generated-objects");
    generate(&dir, &[OBJECT_SEED], COUNT, true);
    let (runs, wall_s) = grasp_folder(&dir, &["--jitter", &PLACEMENT_SEED.to_string()]);
    assert_eq!(runs.len(), COUNT);
    let column = Column { world: "built-in", runs, wall_s };
    println!(
        "objects seed {OBJECT_SEED}, placements --jitter {PLACEMENT_SEED}\n{}",
        table(std::slice::from_ref(&column))
    );
    check_goal(std::slice::from_ref(&column), 95);
    std::fs::remove_dir_all(&dir).unwrap();
}

/// 100 objects from several generator seeds, each placed anywhere both
/// arms reach (see [`Reach`]) and turned up to 0.3 rad, in every world.
#[test]
#[ignore]
fn a_hundred_objects_anywhere_the_arms_reach_in_each_world() {
    let dir = scratch("reached-objects");
    let share = COUNT / SIDE_BY_SIDE_SEEDS.len();
    generate(&dir, &SIDE_BY_SIDE_SEEDS, share, false);
    let columns = in_every_world(&dir);
    for c in &columns {
        assert_eq!(c.runs.len(), COUNT, "{}", c.world);
    }
    println!(
        "objects seeds {SIDE_BY_SIDE_SEEDS:?}, {share} each, placed anywhere both arms reach\n{}",
        table(&columns)
    );
    check_goal(&columns, 95);
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Too wide for the arms, too heavy to carry: not held, without pain,
/// and given up (`cancelled`) in every world. Their pulls stall hug after
/// hug; or, where the person's hands go along with the pull (MuJoCo), the
/// heavy box reaches the chest, comes down with the person's hands as they
/// let it go, and they carry it away, out of the arms that then lose it.
/// A wider box is in the way of the opening arms (0.7 m: pain while
/// opening).
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
            assert_eq!(r["succeeded"], false, "{what}");
            // The controller gives up: the pulls stall, or the object the
            // person took back and carried away is lost to the arms.
            assert_eq!(r["controller_state"], "cancelled", "{what}: {r}");
        }
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// `skin objects`: the same seeds write the same files, which `skin grasp`
/// reads; a file already there is never overwritten.
#[test]
fn generated_object_files_are_the_same_for_a_seed_and_never_overwrite() {
    let [a, b] = ["objects-a", "objects-b"].map(scratch);
    generate(&a, &[7, 8], 3, false);
    generate(&b, &[7, 8], 3, false);
    let files = |dir: &Path| {
        let mut v: Vec<(String, String)> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| {
                let path = e.unwrap().path();
                (path.file_name().unwrap().to_string_lossy().into_owned(), std::fs::read_to_string(&path).unwrap())
            })
            .collect();
        v.sort();
        v
    };
    let written = files(&a);
    let names: Vec<&str> = written.iter().map(|(n, _)| n.as_str()).collect();
    assert_eq!(names, ["gen7_00.toml", "gen7_01.toml", "gen7_02.toml", "gen8_00.toml", "gen8_01.toml", "gen8_02.toml"]);
    assert_eq!(files(&b), written);
    assert!(written.iter().all(|(_, text)| text.contains("offset_m")), "placed");
    let again = run_skin(&["objects", "--seed", "7", "--count", "1", "--out", a.to_str().unwrap()]);
    assert_eq!(again.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&again.stderr).contains("gen7_00.toml"), "names the file it would overwrite");
    assert_eq!(files(&a), written, "nothing overwritten");
    let zero = run_skin(&["objects", "--count", "0", "--out", "x"]);
    assert_eq!(zero.status.code(), Some(2), "a bad count is a usage error");
    for dir in [a, b] {
        std::fs::remove_dir_all(dir).unwrap();
    }
}
