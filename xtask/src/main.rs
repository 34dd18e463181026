//! The project's task runner, in the `cargo xtask` way: plain Rust, no
//! dependencies, so it builds in seconds on a fresh machine.
//!
//! - `cargo xtask ci`: installs what a fresh machine lacks, then runs every
//!   check CI runs, one line per step, and a final `N passed, N failed`.
//! - `cargo xtask install`: only the installation part.
//! - `cargo xtask book`: builds the book (`docs/`) with mdBook and checks
//!   its internal links and those of the README.
//! - `cargo xtask firmware`: builds the cell firmware and the bootloader
//!   for both boards and checks them against their flash and RAM budget.
//! - `cargo xtask qemu-net --cells N`: a hexagonal patch of N QEMU cells.
//! - `cargo xtask image --key KEY --version V`: a board's firmware as a
//!   signed update image (`skin sign`).
//! - `cargo xtask menagerie`: MuJoCo Menagerie's robots from PyPI into
//!   `target/menagerie/models`, for the ignored test over `SKIN_MJCF_DIR`.
//! - `cargo xtask provision --key KEY`: a new STM32F405 cell's bootloader
//!   and first image as one file for a debug probe; `cargo xtask fw-flash
//!   --key KEY` (`cargo fw-flash`) writes it with probe-rs.

mod elf;
#[path = "../../firmware/src/flash_map.rs"]
#[allow(dead_code)]
mod flash_map;
mod hex;
mod links;
mod menagerie;

use std::env;
use std::fs;
use std::path::{Path, PathBuf};
use std::process::{Command, ExitCode, Stdio};
use std::time::Instant;

const THUMB: &str = "thumbv7em-none-eabihf";
/// The cell MCU's budget, flash and static RAM in bytes: what a small
/// Cortex-M4F of a skin cell offers (`memory.x`), so the firmware fits one.
const FLASH_BUDGET: u64 = 64 * 1024;
const RAM_BUDGET: u64 = 16 * 1024;
/// The bootloader's flash (`skin_firmware::flash_map::BOOTLOADER`).
const BOOTLOADER_BUDGET: u64 = 32 * 1024;
/// The cell programs, with the cargo features of their board.
const BOARDS: [(&str, &str); 2] = [("qemu", "cell-qemu"), ("stm32f4", "cell-stm32f4")];
/// Every firmware binary and its flash budget.
const BINARIES: [(&str, u64); 4] = [
    ("cell-qemu", FLASH_BUDGET),
    ("boot-qemu", BOOTLOADER_BUDGET),
    ("cell-stm32f4", FLASH_BUDGET),
    ("boot-stm32f4", BOOTLOADER_BUDGET),
];

/// The one build of every crate's tests, with every feature: each feature
/// set compiles skin-host and its test programs again.
const TEST_BUILD: &str = "test --workspace --features skin-host/ros2,skin-host/mujoco";

/// The test build's compiler for our crates: clippy's driver, which lints
/// as it compiles (`cargo clippy` sets the same two). So the build that
/// runs the tests is also the clippy run with ROS 2 and MuJoCo; a `cargo
/// clippy` with those features checked their stacks again, 185 s cold.
const LINTED: [(&str, &str); 2] = [("RUSTC_WORKSPACE_WRAPPER", "clippy-driver"), ("CLIPPY_ARGS", "-Dwarnings")];

/// What a step does.
enum Action {
    /// Runs a program with its output in the step's log.
    Run(&'static str, Vec<&'static str>),
    /// Runs [`TEST_BUILD`] with these arguments added, [`LINTED`].
    Test(Vec<&'static str>),
    /// Runs a test program of [`TEST_BUILD`] (the test target's name) with
    /// these arguments, as `cargo test` would: from its package's folder.
    /// A `cargo test --test NAME` resolves features anew and compiled
    /// skin-host and the ROS 2 stack again (161 s cold).
    TestProgram(&'static str, Vec<&'static str>),
    /// Runs a check of our own; `Ok` carries lines to print.
    Check(fn() -> Result<Vec<String>, String>),
}

/// One check of `cargo xtask ci`.
struct Step {
    name: &'static str,
    action: Action,
}

/// A cargo step; `args` are split on spaces.
fn cargo(name: &'static str, args: &'static str) -> Step {
    Step { name, action: Action::Run("cargo", args.split(' ').collect()) }
}

/// Every check of `cargo xtask ci`, in order.
fn ci_steps() -> Vec<Step> {
    vec![
        cargo("format", "fmt --all --check"),
        cargo("clippy (host crates)", "clippy --workspace --all-targets -- -D warnings"),
        cargo(
            "clippy (skin-host without the simulator glue)",
            "clippy -p skin-host --no-default-features -- -D warnings",
        ),
        cargo(
            "clippy (skin-protocol, thumb)",
            "clippy -p skin-protocol --target thumbv7em-none-eabihf --no-default-features --features defmt -- -D warnings",
        ),
        cargo(
            "clippy (firmware, qemu board)",
            "clippy -p skin-firmware --target thumbv7em-none-eabihf --features qemu --bins --examples -- -D warnings",
        ),
        cargo(
            "clippy (firmware, stm32f4 board)",
            "clippy -p skin-firmware --target thumbv7em-none-eabihf --features stm32f4 --bins -- -D warnings",
        ),
        cargo("docs", r#"doc --workspace --no-deps --config build.rustdocflags=["-D","warnings"]"#),
        // The benchmarks are built, not run, for clippy to see their ROS 2 code.
        Step {
            name: "clippy while building every crate's tests and benchmarks (with ROS 2 and the MuJoCo world)",
            action: Action::Test(vec!["--lib", "--bins", "--tests", "--examples", "--benches", "--no-run"]),
        },
        Step {
            // rclpy on Fast DDS, a Python zenoh peer and Foxglove client; libmujoco
            // of the pinned wheel, explore, a welded base, sim-endpoint over UDP,
            // robot_with_skin.xml read by MuJoCo's Python package. Every test
            // program runs, past a failing one: a failure hides no other.
            name: "tests (every crate, with ROS 2 on DDS and Zenoh, ros2_control, Foxglove and the MuJoCo world)",
            action: Action::Test(vec!["--no-fail-fast"]),
        },
        cargo("build skin-protocol (thumb)", "build -p skin-protocol --target thumbv7em-none-eabihf --no-default-features"),
        cargo(
            "build firmware and bootloader (qemu board)",
            "build -p skin-firmware --profile firmware --target thumbv7em-none-eabihf --features qemu --bins --examples",
        ),
        cargo(
            "build firmware and bootloader (stm32f4 board)",
            "build -p skin-firmware --profile firmware --target thumbv7em-none-eabihf --features stm32f4 --bins",
        ),
        Step { name: "firmware size within budget", action: Action::Check(firmware_size) },
        Step { name: "book (mdbook build docs)", action: Action::Run("mdbook", vec!["build", "docs"]) },
        Step { name: "book and README internal links", action: Action::Check(book_links) },
        Step {
            name: "QEMU tests (fault exits, 7-cell network)",
            action: Action::TestProgram("qemu", vec!["--ignored"]),
        },
        // The clean update of 7 cells is left to the heavy runs: the kill
        // test updates the same 7 cells to the end, one of them cut mid-write.
        Step {
            name: "QEMU update tests (7 cells: update with one killed mid-write, refusals; rollback on 3; a hanging trial image)",
            action: Action::TestProgram("qemu_update", vec!["--ignored", "--skip", "twenty", "--skip", "seven_cells"]),
        },
    ]
}

fn main() -> ExitCode {
    let args: Vec<String> = env::args().skip(1).collect();
    let root = workspace_root();
    if let Err(e) = env::set_current_dir(&root) {
        eprintln!("xtask: cannot enter the workspace root {}: {e}", root.display());
        return ExitCode::FAILURE;
    }
    let result = match args.first().map(String::as_str) {
        Some("ci") => return ci(&root),
        Some("install") => install(),
        Some("book") => run("mdbook", &["build", "docs"])
            .and_then(|()| book_links().map(|l| l.iter().for_each(|l| println!("{l}")))),
        Some("firmware") => firmware(),
        Some("qemu-net") => qemu_net(&args[1..]),
        Some("image") => image(&args[1..]).map(drop),
        Some("provision") => provision(&args[1..]).map(drop),
        Some("fw-flash") => fw_flash(&args[1..]),
        Some("menagerie") => menagerie::menagerie(&target_dir()),
        _ => {
            eprintln!(
                "usage: cargo xtask <command>\n\n  \
                 ci                   install what is missing, then run every CI check\n  \
                 install              only install what is missing (rustup target and components, qemu-system-arm, openssl, Python readers, mdbook)\n  \
                 book                 build the book into docs/book and check its internal links and the README's\n  \
                 firmware             build the cell firmware and bootloader for both boards and check their size\n  \
                 qemu-net --cells N   run a hexagonal patch of N QEMU cells (more flags: --json, --keep)\n  \
                 image --key KEY --version V [--board qemu|stm32f4] [--out FILE]\n                       \
                 build a board's firmware and sign it into an update image\n  \
                 provision --key KEY [--version V] [--out FILE]\n                       \
                 a new STM32F405 cell: bootloader and signed image in slot A as one Intel HEX file\n  \
                 fw-flash --key KEY [--version V]\n                       \
                 provision, then write it to a cell with probe-rs\n  \
                 menagerie            install MuJoCo Menagerie's robots from PyPI into target/menagerie (for SKIN_MJCF_DIR)"
            );
            return ExitCode::from(2);
        }
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("xtask: {e}");
            ExitCode::FAILURE
        }
    }
}

fn workspace_root() -> PathBuf {
    let manifest = env::var_os("CARGO_MANIFEST_DIR").map(PathBuf::from).unwrap_or_else(|| PathBuf::from("xtask"));
    manifest.parent().map(Path::to_path_buf).unwrap_or(manifest)
}

fn target_dir() -> PathBuf {
    env::var_os("CARGO_TARGET_DIR").map(PathBuf::from).unwrap_or_else(|| PathBuf::from("target"))
}

fn ci(root: &Path) -> ExitCode {
    let logs = root.join("target").join("xtask");
    if let Err(e) = fs::create_dir_all(&logs) {
        eprintln!("xtask: cannot create {}: {e}", logs.display());
        return ExitCode::FAILURE;
    }
    let (mut passed, mut failed) = (0, 0);
    let started = Instant::now();
    match install() {
        Ok(()) => {
            println!("ok    install ({:.1} s)", started.elapsed().as_secs_f64());
            passed += 1;
        }
        Err(e) => {
            println!("FAIL  install: {e}");
            failed += 1;
        }
    }
    for (i, s) in ci_steps().iter().enumerate() {
        let t = Instant::now();
        let log = logs.join(format!("{:02}-{}.log", i + 1, slug(s.name)));
        let outcome = match &s.action {
            Action::Run(program, args) => {
                let mut command = Command::new(program);
                command.args(args);
                run_logged(command, &log)
            }
            Action::Test(extra) => run_logged(test_build(extra), &log),
            Action::TestProgram(name, args) => test_program(name).and_then(|(program, dir)| {
                let mut command = Command::new(program);
                command.args(args).current_dir(dir);
                run_logged(command, &log)
            }),
            Action::Check(check) => check(),
        };
        let secs = t.elapsed().as_secs_f64();
        match outcome {
            Ok(lines) => {
                println!("ok    {} ({secs:.1} s)", s.name);
                lines.iter().for_each(|l| println!("      {l}"));
                passed += 1;
            }
            Err(why) => {
                println!("FAIL  {} ({secs:.1} s): {why}", s.name);
                print_tail(&log, 40);
                failed += 1;
            }
        }
    }
    println!("{passed} passed, {failed} failed ({:.0} s)", started.elapsed().as_secs_f64());
    if failed == 0 {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    }
}

fn slug(name: &str) -> String {
    let s: String =
        name.chars().map(|c| if c.is_ascii_alphanumeric() { c.to_ascii_lowercase() } else { '-' }).collect();
    s.split('-').filter(|p| !p.is_empty()).collect::<Vec<_>>().join("-")
}

/// Runs `command` with its output in a log file.
fn run_logged(mut command: Command, log: &Path) -> Result<Vec<String>, String> {
    let words: Vec<_> = std::iter::once(command.get_program())
        .chain(command.get_args())
        .map(|w| w.to_string_lossy().into_owned())
        .collect();
    let failed = || format!("`{}`, log {}", words.join(" "), log.display());
    let out = fs::File::create(log).map_err(|_| failed())?;
    let err = out.try_clone().map_err(|_| failed())?;
    let status = command.stdin(Stdio::null()).stdout(out).stderr(err).status();
    status.is_ok_and(|s| s.success()).then(Vec::new).ok_or_else(failed)
}

/// `cargo` running [`TEST_BUILD`] with `extra` arguments, [`LINTED`].
fn test_build(extra: &[&str]) -> Command {
    let mut command = Command::new("cargo");
    command.args(TEST_BUILD.split(' ')).args(extra).envs(LINTED);
    command
}

/// Where test program `name` of [`TEST_BUILD`] is (built by then: cargo
/// only says where), and its package's folder, which `cargo test` runs it in.
fn test_program(name: &str) -> Result<(String, PathBuf), String> {
    let out = test_build(&["--no-run", "--message-format=json"])
        .stderr(Stdio::null())
        .output()
        .map_err(|e| format!("cannot run cargo: {e}"))?;
    let listing = String::from_utf8_lossy(&out.stdout);
    let (program, manifest) = listing
        .lines()
        .filter(|l| l.contains("\"kind\":[\"test\"]") && l.contains(&format!("\"name\":\"{name}\",")))
        .find_map(|l| Some((json_string(l, "executable")?, json_string(l, "manifest_path")?)))
        .ok_or_else(|| format!("`cargo {TEST_BUILD} --no-run` lists no test program {name}"))?;
    let dir = Path::new(&manifest).parent().ok_or_else(|| format!("no folder in {manifest}"))?;
    Ok((program, dir.to_path_buf()))
}

/// The string value of `key` in one line of cargo's JSON messages, when it
/// has no escapes (cargo's paths here have none).
fn json_string(line: &str, key: &str) -> Option<String> {
    let start = line.find(&format!("\"{key}\":\""))? + key.len() + 4;
    let value = &line[start..start + line[start..].find('"')?];
    (!value.contains('\\')).then(|| value.to_owned())
}

/// What a failed step's log says of its failure: each failing test's
/// panic (its header and the message after it; with `--no-fail-fast` a
/// later test program's output would push them out of the tail), then
/// the log's last `lines`.
fn print_tail(log: &Path, lines: usize) {
    if let Ok(text) = fs::read_to_string(log) {
        let all: Vec<&str> = text.lines().collect();
        let tail = all.len().saturating_sub(lines);
        for l in panics(&all[..tail]).into_iter().chain(all[tail..].iter().copied()) {
            println!("      | {l}");
        }
    }
}

/// The lines of `log` that say why a test failed: `---- name stdout ----`
/// and up to six lines from each `panicked at`.
fn panics<'a>(log: &[&'a str]) -> Vec<&'a str> {
    let mut keep = vec![false; log.len()];
    for (i, l) in log.iter().enumerate() {
        if l.starts_with("---- ") {
            keep[i] = true;
        }
        if l.contains("panicked at") {
            keep[i..(i + 6).min(log.len())].iter_mut().for_each(|k| *k = true);
        }
    }
    log.iter().zip(keep).filter(|(_, k)| *k).map(|(l, _)| *l).collect()
}

fn succeeds(program: &str, args: &[&str]) -> bool {
    Command::new(program).args(args).stdout(Stdio::null()).stderr(Stdio::null()).status().is_ok_and(|s| s.success())
}

fn output(program: &str, args: &[&str]) -> Option<String> {
    let out = Command::new(program).args(args).stderr(Stdio::null()).output().ok()?;
    out.status.success().then(|| String::from_utf8_lossy(&out.stdout).into_owned())
}

/// Runs a program in the foreground, its output going to ours.
fn run(program: &str, args: &[&str]) -> Result<(), String> {
    let status = Command::new(program)
        .args(args)
        .env("DEBIAN_FRONTEND", "noninteractive")
        .stdin(Stdio::null())
        .status()
        .map_err(|e| format!("cannot run {program}: {e}"))?;
    status.success().then_some(()).ok_or_else(|| format!("`{program} {}` failed ({status})", args.join(" ")))
}

/// Installs what a fresh machine lacks: the thumb target, rustfmt and
/// clippy, QEMU for the firmware tests and Python 3 for the object-file
/// interop test (from Debian's packages when running as root; otherwise
/// says the command to run).
fn install() -> Result<(), String> {
    let targets = output("rustup", &["target", "list", "--installed"]).ok_or("rustup is not available")?;
    if !targets.lines().any(|t| t.trim() == THUMB) {
        run("rustup", &["target", "add", THUMB])?;
    }
    for (probe, component) in [("fmt", "rustfmt"), ("clippy", "clippy")] {
        if !succeeds("cargo", &[probe, "--version"]) {
            run("rustup", &["component", "add", component])?;
        }
    }
    // QEMU runs the firmware tests; OpenSSL checks our update keys and
    // signatures, Python 3.11+ (its tomllib) our object files: readers we
    // did not write.
    let missing: Vec<&str> = [
        ("qemu-system-arm", &["--version"][..]),
        ("openssl", &["version"][..]),
        ("python3", &["-c", "import tomllib"][..]),
    ]
    .into_iter()
    .filter(|(program, args)| !succeeds(program, args))
    .map(|(program, _)| program)
    .collect();
    mdbook()?;
    if !missing.is_empty() {
        let root = output("id", &["-u"]).is_some_and(|u| u.trim() == "0");
        if !root {
            return Err(format!("missing: run `sudo apt-get install -y {}`", missing.join(" ")));
        }
        run("apt-get", &["update", "-q"])?;
        let mut args = vec!["install", "-y", "-q"];
        args.extend(&missing);
        run("apt-get", &args)?;
    }
    python_readers()?;
    mujoco_library()?;
    ros_python()
}

/// The mdBook the book is built with; CI installs exactly this one.
const MDBOOK_VERSION: &str = "0.5.4";

/// Installs [`MDBOOK_VERSION`] of mdBook unless it is there, without the
/// default features (a file watcher, a web server with tokio and axum, and
/// search), which `mdbook build` does not need: 122 crates to compile.
fn mdbook() -> Result<(), String> {
    let installed = output("mdbook", &["--version"]);
    if installed.is_some_and(|v| v.trim() == format!("mdbook v{MDBOOK_VERSION}")) {
        return Ok(());
    }
    run("cargo", &["install", "mdbook", "--version", MDBOOK_VERSION, "--locked", "--no-default-features"])
}

/// Every relative link and anchor of the README and the book resolves.
fn book_links() -> Result<Vec<String>, String> {
    let pages = links::pages(Path::new("."))?;
    let broken = links::check(&pages)?;
    if broken.is_empty() {
        Ok(vec![format!("{} pages, every internal link resolves", pages.len())])
    } else {
        Err(format!("{} broken links:\n      {}", broken.len(), broken.join("\n      ")))
    }
}

/// The Python readers the tests check our files and our live topics with
/// (readers we did not write), pinned, in a venv under the target
/// directory: rosbags and mcap-ros2-support read MCAP and CDR,
/// eclipse-zenoh subscribes as a ROS 2 machine's peer would, ROS's own
/// urdf_parser_py reads our URDF with skin frames, and websockets with
/// protobuf watch the Foxglove view as a Foxglove client would.
const PYTHON_READERS: [&str; 6] = [
    "rosbags==0.11.9",
    "mcap-ros2-support==0.6.0",
    "eclipse-zenoh==1.10.2",
    "urdf-parser-py==0.0.4",
    "websockets==15.0.1",
    "protobuf==6.31.1",
];

/// Creates the venv `target/pyenv` with [`PYTHON_READERS`]; without
/// python3 it says that those tests will be skipped.
fn python_readers() -> Result<(), String> {
    if !succeeds("python3", &["--version"]) {
        eprintln!("xtask: python3 is missing: the tests reading our ROS 2 files with rosbags will be skipped");
        return Ok(());
    }
    let venv = target_dir().join("pyenv");
    let python = venv.join("bin").join("python");
    let python = python.to_str().ok_or("the target directory's path is not UTF-8")?;
    if !Path::new(python).exists() {
        run("python3", &["-m", "venv", venv.to_str().ok_or("the target directory's path is not UTF-8")?])?;
    }
    if !succeeds(python, &["-c", "import rosbags, mcap_ros2, zenoh, urdf_parser_py, websockets, google.protobuf"]) {
        let mut args = vec!["-m", "pip", "install", "-q"];
        args.extend(PYTHON_READERS);
        run(python, &args)?;
    }
    Ok(())
}

/// The MuJoCo the `mujoco` feature links: the pinned wheel carries
/// `libmujoco.so.3.17.0` (libc and libm only), the version mujoco-rs 7.0.0
/// binds.
const MUJOCO_WHEEL: &str = "mujoco==3.17.0";
const MUJOCO_LIBRARY: &str = "libmujoco.so.3.17.0";
/// Where `.cargo/config.toml` points mujoco-rs (`MUJOCO_DYNAMIC_LINK_DIR`)
/// and the build scripts point the binaries' rpath.
const MUJOCO_LINK_DIR: &str = "target/mujoco/lib";

/// Installs [`MUJOCO_WHEEL`] into the readers' venv and links its library
/// into [`MUJOCO_LINK_DIR`] under both names the build needs: `libmujoco.so`
/// to link, the soname to load.
fn mujoco_library() -> Result<(), String> {
    let python = target_dir().join("pyenv").join("bin").join("python");
    if !python.exists() {
        eprintln!("xtask: no Python venv: the MuJoCo world (`--features mujoco`) cannot be built");
        return Ok(());
    }
    let python = python.to_str().ok_or("the target directory's path is not UTF-8")?;
    let locate = "import mujoco, os; print(os.path.dirname(mujoco.__file__))";
    let package = match output(python, &["-c", locate]) {
        Some(dir) => dir,
        None => {
            run(python, &["-m", "pip", "install", "-q", MUJOCO_WHEEL])?;
            output(python, &["-c", locate]).ok_or("the mujoco wheel installed but does not import")?
        }
    };
    let library = fs::canonicalize(Path::new(package.trim()).join(MUJOCO_LIBRARY))
        .map_err(|e| format!("the mujoco wheel has no {MUJOCO_LIBRARY}: {e}"))?;
    let dir = Path::new(MUJOCO_LINK_DIR);
    fs::create_dir_all(dir).map_err(|e| format!("cannot create {MUJOCO_LINK_DIR}: {e}"))?;
    for name in ["libmujoco.so", MUJOCO_LIBRARY] {
        let link = dir.join(name);
        if fs::read_link(&link).is_ok_and(|to| to == library) {
            continue;
        }
        let _ = fs::remove_file(&link);
        std::os::unix::fs::symlink(&library, &link)
            .map_err(|e| format!("cannot link {} to {}: {e}", link.display(), library.display()))?;
    }
    Ok(())
}

/// Real ROS 2 Jazzy from PyPI, pinned: rclpy on Fast DDS (the default
/// RMW) and the message packages of the skin's topics and of
/// ros2_control's velocity controllers; tf2_msgs has no wheel.
const ROS_WHEELS: [&str; 8] = [
    "ros-jazzy-rclpy==7.1.6",
    "ros-jazzy-rmw-fastrtps-cpp==8.4.3",
    "ros-jazzy-builtin-interfaces==2.0.3",
    "ros-jazzy-rcl-interfaces==2.0.3",
    "ros-jazzy-std-msgs==5.3.6",
    "ros-jazzy-sensor-msgs==5.3.6",
    "ros-jazzy-geometry-msgs==5.3.6",
    "ros-jazzy-visualization-msgs==5.3.6",
];

/// Creates the venv `target/rosenv` with [`ROS_WHEELS`] (apart from the
/// readers' venv: ROS pins its own Python packages), for the tests that
/// check the skin with rclpy; the wheels are built for Python 3.11.
fn ros_python() -> Result<(), String> {
    let Some(python3_11) = ["python3.11", "python3"].into_iter().find(|p| {
        output(p, &["-c", "import sys; print(sys.version_info[:2] == (3, 11))"]).is_some_and(|o| o.trim() == "True")
    }) else {
        eprintln!("xtask: no Python 3.11: the rclpy tests of ROS 2 over DDS will be skipped");
        return Ok(());
    };
    let venv = target_dir().join("rosenv");
    let python = venv.join("bin").join("python");
    let python = python.to_str().ok_or("the target directory's path is not UTF-8")?;
    if !Path::new(python).exists() {
        run(python3_11, &["-m", "venv", venv.to_str().ok_or("the target directory's path is not UTF-8")?])?;
    }
    let check =
        "import rclpy, rmw_fastrtps_cpp, sensor_msgs.msg, std_msgs.msg, visualization_msgs.msg, rcl_interfaces.srv";
    if !succeeds(python, &["-c", check]) {
        let mut args = vec!["-m", "pip", "install", "-q"];
        args.extend(ROS_WHEELS);
        run(python, &args)?;
    }
    Ok(())
}

/// Builds a board's cell program and bootloader.
fn build_board(features: &str) -> Result<(), String> {
    let mut args = vec!["build", "-p", "skin-firmware", "--profile", "firmware", "--target", THUMB];
    args.extend(["--features", features, "--bins"]);
    run("cargo", &args)
}

/// `cargo xtask firmware`: builds both boards and prints their size.
fn firmware() -> Result<(), String> {
    for (features, _) in BOARDS {
        build_board(features)?;
    }
    firmware_size()?.iter().for_each(|l| println!("{l}"));
    Ok(())
}

/// Flash and static RAM of each binary against its budget.
fn firmware_size() -> Result<Vec<String>, String> {
    let dir = target_dir().join(THUMB).join("firmware");
    let mut lines = Vec::new();
    let mut over = Vec::new();
    for (bin, flash_budget) in BINARIES {
        let path = dir.join(bin);
        let bytes = fs::read(&path).map_err(|e| format!("cannot read {}: {e}", path.display()))?;
        let size = elf::size(&bytes).map_err(|e| format!("{}: {e}", path.display()))?;
        lines.push(format!(
            "{bin}: flash {} B of {} ({:.0}%), static RAM {} B of {} ({:.0}%)",
            size.flash,
            flash_budget,
            100.0 * size.flash as f64 / flash_budget as f64,
            size.ram,
            RAM_BUDGET,
            100.0 * size.ram as f64 / RAM_BUDGET as f64,
        ));
        if size.flash > flash_budget || size.ram > RAM_BUDGET {
            over.push(bin);
        }
    }
    if over.is_empty() {
        Ok(lines)
    } else {
        Err(format!("over budget: {} ({})", over.join(", "), lines.join("; ")))
    }
}

/// A flag's value in `args`.
fn flag<'a>(args: &'a [String], name: &str) -> Option<&'a str> {
    args.iter().position(|a| a == name).and_then(|i| args.get(i + 1)).map(String::as_str)
}

/// `cargo xtask image --key KEY --version V [--board B] [--out FILE]`:
/// builds the board's firmware, flattens its ELF and signs it with `skin
/// sign`; returns the signed image's path.
fn image(args: &[String]) -> Result<PathBuf, String> {
    let key = flag(args, "--key").ok_or("image needs --key KEY (make one with `skin keygen`)")?;
    let version = flag(args, "--version").ok_or("image needs --version V")?;
    let board = flag(args, "--board").unwrap_or("qemu");
    let (features, bin) = BOARDS
        .into_iter()
        .find(|(b, _)| *b == board)
        .ok_or_else(|| format!("unknown --board {board}; one of {}", BOARDS.map(|(b, _)| b).join(", ")))?;
    let signed_board = if board == "qemu" { "mps2-an386" } else { "stm32f405" };
    build_board(features)?;
    let elf_path = target_dir().join(THUMB).join("firmware").join(bin);
    let (at, flat) = flat_elf(&elf_path)?;
    let program = elf_path.with_extension("bin");
    fs::write(&program, &flat).map_err(|e| format!("cannot write {}: {e}", program.display()))?;
    println!("{}: {} bytes loaded at {at:#010x}", program.display(), flat.len());
    let out = flag(args, "--out").map(PathBuf::from).unwrap_or_else(|| elf_path.with_extension("skfw"));
    let program = program.display().to_string();
    let out_arg = out.display().to_string();
    run(
        "cargo",
        &[
            "run",
            "--quiet",
            "-p",
            "skin-host",
            "--",
            "sign",
            &program,
            "--key",
            key,
            "--version",
            version,
            "--board",
            signed_board,
            "--out",
            &out_arg,
        ],
    )?;
    Ok(out)
}

/// An ELF file's flash contents and where they start.
fn flat_elf(path: &Path) -> Result<(u32, Vec<u8>), String> {
    let bytes = fs::read(path).map_err(|e| format!("cannot read {}: {e}", path.display()))?;
    elf::flat_binary(&bytes).map_err(|e| format!("{}: {e}", path.display()))
}

/// `cargo xtask provision --key KEY [--version V] [--out FILE]`: what a new
/// STM32F405 cell needs through a debug probe, as one Intel HEX file:
/// `boot-stm32f4` in sectors 0-1, the cell program signed with KEY (version
/// V, 1 by default) in slot A, and one erased byte in each boot record
/// sector, so that the probe erases them (probe-rs erases every sector it
/// writes to) and the bootloader starts from slot A. The settings store
/// (ID, offsets) is not touched. The firmware must trust KEY: build with
/// `SKIN_UPDATE_KEY` set to its public key, or the bootloader boots nothing.
fn provision(args: &[String]) -> Result<PathBuf, String> {
    use flash_map::{BOOTLOADER, STM32F4, STM32F4_FLASH};
    let version = flag(args, "--version").unwrap_or("1").to_owned();
    let key = flag(args, "--key").ok_or("provision needs --key KEY (make one with `skin keygen`)")?.to_owned();
    let signed = image(&["--key".into(), key, "--version".into(), version, "--board".into(), "stm32f4".into()])?;
    let image = fs::read(&signed).map_err(|e| format!("cannot read {}: {e}", signed.display()))?;
    let boot_elf = target_dir().join(THUMB).join("firmware").join("boot-stm32f4");
    let (at, boot) = flat_elf(&boot_elf)?;
    let region = BOOTLOADER[1].1;
    if at != region.base || boot.len() as u32 > region.len {
        return Err(format!(
            "{}: {} bytes at {at:#x}, not within the bootloader's sectors",
            boot_elf.display(),
            boot.len()
        ));
    }
    if image.len() as u32 > STM32F4.slots[0].len {
        return Err(format!("{}: {} bytes, longer than slot A", signed.display(), image.len()));
    }
    let erased = [0xFFu8];
    let records = STM32F4_FLASH + STM32F4.records.base;
    let half = STM32F4.records.len / 2;
    let text = hex::encode(&[
        (at, &boot),
        (STM32F4_FLASH + STM32F4.slots[0].base, &image),
        (records, &erased),
        (records + half, &erased),
    ]);
    let default_out = boot_elf.with_file_name("provision-stm32f4.hex");
    let out = flag(args, "--out").map(PathBuf::from).unwrap_or(default_out);
    fs::write(&out, text).map_err(|e| format!("cannot write {}: {e}", out.display()))?;
    println!(
        "{}: bootloader ({} B) at {at:#010x}, signed image ({} B) in slot A at {:#010x}, boot record erased",
        out.display(),
        boot.len(),
        image.len(),
        STM32F4_FLASH + STM32F4.slots[0].base
    );
    Ok(out)
}

/// `cargo xtask fw-flash --key KEY [--version V]` (`cargo fw-flash`):
/// provisions, then writes the file to the cell on the probe and starts it.
fn fw_flash(args: &[String]) -> Result<(), String> {
    let hex = provision(args)?;
    let hex = hex.display().to_string();
    run("probe-rs", &["download", "--chip", "STM32F405RGTx", "--binary-format", "hex", &hex])?;
    run("probe-rs", &["reset", "--chip", "STM32F405RGTx"])?;
    let elf = target_dir().join(THUMB).join("firmware").join("cell-stm32f4");
    println!("cell logs: probe-rs attach --chip STM32F405RGTx {}", elf.display());
    Ok(())
}

/// `cargo xtask qemu-net --cells N ...`: builds the QEMU board and runs the
/// network of QEMU cells.
fn qemu_net(args: &[String]) -> Result<(), String> {
    build_board("qemu")?;
    let mut all = vec!["run", "--quiet", "-p", "skin-tests", "--bin", "qemu-net", "--"];
    all.extend(args.iter().map(String::as_str));
    run("cargo", &all)
}

#[cfg(test)]
mod tests {
    use super::json_string;

    /// A compiler-artifact line as cargo 1.95 prints it (shortened).
    const ARTIFACT: &str = r#"{"reason":"compiler-artifact","manifest_path":"/w/tests/Cargo.toml","target":{"kind":["test"],"crate_types":["bin"],"name":"qemu","src_path":"/w/tests/tests/qemu.rs","test":true},"executable":"/w/target/debug/deps/qemu-63ba01df0dff747a","fresh":true}"#;

    #[test]
    fn a_failed_logs_panics_are_picked_out() {
        let log = [
            "running 2 tests",
            "test a ... ok",
            "---- b stdout ----",
            "",
            "thread 'b' panicked at host/tests/b.rs:3:5:",
            "b failed: why",
            "stack backtrace:",
            "   0: x",
            "   1: y",
            "   2: z",
            "   3: w",
            "test result: FAILED. 1 passed; 1 failed",
        ];
        assert_eq!(
            super::panics(&log),
            [
                "---- b stdout ----",
                "thread 'b' panicked at host/tests/b.rs:3:5:",
                "b failed: why",
                "stack backtrace:",
                "   0: x",
                "   1: y",
                "   2: z"
            ]
        );
        assert!(super::panics(&log[..2]).is_empty());
    }

    #[test]
    fn a_test_program_and_its_package_are_read_from_cargos_json() {
        assert_eq!(json_string(ARTIFACT, "executable").as_deref(), Some("/w/target/debug/deps/qemu-63ba01df0dff747a"));
        assert_eq!(json_string(ARTIFACT, "manifest_path").as_deref(), Some("/w/tests/Cargo.toml"));
        assert_eq!(json_string(ARTIFACT, "missing"), None);
        // A value with an escape is not read as a path.
        assert_eq!(json_string(r#"{"executable":"C:\\t\\q.exe"}"#, "executable"), None);
        assert_eq!(json_string(r#"{"executable":null}"#, "executable"), None);
    }
}
