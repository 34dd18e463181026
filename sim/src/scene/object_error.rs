//! Why an object file or a placement cannot be used: one error for both,
//! so a mistake names its key wherever it was made.

/// Why an object file cannot be used.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ObjectError {
    /// The file or folder could not be read.
    #[error("cannot read object file {path}: {source}")]
    Read {
        /// The file or folder.
        path: String,
        /// The I/O error.
        #[source]
        source: std::io::Error,
    },
    /// A mistake in a file, which is named.
    #[error("object file {path}: {source}")]
    InFile {
        /// The file.
        path: String,
        /// The mistake.
        #[source]
        source: Box<ObjectError>,
    },
    /// Not TOML, a key missing or unknown, or a value of the wrong type.
    #[error("not an object description: {0}")]
    Toml(#[source] toml::de::Error),
    /// A value out of its range.
    #[error("`{key}` = {value}: expected {expected}")]
    Range {
        /// The key.
        key: String,
        /// The value given.
        value: f64,
        /// The range.
        expected: &'static str,
    },
    /// A name that cannot name a file or a command-line choice.
    #[error("`name` = {0:?}: expected 1 to 64 letters, digits, '_' or '-', and not \"all\" or \"none\"")]
    Name(String),
    /// A folder without object files.
    #[error("no object files (*.toml) in {0}")]
    EmptyFolder(String),
}
