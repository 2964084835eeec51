//! The error type of sim-core.

use std::path::PathBuf;

/// Everything that can go wrong in sim-core.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A parameter that makes no sense (negative radius, zero-sized map, …).
    #[error("invalid parameter: {0}")]
    InvalidParameter(String),
    /// A map file that cannot be read: where and why.
    #[error("map file {}: {problem} (at byte {offset})", path.display())]
    MapFile {
        /// The file (or `<memory>`).
        path: PathBuf,
        /// Byte offset where the problem was found.
        offset: u64,
        /// What is wrong.
        problem: String,
    },
    /// An I/O failure on a named file.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
}

/// sim-core's result type.
pub type Result<T, E = Error> = std::result::Result<T, E>;
