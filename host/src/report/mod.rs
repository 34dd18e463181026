//! The report folder of `skin demo` and `skin run`: every figure as an SVG
//! file, `report.json` with the data of every figure, and `index.html`
//! showing them together (open it in any browser; it needs nothing else).
//!
//! - `schema`: what `report.json` holds ([`Report`] and its sections).
//! - `render`: the figures drawn from it.
//! - `sim` (the `sim` feature): the sections only a simulation can fill
//!   (network latency, grasps, checks against the truth), with their figures.
//! - `traces` (the `sim` feature): the grasps' force and proximity traces (Figure 18), CSV and SVG.
//! - [`figures`]: the kinds of figure (grids, trees, histograms).
//! - `html` and `markup`: `index.html`, and the escaping and table rows it and `sim` write with.
//! - `staging`: the folder written beside its place and renamed into it.

pub mod figures;
mod html;
mod markup;
mod render;
mod schema;
#[cfg(feature = "sim")]
mod sim;
mod staging;
#[cfg(feature = "sim")]
pub mod traces;

use std::path::{Path, PathBuf};

pub use schema::*;
#[cfg(feature = "sim")]
pub use sim::{GraspSection, LatencySection, TruthSection};

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
    /// Draws every figure, then writes `report.json` and `index.html`, into a
    /// temporary folder beside `dir` that then takes `dir`'s place (files
    /// already in `dir` that the report does not write are kept); on an
    /// error the old `dir` is left whole. Returns the files written.
    pub fn write(&mut self, dir: &Path) -> Result<Vec<PathBuf>, ReportError> {
        let files = staging::replace_folder(dir, |staging| {
            let mut renderer = render::Renderer { report: self, dir: staging, figures: Vec::new() };
            renderer.draw_all()?;
            self.figures = renderer.figures;
            let json = staging.join("report.json");
            std::fs::write(&json, serde_json::to_string_pretty(self)?).map_err(ReportError::write(&json))?;
            let index = staging.join("index.html");
            std::fs::write(&index, html::page(self)).map_err(ReportError::write(&index))?;
            Ok(self.figures.iter().map(|f| f.file.clone()).collect::<Vec<_>>())
        })?;
        let mut written: Vec<PathBuf> = files.iter().map(|f| dir.join(f)).collect();
        written.extend([dir.join("report.json"), dir.join("index.html")]);
        Ok(written)
    }
}
