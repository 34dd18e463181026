//! Exploration and calibration on every MuJoCo model in a folder
//! (`SKIN_MJCF_DIR`, e.g. the Menagerie robots `cargo xtask menagerie`
//! gathers), seeds 1 to 3, default flags: one line per robot and seed with
//! its DoFs, cells, tree verdict, assumptions, robot time, the calibration's
//! position (mean, p95, max) and orientation (mean) errors over the
//! observable cells, and wall time; then the totals against the goals
//! (>= 95 % true trees, none wrong; mean <= 5 mm, p95 <= 10 mm, <= 2 deg).
//!
//! Ignored: minutes per robot, and the models are downloaded by hand.
//! `cargo test --release -p skin-host --features mujoco --test mujoco_robots -- --ignored --nocapture`

use std::path::PathBuf;
use std::process::Command;
use std::time::Instant;

use serde_json::Value;

/// `skin ARGS --json` on the model: its JSON report, or the error it printed.
fn skin(args: &[&str], model: &std::path::Path, seed: u64) -> Result<Value, String> {
    let out = Command::new(env!("CARGO_BIN_EXE_skin"))
        .args(args)
        .arg("--mujoco")
        .arg(model)
        .args(["--seed", &seed.to_string(), "--json"])
        .output()
        .map_err(|e| e.to_string())?;
    let report: Value = serde_json::from_slice(&out.stdout).unwrap_or(Value::Null);
    if out.status.success() {
        return Ok(report);
    }
    let stderr = String::from_utf8_lossy(&out.stderr);
    Err(report["error"].as_str().map_or_else(|| stderr.lines().last().unwrap_or_default().to_owned(), str::to_owned))
}

fn mm(v: &Value) -> String {
    v.as_f64().map_or_else(|| "-".into(), |m| format!("{:.1}", m * 1e3))
}

#[test]
#[ignore = "minutes per robot; needs SKIN_MJCF_DIR (cargo xtask menagerie)"]
fn every_model_in_the_folder_is_explored_and_calibrated() {
    let Some(dir) = std::env::var_os("SKIN_MJCF_DIR").map(PathBuf::from) else {
        println!("skipped: set SKIN_MJCF_DIR to a folder of MuJoCo models (cargo xtask menagerie gathers Menagerie's)");
        return;
    };
    let mut models: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "xml" || x == "urdf"))
        .collect();
    models.sort();
    let seeds: Vec<u64> = std::env::var("SKIN_SEEDS")
        .map(|s| s.split(',').map(|x| x.trim().parse().expect("SKIN_SEEDS: numbers separated by commas")).collect())
        .unwrap_or_else(|_| vec![1, 2, 3]);
    println!("| robot | seed | DoFs | cells | tree | assumed | robot time s | mean mm | p95 mm | max mm | orient. deg | wall s |");
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|");
    let (mut runs, mut true_trees, mut wrong) = (0, 0, 0);
    let mut worst = (0.0f64, 0.0f64, 0.0f64);
    for model in &models {
        // MuJoCo finds a model's meshes from its own folder: a link is followed.
        let path = std::fs::canonicalize(model).unwrap_or_else(|_| model.clone());
        let name = model.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
        for &seed in &seeds {
            runs += 1;
            let wall = Instant::now();
            // One run explores and calibrates, and reports the exploration's verdict too.
            let c = match skin(&["calibrate"], &path, seed) {
                Ok(c) => c,
                Err(e) => {
                    println!("| {name} | {seed} | | | failed: {e} | | | | | | | {:.0} |", wall.elapsed().as_secs_f64());
                    continue;
                }
            };
            let explored = &c["exploration_truth"];
            let correct = explored["tree_correct"].as_bool() == Some(true);
            let wrong_entries = explored["wrong_entries"].as_u64().unwrap_or(0);
            true_trees += usize::from(correct);
            wrong += usize::from(!correct && wrong_entries > 0);
            let verdict = if correct { "true".to_owned() } else { format!("{wrong_entries} wrong") };
            let (dofs, cells) = (c["dofs"].as_array().map_or(0, Vec::len), c["cells"].as_array().map_or(0, Vec::len));
            let assumed = c["assumed"].as_array().map_or(0, Vec::len);
            let t = &c["truth"];
            let p = &t["position_m"];
            let deg = t["orientation_deg"]["mean"].as_f64().unwrap_or(f64::NAN);
            let (mean, p95) = (p["mean"].as_f64().unwrap_or(0.0), p["p95"].as_f64().unwrap_or(0.0));
            worst = (worst.0.max(mean), worst.1.max(p95), worst.2.max(deg));
            println!(
                "| {name} | {seed} | {dofs} | {cells} | {verdict} | {assumed} | {:.0} | {} | {} | {} | {deg:.2} | {:.0} |",
                c["robot_time_s"]["total"].as_f64().unwrap_or(0.0),
                mm(&p["mean"]),
                mm(&p["p95"]),
                mm(&p["max"]),
                wall.elapsed().as_secs_f64()
            );
        }
    }
    println!(
        "\n{runs} runs: {true_trees} true trees ({:.0} %, goal >= 95 %), {wrong} wrong (goal 0); worst calibration mean {:.1} mm (goal <= 5), p95 {:.1} mm (goal <= 10), orientation {:.2} deg (goal <= 2)",
        100.0 * true_trees as f64 / runs.max(1) as f64,
        worst.0 * 1e3,
        worst.1 * 1e3,
        worst.2
    );
}
