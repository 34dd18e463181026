//! Text a subcommand writes (a configuration, a robot model): to standard
//! output, or to a file it overwrites only when told to.

use std::io::Write;
use std::path::{Path, PathBuf};

/// Why the text could not be written.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// The output file exists and --force was not given.
    #[error("{0} exists; pass --force to overwrite it")]
    Exists(PathBuf),
    /// The output could not be written.
    #[error("cannot write {path}: {source}")]
    Write {
        /// Where.
        path: String,
        /// What the OS said.
        #[source]
        source: std::io::Error,
    },
}

/// Writes `text` to `path` (an existing file only if `force`), saying so
/// with `what` it is, or to standard output without a path.
pub fn write_text(text: &str, path: Option<&Path>, force: bool, what: &str) -> Result<(), Error> {
    match path {
        Some(path) => {
            if path.exists() && !force {
                return Err(Error::Exists(path.to_owned()));
            }
            std::fs::write(path, text).map_err(|source| Error::Write { path: path.display().to_string(), source })?;
            eprintln!("wrote {what} to {}", path.display());
        }
        None => std::io::stdout()
            .write_all(text.as_bytes())
            .map_err(|source| Error::Write { path: "standard output".into(), source })?,
    }
    Ok(())
}
