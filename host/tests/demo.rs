//! The main job end to end, as a person runs it: `skin demo --quick`
//! writes a complete report folder, and `skin run` drives the simulated
//! robot and skin served by `skin sim-endpoint` in another process, over
//! loopback UDP only. The demo's recording is read by readers we did not
//! write, and `skin replay` of it explores the same body.

mod common;

use std::collections::HashSet;
use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

use common::free_addr;
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
    let recording = dir.join("recording.mcap");
    check_replay(&recording, &report);
    check_topics(&recording, &["/skin/events"]);
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Messages per topic, as the mcap crate reads them.
fn topics_of(file: &Path) -> serde_json::Map<String, Value> {
    let bytes = std::fs::read(file).unwrap();
    let mut counts = serde_json::Map::new();
    for message in mcap::MessageStream::new(&bytes).unwrap() {
        let topic = message.unwrap().channel.topic.clone();
        let n = counts.get(&topic).and_then(Value::as_u64).unwrap_or(0);
        counts.insert(topic, (n + 1).into());
    }
    counts
}

/// `skin replay --explore` of a recording learns what the run that
/// recorded it learned live.
fn check_replay(file: &Path, report: &Value) {
    let replayed = json_of(skin().args(["replay", "--explore", "--json"]).arg(file));
    assert!(replayed == report["exploration"], "the replay explores the same body as the live run");
}

/// The raw channels and the ROS 2 topics are in the recording, and
/// `extra` too; returns the messages per topic.
fn check_topics(file: &Path, extra: &[&str]) -> serde_json::Map<String, Value> {
    let ours = topics_of(file);
    let always = [
        "/skin/interface",
        "/skin/robot_link/command",
        "/skin/robot_link/state",
        "/skin/explore_start",
        "/joint_states",
        "/skin/cells",
        "/tf_static",
        "/robot_description",
    ];
    for topic in always.iter().chain(extra) {
        assert!(ours.get(*topic).and_then(Value::as_u64).is_some_and(|n| n > 0), "{topic} missing: {ours:?}");
    }
    ours
}

/// rosbags and mcap-ros2-support decode every message of the recording,
/// into the values the run had.
fn check_readers(file: &Path, ours: &serde_json::Map<String, Value>) {
    let Some(python) = common::python() else { return };
    let theirs = common::run_json(&python, "check_mcap.py", &[file]);
    assert_eq!(theirs["rosbags"].as_object(), Some(ours), "rosbags decoded every message");
    assert_eq!(theirs["mcap_ros2"].as_object(), Some(ours), "mcap-ros2-support decoded every message");
    let types = &theirs["types"];
    assert_eq!(types["/skin/cells"], "sensor_msgs/msg/PointCloud2");
    assert_eq!(types["/tf_static"], "tf2_msgs/msg/TFMessage");
    assert_eq!(types["/skin/imu"], "sensor_msgs/msg/Imu");
    let v = &theirs["values"];
    assert_eq!((v["cloud_points"].as_u64(), v["cloud_bytes_ok"].as_bool()), (Some(74), Some(true)), "{v}");
    assert_eq!((v["joints"].as_u64(), v["positions"].as_u64()), (Some(14), Some(14)), "{v}");
    assert_eq!(v["cell_frames"], 74, "{v}");
    assert!(v["first_frame"][0].as_str().unwrap().starts_with("skin_part_"), "{v}");
    assert!(v["first_frame"][1].as_str().unwrap().starts_with("skin_cell_"), "{v}");
    assert_eq!(v["urdf_start"], "<?xml version=\"1.0\"?>", "{v}");
    let g = v["imu_g"].as_f64().unwrap();
    assert!((0.9..1.1).contains(&g), "a resting cell feels 1 g, not {g} g");
    let fields: Vec<&str> = v["cloud_fields"].as_array().unwrap().iter().map(|f| f.as_str().unwrap()).collect();
    for field in ["x", "y", "z", "id", "proximity", "force", "temperature", "ax", "ay", "az"] {
        assert!(fields.contains(&field), "{field} not in {fields:?}");
    }
}

/// A loopback address with a port free right now.
/// `skin sim-endpoint ARGS` running, and the line it announces itself with.
fn serve(args: &[&str]) -> (std::process::Child, String) {
    let mut endpoint =
        skin().arg("sim-endpoint").args(args).stdout(Stdio::piped()).stderr(Stdio::null()).spawn().unwrap();
    let mut announced = String::new();
    BufReader::new(endpoint.stdout.take().unwrap()).read_line(&mut announced).unwrap();
    (endpoint, announced)
}

#[test]
fn skin_run_drives_the_simulated_robot_served_by_another_process() {
    let (host, robot) = (free_addr(), free_addr());
    let (mut endpoint, announced) = serve(&["--seed", "4", "--duration", "300", "--host", &host, "--robot", &robot]);
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
    let recording = dir.join("again.mcap");
    // The first host also calibrates the skin on the robot's description.
    let urdf = dir.with_extension("urdf");
    std::fs::write(&urdf, skin_model::robot::hrp2::urdf()).unwrap();
    let calibrated = dir.join("first.mcap");
    let first = run(&dirs[0], &["--urdf".as_ref(), urdf.as_os_str(), "--record".as_ref(), calibrated.as_os_str()]);
    // The endpoint serves one host at a time and lets it go after 2 s of silence.
    std::thread::sleep(std::time::Duration::from_millis(2500));
    let results = [
        first,
        run(
            &dirs[1],
            &["--config".as_ref(), config.as_os_str(), "--imu".as_ref(), "--record".as_ref(), recording.as_os_str()],
        ),
    ];
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
        if dir == &dirs[0] {
            check_calibration(dir, &report, &calibrated, &urdf);
        }
        if dir == &dirs[1] {
            check_replay(&recording, &report);
            let topics = check_topics(&recording, &["/skin/imu"]);
            check_readers(&recording, &topics);
        }
    }
    std::fs::remove_dir_all(&dir).unwrap();
    std::fs::remove_file(&config).unwrap();
    std::fs::remove_file(&urdf).unwrap();
}

/// `skin run --urdf F --cell-pitch 0.025` against `skin sim-endpoint
/// --patches`: the neighbour tables come from the cells' own
/// self-organization over the real protocol, and place cells the motion
/// leaves blind along an axis (those left partial without the pitch), each
/// within 10 mm of where the simulator truly put it (the same seeded skin,
/// rebuilt here; a placed cell is matched to the true cell of its link
/// nearest to it, no two to one, as the network gives IDs of its own).
#[test]
fn skin_run_places_blind_cells_from_the_neighbour_tables_the_skin_reports() {
    let robot = skin_model::robot::hrp2::robot();
    let truth =
        skin_model::skin::Skin::patches(&robot, |l| skin_model::robot::hrp2::skin_cells_on(&l.name), 1).unwrap();
    let dir = scratch("pitch");
    std::fs::create_dir_all(&dir).unwrap();
    let urdf = dir.join("hrp2.urdf");
    std::fs::write(&urdf, skin_model::robot::hrp2::urdf()).unwrap();
    let run = |pitch: Option<&str>| -> (Value, String) {
        let (host, robot_addr) = (free_addr(), free_addr());
        let args = ["--patches", "--seed", "1", "--duration", "120", "--host", &host, "--robot", &robot_addr];
        let (mut endpoint, announced) = serve(&args);
        // As many interface ports as the endpoint serves, numbered from 0.
        let ports = announced.split("interface ports ").nth(1).unwrap().split(',').count();
        let config = dir.join(format!("ports-{}.toml", pitch.is_some()));
        let mut text = format!("[interface]\nlisten = \"{host}\"\n");
        (0..ports).for_each(|k| text += &format!("\n[[interface.ports]]\nnumber = {k}\n"));
        std::fs::write(&config, text).unwrap();
        let out = dir.join(format!("out-{}", pitch.is_some()));
        let mut command = skin();
        command.args(["run", "--json", "--cells", "74", "--robot", &robot_addr, "--urdf"]).arg(&urdf);
        command.arg("--config").arg(&config).arg("--out").arg(&out);
        if let Some(p) = pitch {
            command.args(["--cell-pitch", p]);
        }
        let report = json_of(&mut command);
        endpoint.kill().unwrap();
        endpoint.wait().unwrap();
        (report, std::fs::read_to_string(out.join("skin.toml")).unwrap())
    };
    let (blind, blind_toml) = run(None);
    let (placed, skin_toml) = run(Some("0.025"));
    let partial = |r: &Value| r["calibration"]["cells_partial"].as_u64().unwrap();
    assert!(partial(&blind) > 0, "nothing blind to place");
    assert!(
        partial(&placed) < partial(&blind),
        "{} partial cells, {} with the pitch",
        partial(&blind),
        partial(&placed)
    );
    // The run is deterministic: what the pitch changed is what it placed.
    let before = skin_model::skin::Skin::from_toml_str(&robot, &blind_toml).unwrap();
    let after = skin_model::skin::Skin::from_toml_str(&robot, &skin_toml).unwrap();
    let moved: Vec<_> = after
        .cells()
        .iter()
        .filter(|c| {
            let was = before.cells().iter().find(|b| b.id == c.id).expect("the same cells");
            (was.pose.translation.vector - c.pose.translation.vector).norm() > 1e-6
        })
        .collect();
    assert_eq!(moved.len() as u64, partial(&blind) - partial(&placed), "only the blind cells move");
    let mut claimed = HashSet::new();
    for cell in moved {
        let p = cell.pose.translation.vector;
        let (k, error) = truth
            .cells()
            .iter()
            .enumerate()
            .filter(|(_, r)| r.link == cell.link)
            .map(|(k, r)| (k, (r.pose.translation.vector - p).norm()))
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .unwrap();
        println!("cell {} on {}: {:.2} mm from the nearest true cell", cell.id.0, cell.link, error * 1e3);
        assert!(
            error <= 0.010,
            "cell {} on {}: {:.1} mm from the nearest true cell",
            cell.id.0,
            cell.link,
            error * 1e3
        );
        assert!(claimed.insert(k), "two cells placed on one");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// The skin calibrated over the wire: the chest's 14 cells on the fixed
/// base without a position, the arms' with one, and the files that say so
/// readable by the simulator's own skin reader and the URDF reader.
fn check_calibration(dir: &Path, report: &Value, recording: &Path, urdf: &Path) {
    let c = &report["calibration"];
    assert_eq!(c["cells_unobservable"], 14, "{c}");
    assert!(c["cells_3d"].as_u64().unwrap() >= 50, "{c}");
    assert_eq!(c["warnings"].as_array().unwrap().len(), 0, "{c}");
    let files: Vec<&str> = report["figures"].as_array().unwrap().iter().map(|f| f["file"].as_str().unwrap()).collect();
    assert!(files.contains(&"calibration.svg"), "{files:?}");
    let robot = skin_model::robot::hrp2::robot();
    let calibrated =
        skin_model::skin::Skin::from_file(&robot, &dir.join("skin.toml")).expect("the calibrated skin reads back");
    assert_eq!(calibrated.cells().len(), 74);
    let with_skin = skin_model::robot::Robot::from_urdf_file(&dir.join("robot_with_skin.urdf")).expect("a URDF");
    assert!(calibrated.cells().iter().all(|cell| with_skin.link(&format!("skin_cell_{}", cell.id.0)).is_some()));
    // ROS's own URDF parser finds a fixed frame per cell, where the skin file puts it.
    let Some(python) = common::python() else { return };
    let parsed = common::run_json(&python, "urdf_frames.py", &[&dir.join("robot_with_skin.urdf")]);
    assert_eq!(parsed["links"].as_u64(), Some(robot.links().len() as u64 + 74), "{parsed}");
    for cell in calibrated.cells() {
        let frame = &parsed["cells"][cell.id.0.to_string()];
        assert_eq!(frame["parent"], cell.link.as_str());
        let xyz: Vec<f64> = frame["xyz"].as_array().unwrap().iter().map(|v| v.as_f64().unwrap()).collect();
        let t = cell.pose.translation.vector;
        assert!((t - nalgebra::Vector3::new(xyz[0], xyz[1], xyz[2])).norm() < 1e-5, "cell {}: {frame}", cell.id.0);
    }
    // The replay of the recording calibrates the same skin, to the digit.
    let replayed = skin().args(["replay", "--calibrate"]).arg(urdf).arg(recording).output().unwrap();
    assert!(replayed.status.success(), "{}", String::from_utf8_lossy(&replayed.stderr));
    let live = std::fs::read_to_string(dir.join("skin.toml")).unwrap();
    assert_eq!(String::from_utf8(replayed.stdout).unwrap().trim_end(), live.trim_end());
    // The recording's last /tf_static puts every cell on its URDF link where
    // the calibration does, and its /robot_description has the skin's frames.
    let tf = common::run_json(&python, "tf_static_frames.py", &[recording]);
    assert_eq!(tf["description_skin_frames"], 74, "{tf}");
    let frames = tf["frames"].as_array().unwrap();
    assert_eq!(frames.len(), 74);
    for f in frames {
        let id: u16 = f[1].as_str().unwrap().trim_start_matches("skin_cell_").parse().unwrap();
        let cell = calibrated.cells().iter().find(|c| c.id.0 == id).expect("a calibrated cell");
        assert_eq!(f[0], cell.link.as_str());
        let xyz: Vec<f64> = f[2].as_array().unwrap().iter().map(|v| v.as_f64().unwrap()).collect();
        assert!((cell.pose.translation.vector - nalgebra::Vector3::new(xyz[0], xyz[1], xyz[2])).norm() < 1e-5);
    }
}

#[test]
fn a_missing_robot_or_a_bad_flag_is_explained() {
    let nobody = free_addr();
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
    // A recording that is not there, or not MCAP, is named in one line.
    let junk = scratch("junk").with_extension("mcap");
    std::fs::write(&junk, b"not an MCAP file at all").unwrap();
    for file in [Path::new("/nonexistent/recording.mcap"), junk.as_path()] {
        let out = skin().args(["replay", "--explore"]).arg(file).output().unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success() && err.starts_with("error: ") && err.contains(&*file.to_string_lossy()), "{err}");
        assert!(!err.contains("panicked"), "{err}");
    }
    std::fs::remove_file(&junk).unwrap();
}
