//! Firmware updates of the skin from the robot PC.
//!
//! - [`keys`]: the update key pair in OpenSSL-compatible PEM files.
//! - [`signing`]: a signed image ([`skin_protocol::image`]) from a program's bytes.

pub mod keys;
pub mod signing;

use std::path::PathBuf;

/// Why an update step failed; each says what to do.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// A file could not be read.
    #[error("cannot read {path}: {source}")]
    Read {
        /// Which file.
        path: PathBuf,
        /// What the OS said.
        source: std::io::Error,
    },
    /// A file could not be written.
    #[error("cannot write {path}: {source}")]
    Write {
        /// Which file.
        path: PathBuf,
        /// What the OS said.
        source: std::io::Error,
    },
    /// A key file would be overwritten.
    #[error("{0} exists; pass --force to replace it (images signed with the old key will no longer match it)")]
    Exists(PathBuf),
    /// The file is not a key of the expected kind.
    #[error("{path} is not an ed25519 {kind} key in PEM (as `skin keygen` or `openssl genpkey -algorithm ed25519` write): {reason}")]
    BadKey {
        /// Which file.
        path: PathBuf,
        /// "secret" or "public".
        kind: &'static str,
        /// What the parser said.
        reason: String,
    },
    /// The operating system gave no randomness for a new key.
    #[error("no randomness from the operating system for a new key: {0}")]
    Random(String),
    /// The program is empty or is already a signed image.
    #[error("{path}: {reason}")]
    BadProgram {
        /// Which file.
        path: PathBuf,
        /// Why it cannot be signed.
        reason: &'static str,
    },
    /// A signed image does not check out.
    #[error("{path}: {source}")]
    Image {
        /// Which file.
        path: PathBuf,
        /// Why.
        source: skin_protocol::image::ImageError,
    },
}

/// The largest file read here: a program or image for a cell's 64 KiB of
/// flash, or a key.
pub const MAX_FILE_BYTES: usize = skin_model::file::MIB;

/// Reads a whole file of at most [`MAX_FILE_BYTES`], naming it in the error.
pub fn read(path: &std::path::Path) -> Result<Vec<u8>, Error> {
    skin_model::file::read_capped(path, MAX_FILE_BYTES).map_err(|source| Error::Read { path: path.into(), source })
}
