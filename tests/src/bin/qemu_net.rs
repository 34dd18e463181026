//! Runs the QEMU network test: `cargo run -p skin-tests --bin qemu-net -- --cells 7`.

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Duration;

use clap::Parser;
use indicatif::{ProgressBar, ProgressStyle};
use skin_tests::qemu::net::{self, NetOptions};

/// A hexagonal patch of QEMU skin cells running the firmware: self-organization,
/// configuration, sample delivery, and the death and return of a cell.
#[derive(Parser, Debug)]
struct Args {
    /// Cells in the patch (2 to 40).
    #[arg(long, default_value_t = 7)]
    cells: usize,
    /// The cell-qemu firmware image [default: TARGET_DIR/thumbv7em-none-eabihf/firmware/cell-qemu].
    #[arg(long)]
    elf: Option<PathBuf>,
    /// Keep the run directory (sockets, stores, defmt logs of the cells).
    #[arg(long)]
    keep: bool,
    /// Print the report as JSON.
    #[arg(long)]
    json: bool,
}

fn main() -> ExitCode {
    tracing_subscriber::fmt()
        .with_env_filter(tracing_subscriber::EnvFilter::from_default_env())
        .with_writer(std::io::stderr)
        .init();
    let args = Args::parse();
    let elf = args.elf.unwrap_or_else(|| skin_tests::qemu::default_elf_dir().join("cell-qemu"));
    let bar = ProgressBar::new_spinner().with_style(
        ProgressStyle::with_template("{spinner} {elapsed} {msg}").unwrap_or_else(|_| ProgressStyle::default_spinner()),
    );
    bar.enable_steady_tick(Duration::from_millis(100));
    let result = net::run(&NetOptions { cells: args.cells, elf, keep: args.keep }, &mut |stage| {
        bar.set_message(stage.to_owned())
    });
    bar.finish_and_clear();
    match result {
        Ok(report) if args.json => {
            println!("{}", serde_json::to_string_pretty(&report).unwrap_or_default());
            ExitCode::SUCCESS
        }
        Ok(r) => {
            println!(
                "qemu-net: {} cells, {} links, IDs {:?}: organized in {:.2} s, configured in {:.2} s, samples in {:.2} s; \
                 cell {} killed: others re-attached in {:.2} s; restarted: back with its ID in {:.2} s",
                r.cells, r.links, r.ids, r.organize_s, r.configure_s, r.samples_s, r.killed, r.reattach_s, r.rejoin_s
            );
            println!(
                "QEMU cells: {:.1} CPU-s in {:.1} s ({:.2} cores on average), {:.1} s waiting for a CPU",
                r.cpu.run_s,
                r.wall_s,
                r.cpu.run_s / r.wall_s,
                r.cpu.wait_s
            );
            if let Some(s) = r.stack {
                println!("stack: deepest of all cells {} bytes of {} reserved", s.peak_bytes, s.reserved_bytes);
            }
            println!("1 passed, 0 failed");
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("qemu-net: {e}");
            ExitCode::FAILURE
        }
    }
}
