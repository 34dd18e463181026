//! Writing a folder all at once: the new content goes into a temporary
//! folder beside the target and is renamed into place, so a crash, a full
//! disk or a failed figure leaves the old folder whole, never half old and
//! half new.

use std::io;
use std::path::{Path, PathBuf};

use super::ReportError;

/// Fills a fresh temporary folder beside `dir` with `fill`, then puts it in
/// `dir`'s place. Files already in `dir` that `fill` did not write (a
/// recording, a calibration written earlier in the run) are kept. On any
/// error the temporary folder is removed and `dir` is as it was.
pub fn replace_folder<T>(dir: &Path, fill: impl FnOnce(&Path) -> Result<T, ReportError>) -> Result<T, ReportError> {
    let staging = sibling(dir, "writing");
    let _ = std::fs::remove_dir_all(&staging);
    std::fs::create_dir_all(&staging).map_err(ReportError::write(&staging))?;
    let result = fill(&staging).and_then(|value| swap(dir, &staging).map(|()| value));
    if result.is_err() {
        let _ = std::fs::remove_dir_all(&staging);
    }
    result
}

/// `dir` with its last component hidden and marked `what` and this process.
fn sibling(dir: &Path, what: &str) -> PathBuf {
    let name = dir.file_name().map_or_else(|| "report".into(), |n| n.to_string_lossy().into_owned());
    let parent = dir.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
    parent.join(format!(".{name}.{what}-{}", std::process::id()))
}

/// Puts `staging` in `dir`'s place, carrying over what only `dir` held.
fn swap(dir: &Path, staging: &Path) -> Result<(), ReportError> {
    if !dir.exists() {
        return std::fs::rename(staging, dir).map_err(ReportError::write(dir));
    }
    let old = sibling(dir, "old");
    let _ = std::fs::remove_dir_all(&old);
    std::fs::rename(dir, &old).map_err(ReportError::write(dir))?;
    if let Err(e) = std::fs::rename(staging, dir) {
        // Put the old folder back; it was never touched.
        let _ = std::fs::rename(&old, dir);
        return Err(ReportError::Write { path: dir.to_owned(), source: e });
    }
    carry_over(&old, dir).map_err(ReportError::write(dir))?;
    std::fs::remove_dir_all(&old).map_err(ReportError::write(&old))
}

/// Moves every entry of `from` that `to` does not have into `to`.
fn carry_over(from: &Path, to: &Path) -> io::Result<()> {
    for entry in std::fs::read_dir(from)? {
        let entry = entry?;
        let target = to.join(entry.file_name());
        if !target.exists() {
            std::fs::rename(entry.path(), target)?;
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn folder(name: &str) -> PathBuf {
        let root =
            Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("../target/tmp/staging-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&root);
        std::fs::create_dir_all(root.join("report")).unwrap();
        std::fs::write(root.join("report/report.json"), "old").unwrap();
        std::fs::write(root.join("report/recording.mcap"), "kept").unwrap();
        root
    }

    fn entries(dir: &Path) -> Vec<String> {
        let mut names: Vec<_> =
            std::fs::read_dir(dir).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
        names.sort();
        names
    }

    #[test]
    fn a_failure_half_way_leaves_the_old_report_whole() {
        let root = folder("fail");
        let dir = root.join("report");
        let result = replace_folder(&dir, |staging| {
            std::fs::write(staging.join("report.json"), "new").unwrap();
            Err::<(), _>(ReportError::write(staging)(io::Error::other("disk full (injected)")))
        });
        assert!(matches!(result, Err(ReportError::Write { .. })));
        assert_eq!(std::fs::read_to_string(dir.join("report.json")).unwrap(), "old");
        assert_eq!(entries(&dir), ["recording.mcap", "report.json"]);
        assert_eq!(entries(&root), ["report"], "no temporary folder is left behind");
    }

    #[test]
    fn a_whole_report_replaces_the_old_and_keeps_what_it_did_not_write() {
        let root = folder("ok");
        let dir = root.join("report");
        replace_folder(&dir, |staging| {
            std::fs::write(staging.join("report.json"), "new").map_err(ReportError::write(staging))
        })
        .unwrap();
        assert_eq!(std::fs::read_to_string(dir.join("report.json")).unwrap(), "new");
        assert_eq!(std::fs::read_to_string(dir.join("recording.mcap")).unwrap(), "kept");
        assert_eq!(entries(&root), ["report"]);
        // Into a folder that does not exist yet.
        let fresh = root.join("fresh");
        replace_folder(&fresh, |s| std::fs::write(s.join("a"), "1").map_err(ReportError::write(s))).unwrap();
        assert_eq!(entries(&fresh), ["a"]);
    }
}
