//! One QEMU cell whose trial image hangs without crashing: only the
//! hardware watchdog the bootloader arms can reset it, and the bootloader
//! must then go back to the old image, which keeps running (it feeds the
//! watchdog).

use std::path::Path;
use std::thread::sleep;
use std::time::{Duration, Instant};

use skin_firmware::boot::BootRecord;
use skin_protocol::image::{self, Board};

use super::cells::{CellCommand, Cells};
use super::flash::{self, hanging_body, Programs, DEVELOPMENT_SEED};
use super::net::run_dir;
use super::QemuError;

/// What the cell did.
#[derive(Clone, Debug)]
pub struct HangReport {
    /// Wall time from the start of QEMU until the record said the trial failed.
    pub rollback_s: f64,
    /// The boot record then.
    pub record: BootRecord,
    /// Bootloader starts over the whole run (QEMU's stderr).
    pub boots: usize,
    /// Stack reports of the cell program after the rollback: it ran its main loop.
    pub program_reports: usize,
}

/// The version of the hanging image.
pub const HANGING_VERSION: u32 = 2;

/// Starts one cell of the `cell-qemu` program `elf` with version 1
/// confirmed in slot A and a genuine, signed image that hangs in slot B,
/// its trial asked for; waits (at most `limit`) until its boot record says
/// the trial failed, then lets it run `settle` more.
pub fn hanging_trial(elf: &Path, limit: Duration, settle: Duration) -> Result<HangReport, QemuError> {
    let dir = run_dir()?;
    let programs = Programs::load(elf)?;
    let flash = dir.join("cell0.flash");
    flash::provision(&flash, &programs.genuine(1))?;
    let hanging =
        image::sign(&hanging_body(), Board::Mps2An386, HANGING_VERSION, &DEVELOPMENT_SEED).unwrap_or_default();
    flash::write_slot(&flash, 1, &hanging)?;
    flash::write_record(&flash, BootRecord::default().request_trial(HANGING_VERSION))?;
    let mut cells = Cells::new(&dir, vec![CellCommand::new(&programs.bootloader, &flash, Default::default())]);
    cells.start(0)?;
    let start = Instant::now();
    let (record, rollback_s) = loop {
        cells.check_alive()?;
        // A record read while the cell writes it may not open: not yet.
        if let Ok(record) = flash::record(&flash) {
            if record.failed.is_some() && record.trial.is_none() {
                break (record, start.elapsed().as_secs_f64());
            }
        }
        if start.elapsed() > limit {
            let detail = format!("boot record {:?}", flash::record(&flash));
            return Err(QemuError::Timeout { stage: "watchdog reset", seconds: limit.as_secs_f64(), detail });
        }
        sleep(Duration::from_millis(20));
    };
    let end = Instant::now() + settle;
    while Instant::now() < end {
        cells.check_alive()?;
        sleep(Duration::from_millis(50));
    }
    let log = std::fs::read_to_string(cells.qemu_log(0)).unwrap_or_default();
    cells.stop();
    let boots = log.lines().filter(|l| l.starts_with("bootloader stack peak")).count();
    let after = log.lines().skip_while(|l| !l.starts_with("bootloader stack peak")).skip(1);
    let after = after.skip_while(|l| !l.starts_with("bootloader stack peak")).skip(1);
    let program_reports = after.filter(|l| l.starts_with("stack peak")).count();
    let _ = std::fs::remove_dir_all(&dir);
    Ok(HangReport { rollback_s, record, boots, program_reports })
}
