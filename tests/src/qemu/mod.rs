//! QEMU skin cells, wired into a patch, with an interface port and a host.
//!
//! Each cell is one `qemu-system-arm` process running the `cell-qemu`
//! firmware on the mps2-an386 board. Ports of neighbouring cells are joined
//! by a Unix socket pair (`-chardev socket`), UART0 of every cell takes
//! stimulus frames from the harness, and one free port of one cell is the
//! interface port: a [`gateway::Gateway`] turns its frames into UDP
//! datagrams for the [`host::Host`] on loopback, and back.

pub mod cells;
pub mod flash;
pub mod gateway;
pub mod hang;
pub mod hex;
pub mod host;
pub mod net;
pub mod update;

use std::path::PathBuf;

/// What can go wrong running QEMU cells.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum QemuError {
    /// The firmware image is not where it was looked for.
    #[error("no firmware at {0}: build it with `cargo build -p skin-firmware --profile firmware --target thumbv7em-none-eabihf --features qemu --bins --examples` or pass --elf")]
    MissingElf(PathBuf),
    /// QEMU could not be started.
    #[error("cannot start {program}: {source} (install it with `apt-get install qemu-system-arm`)")]
    Spawn {
        /// The QEMU program.
        program: String,
        /// Why.
        source: std::io::Error,
    },
    /// A cell's QEMU ended on its own.
    #[error("cell {cell} exited with {status}; its log is {log}")]
    CellExited {
        /// The cell's index in the patch.
        cell: usize,
        /// Its exit status.
        status: std::process::ExitStatus,
        /// Its QEMU log file.
        log: PathBuf,
    },
    /// A stage did not reach its goal in time.
    #[error("{stage} did not complete in {seconds} s: {detail}")]
    Timeout {
        /// The stage.
        stage: &'static str,
        /// Its time limit.
        seconds: f64,
        /// What was still missing.
        detail: String,
    },
    /// A patch of fewer than two cells, or one without a free port for the interface.
    #[error("a patch needs 2 to 40 cells, got {0}")]
    BadSize(usize),
    /// Sockets, files or processes failed.
    #[error("{context}: {source}")]
    Io {
        /// What was being done.
        context: String,
        /// Why it failed.
        source: std::io::Error,
    },
}

/// Adds what was being done to an I/O error.
pub(crate) trait Context<T> {
    fn context(self, what: impl FnOnce() -> String) -> Result<T, QemuError>;
}

impl<T> Context<T> for std::io::Result<T> {
    fn context(self, what: impl FnOnce() -> String) -> Result<T, QemuError> {
        self.map_err(|source| QemuError::Io { context: what(), source })
    }
}

/// Where `cargo build --profile firmware --target thumbv7em-none-eabihf` puts the
/// firmware: `$CARGO_TARGET_DIR` or the workspace's `target`.
pub fn default_elf_dir() -> PathBuf {
    let target = std::env::var_os("CARGO_TARGET_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..").join("target"));
    target.join("thumbv7em-none-eabihf").join("firmware")
}
