//! The report folder of `skin demo` and `skin run`: every figure as an SVG
//! file, `report.json` with the data of every figure, and `index.html`
//! showing them together (open it in any browser; it needs nothing else).
//!
//! - `schema`: what `report.json` holds ([`Report`] and its sections).
//! - `render`: the figures drawn from it.
//! - [`traces`]: the grasps' force and proximity traces (Figure 18), CSV and SVG.
//! - [`figures`]: the kinds of figure (grids, trees, histograms).

pub mod figures;
mod html;
mod render;
mod schema;
pub mod traces;

use std::path::{Path, PathBuf};

pub use schema::*;

/// Why the report could not be written.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ReportError {
    /// A file or the folder could not be written.
    #[error("cannot write {}: {source} (choose another folder with --out DIR)", path.display())]
    Write {
        /// The file or folder.
        path: PathBuf,
        /// What went wrong.
        #[source]
        source: std::io::Error,
    },
    /// `report.json` could not be encoded.
    #[error("cannot encode report.json: {0}")]
    Json(#[from] serde_json::Error),
    /// A figure could not be drawn.
    #[error("cannot draw {file}: {message}")]
    Draw {
        /// The figure's file.
        file: String,
        /// What went wrong.
        message: String,
    },
}

impl ReportError {
    /// A write of `path` that failed.
    pub(crate) fn write(path: &Path) -> impl FnOnce(std::io::Error) -> ReportError + '_ {
        move |source| ReportError::Write { path: path.to_owned(), source }
    }
}

/// Makes sure the report can be written into `dir` (created if missing)
/// by writing and removing a probe file: a folder that cannot be written
/// is refused before the robot spends any time, not after.
pub fn check_folder(dir: &Path) -> Result<(), ReportError> {
    std::fs::create_dir_all(dir).map_err(ReportError::write(dir))?;
    let probe = dir.join(".skin-write-check");
    std::fs::write(&probe, b"").map_err(ReportError::write(&probe))?;
    std::fs::remove_file(&probe).map_err(ReportError::write(&probe))
}

impl Report {
    /// Draws every figure into `dir` (created if missing), then writes
    /// `report.json` and `index.html`; returns the files written.
    pub fn write(&mut self, dir: &Path) -> Result<Vec<PathBuf>, ReportError> {
        std::fs::create_dir_all(dir).map_err(ReportError::write(dir))?;
        let mut renderer = render::Renderer { report: self, dir, figures: Vec::new() };
        renderer.draw_all()?;
        self.figures = renderer.figures;
        let mut written: Vec<PathBuf> = self.figures.iter().map(|f| dir.join(&f.file)).collect();
        let json = dir.join("report.json");
        std::fs::write(&json, serde_json::to_string_pretty(self)?).map_err(ReportError::write(&json))?;
        let index = dir.join("index.html");
        std::fs::write(&index, html::page(self)).map_err(ReportError::write(&index))?;
        written.extend([json, index]);
        Ok(written)
    }
}
