//! The project's task runner, in the `cargo xtask` way: plain Rust, no
//! dependencies, so it builds in seconds on a fresh machine.
//!
//! - `cargo xtask ci`: installs what a fresh machine lacks, then runs every
//!   check CI runs, one line per step, and a final `N passed, N failed`.
//! - `cargo xtask install`: only the installation part.

use std::env;
use std::fs;
use std::path::{Path, PathBuf};
use std::process::{Command, ExitCode, Stdio};
use std::time::Instant;

const THUMB: &str = "thumbv7em-none-eabihf";

/// One check: a name and the command that runs it.
struct Step {
    name: &'static str,
    program: &'static str,
    args: Vec<&'static str>,
}

fn step(name: &'static str, program: &'static str, args: &[&'static str]) -> Step {
    Step { name, program, args: args.to_vec() }
}

fn cargo(name: &'static str, args: &[&'static str]) -> Step {
    step(name, "cargo", args)
}

/// Every check of `cargo xtask ci`, in order.
fn ci_steps() -> Vec<Step> {
    vec![
        cargo("format", &["fmt", "--all", "--check"]),
        cargo("clippy (host crates)", &["clippy", "--workspace", "--all-targets", "--", "-D", "warnings"]),
        cargo(
            "clippy (no_std crates, thumb)",
            &[
                "clippy",
                "-p",
                "skin-protocol",
                "--target",
                THUMB,
                "--no-default-features",
                "--features",
                "defmt",
                "--",
                "-D",
                "warnings",
            ],
        ),
        cargo("tests (host)", &["test", "--workspace"]),
        cargo(
            "build skin-protocol (thumb)",
            &["build", "-p", "skin-protocol", "--target", THUMB, "--no-default-features"],
        ),
    ]
}

fn main() -> ExitCode {
    let args: Vec<String> = env::args().skip(1).collect();
    let root = workspace_root();
    if let Err(e) = env::set_current_dir(&root) {
        eprintln!("xtask: cannot enter the workspace root {}: {e}", root.display());
        return ExitCode::FAILURE;
    }
    match args.first().map(String::as_str) {
        Some("ci") => ci(&root),
        Some("install") => match install() {
            Ok(()) => ExitCode::SUCCESS,
            Err(e) => {
                eprintln!("xtask install: {e}");
                ExitCode::FAILURE
            }
        },
        _ => {
            eprintln!("usage: cargo xtask <command>\n\n  ci        install what is missing, then run every CI check\n  install   only install what is missing (rustup target and components, qemu-system-arm)");
            ExitCode::from(2)
        }
    }
}

fn workspace_root() -> PathBuf {
    let manifest = env::var_os("CARGO_MANIFEST_DIR").map(PathBuf::from).unwrap_or_else(|| PathBuf::from("xtask"));
    manifest.parent().map(Path::to_path_buf).unwrap_or(manifest)
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
        let log = logs.join(format!("{:02}-{}.log", i + 1, slug(s.name)));
        let t = Instant::now();
        let ok = run_logged(s, &log);
        let secs = t.elapsed().as_secs_f64();
        if ok {
            println!("ok    {} ({secs:.1} s)", s.name);
            passed += 1;
        } else {
            println!("FAIL  {} ({secs:.1} s): `{} {}`, log {}", s.name, s.program, s.args.join(" "), log.display());
            print_tail(&log, 40);
            failed += 1;
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

/// Runs a step with its output in a log file; true on success.
fn run_logged(s: &Step, log: &Path) -> bool {
    let Ok(out) = fs::File::create(log) else { return false };
    let Ok(err) = out.try_clone() else { return false };
    Command::new(s.program)
        .args(&s.args)
        .stdin(Stdio::null())
        .stdout(out)
        .stderr(err)
        .status()
        .is_ok_and(|st| st.success())
}

fn print_tail(log: &Path, lines: usize) {
    if let Ok(text) = fs::read_to_string(log) {
        let all: Vec<&str> = text.lines().collect();
        for l in &all[all.len().saturating_sub(lines)..] {
            println!("      | {l}");
        }
    }
}

fn succeeds(program: &str, args: &[&str]) -> bool {
    Command::new(program).args(args).stdout(Stdio::null()).stderr(Stdio::null()).status().is_ok_and(|s| s.success())
}

fn output(program: &str, args: &[&str]) -> Option<String> {
    let out = Command::new(program).args(args).stderr(Stdio::null()).output().ok()?;
    out.status.success().then(|| String::from_utf8_lossy(&out.stdout).into_owned())
}

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
/// clippy, and QEMU for the firmware tests (from Debian's packages when
/// running as root; otherwise says the command to run).
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
    if !succeeds("qemu-system-arm", &["--version"]) {
        let root = output("id", &["-u"]).is_some_and(|u| u.trim() == "0");
        if !root {
            return Err("qemu-system-arm is missing: run `sudo apt-get install -y qemu-system-arm`".into());
        }
        run("apt-get", &["update", "-q"])?;
        run("apt-get", &["install", "-y", "-q", "qemu-system-arm"])?;
    }
    Ok(())
}
