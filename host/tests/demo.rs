//! The main job end to end, as a person runs it: `skin demo --quick`
//! writes a complete report folder, and `skin run` drives the simulated
//! robot and skin served by `skin sim-endpoint` in another process, over
//! loopback UDP only.

use std::collections::HashSet;
use std::io::{BufRead, BufReader};
use std::net::UdpSocket;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

use serde_json::Value;

fn skin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_skin"))
}

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("skin-demo-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

/// Runs `skin` with `args`, expecting success and one JSON object on stdout.
fn json_of(command: &mut Command) -> Value {
    let out = command.output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "skin failed: {stderr}");
    serde_json::from_slice(&out.stdout).unwrap_or_else(|e| panic!("stdout is not JSON ({e}); stderr: {stderr}"))
}

/// Every file of the report is there, not empty, and of its kind; the page
/// shows every figure; report.json is the report printed.
fn check_files(dir: &Path, report: &Value) {
    let figures = report["figures"].as_array().expect("a list of figures");
    let files: Vec<&str> = figures.iter().map(|f| f["file"].as_str().unwrap()).collect();
    for name in
        ["activity_before.svg", "activity_after.svg", "kinematic_tree.svg", "sensory_motor_map.svg", "topology.svg"]
    {
        assert!(files.contains(&name), "{name} missing from {files:?}");
    }
    let page = std::fs::read_to_string(dir.join("index.html")).unwrap();
    assert!(page.starts_with("<!DOCTYPE html>") && page.trim_end().ends_with("</html>"));
    for f in &files {
        let svg = std::fs::read_to_string(dir.join(f)).unwrap();
        assert!(svg.contains("<svg") && svg.trim_end().ends_with("</svg>"), "{f} is not an SVG document");
        assert!(svg.len() > 1000, "{f} is nearly empty");
        assert!(page.contains(&format!("<img src=\"{f}\"")), "index.html does not show {f}");
    }
    let written: Value = serde_json::from_str(&std::fs::read_to_string(dir.join("report.json")).unwrap()).unwrap();
    assert!(written["exploration"] == report["exploration"], "report.json holds what was printed");
}

/// The skin organized (every cell once, with a tree) and the body explored
/// into the HRP-2 tree: a static chest and two chains of 7 joints.
fn check_job(report: &Value, cells: usize) {
    let organized = report["organization"]["cells"].as_array().unwrap();
    let ids: HashSet<u64> = organized.iter().map(|c| c["id"].as_u64().unwrap()).collect();
    assert_eq!((organized.len(), ids.len()), (cells, cells), "every cell once, unique IDs");
    assert!(organized.iter().all(|c| c["hops"].as_u64().is_some()), "every cell is in an interface tree");
    let o = &report["organization"];
    assert_eq!(o["settings_acknowledged"], o["settings_written"]);
    assert!(report["interface"]["datagrams"]["rejected"].as_object().unwrap().values().all(|n| n == 0));

    let e = &report["exploration"];
    let activity = e["activity"].as_array().unwrap();
    assert_eq!((activity.len(), activity[0].as_array().unwrap().len()), (cells, 14));
    assert_eq!(e["joints"].as_array().unwrap().len(), 14);
    assert_eq!(e["limbs"].as_array().unwrap().len(), 2);
    let explored: HashSet<u64> = e["cells"].as_array().unwrap().iter().map(|c| c.as_u64().unwrap()).collect();
    assert_eq!(explored, ids, "the exploration saw every organized cell");
    let weights = e["smm_weights"].as_array().unwrap().iter().flat_map(|r| r.as_array().unwrap().clone());
    assert!(weights.map(|w| w.as_f64().unwrap()).all(|w| (-1.0..=1.0).contains(&w)));
    let t = &report["timing"];
    assert!(t["structure_robot_s"].as_f64().unwrap() > 1.0 && t["smm_robot_s"].as_f64().unwrap() > 1.0);
}

#[test]
fn the_quick_demo_writes_a_complete_and_true_report() {
    let dir = scratch("demo");
    let report = json_of(skin().args(["demo", "--quick", "--json", "--out"]).arg(&dir));
    check_files(&dir, &report);
    check_job(&report, 74);
    let truth = &report["truth"];
    assert_eq!(truth["cells_with_id"], 74);
    for check in ["ids_unique", "neighbours_correct", "tree_correct"] {
        assert_eq!(truth[check], true, "{check}: {truth}");
    }
    assert_eq!(truth["wrong_activity_entries"], 0);
    let latency = &report["latency"];
    let (p50, p99) = (latency["p50_us"].as_u64().unwrap(), latency["p99_us"].as_u64().unwrap());
    assert!(p50 > 0 && p50 <= p99, "latency p50 {p50} us, p99 {p99} us");
    let files: Vec<&str> = report["figures"].as_array().unwrap().iter().map(|f| f["file"].as_str().unwrap()).collect();
    assert!(files.contains(&"latency.svg") && files.contains(&"grasp_trash_bin.svg"), "{files:?}");
    assert!(dir.join("grasp_trash_bin.csv").metadata().unwrap().len() > 0);
    let runs = report["grasps"]["runs"].as_array().unwrap();
    assert_eq!(runs.len(), 1);
    assert_eq!(runs[0]["succeeded"], true, "held by the simulator's truth: {}", runs[0]);
    assert!(runs[0]["grip_force_max_n"].as_f64().unwrap() > 0.1, "the grip, not the pats: {}", runs[0]);
    let lessons = report["grasps"]["lessons"].as_array().unwrap();
    assert_eq!(lessons.len(), 3, "open, closed and pulled taught");
    // Teaching and grasping ran on the served skin: its network carried a
    // sample of every cell for every period of them too.
    let taught_s: f64 = lessons.iter().map(|l| l["time_s"].as_f64().unwrap()).sum();
    let t = &report["timing"];
    let robot_s = t["structure_robot_s"].as_f64().unwrap() + t["smm_robot_s"].as_f64().unwrap();
    let periods =
        (robot_s + taught_s + runs[0]["time_s"].as_f64().unwrap()) / report["robot"]["period_s"].as_f64().unwrap();
    let frames = latency["frames"].as_f64().unwrap();
    assert!(frames > 74.0 * periods, "{frames} sensor frames for {periods} periods of 74 cells");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A loopback address with a port free right now.
fn free_port() -> String {
    UdpSocket::bind("127.0.0.1:0").unwrap().local_addr().unwrap().to_string()
}

#[test]
fn skin_run_drives_the_simulated_robot_served_by_another_process() {
    let (host, robot) = (free_port(), free_port());
    let mut endpoint = skin()
        .args(["sim-endpoint", "--seed", "4", "--duration", "120", "--host", &host, "--robot", &robot])
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let mut announced = String::new();
    BufReader::new(endpoint.stdout.take().unwrap()).read_line(&mut announced).unwrap();
    assert!(announced.contains(&format!("serving the simulated robot on {robot}")), "{announced}");

    let dir = scratch("run");
    // A second host starts over against the same robot and skin, with a
    // configuration asking for event-driven traffic (the exploration still
    // gets every sample).
    let config = dir.with_extension("toml");
    let defaults = String::from_utf8(skin().args(["config", "--default"]).output().unwrap().stdout).unwrap();
    assert!(defaults.contains("traffic = \"clock\""));
    std::fs::write(&config, defaults.replace("traffic = \"clock\"", "traffic = \"event\"")).unwrap();
    let run = |out: &Path, extra: &[&std::ffi::OsStr]| {
        skin()
            .args(["run", "--json", "--cells", "74", "--interface", &host, "--robot", &robot, "--out"])
            .arg(out)
            .args(extra)
            .output()
    };
    let dirs = [dir.join("first"), dir.join("again")];
    let results = [run(&dirs[0], &[]), run(&dirs[1], &["--config".as_ref(), config.as_os_str()])];
    endpoint.kill().unwrap();
    endpoint.wait().unwrap();
    for (result, dir) in results.into_iter().zip(&dirs) {
        let out = result.unwrap();
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        let report: Value = serde_json::from_slice(&out.stdout).unwrap();
        check_files(dir, &report);
        check_job(&report, 74);
        assert!(report["truth"].is_null() && report["grasps"].is_null(), "no simulator truth over the wire");
        assert_eq!(report["robot"]["lockstep"], true);
    }
    std::fs::remove_dir_all(&dir).unwrap();
    std::fs::remove_file(&config).unwrap();
}

#[test]
fn a_missing_robot_or_a_bad_flag_is_explained() {
    let nobody = free_port();
    let out = skin()
        .args(["run", "--robot", &nobody, "--interface", "127.0.0.1:0", "--robot-timeout-ms", "100"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(err.contains(&nobody) && err.contains("robot"), "{err}");
    let out = skin().args(["run", "--robot", &nobody, "--organize-timeout=-1"]).output().unwrap();
    assert!(String::from_utf8_lossy(&out.stderr).contains("--organize-timeout"));
    let out = skin().args(["sim-endpoint", "--host", "192.0.2.1:7700"]).output().unwrap();
    assert!(!out.status.success() && String::from_utf8_lossy(&out.stderr).contains("127.0.0.1"));
}
