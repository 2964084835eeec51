//! The editor library's error type: every variant names the file (where there is one) and
//! what is wrong with it.

use std::path::PathBuf;

/// Everything that can go wrong in the editor.
#[derive(Debug, thiserror::Error)]
pub enum EditorError {
    /// A file that cannot be read or written.
    #[error("{}: {cause}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The cause.
        cause: std::io::Error,
    },
    /// An image that cannot be decoded or encoded.
    #[error("{}: cannot read image: {cause}", path.display())]
    Image {
        /// The file.
        path: PathBuf,
        /// The cause.
        cause: image::ImageError,
    },
    /// An input file whose contents make no sense (malformed YAML, a `.map` with a bad
    /// header, a scene with a shape outside the world, …).
    #[error("{}: {problem}", path.display())]
    BadInput {
        /// The file.
        path: PathBuf,
        /// What is wrong, with a line number where one is known.
        problem: String,
    },
    /// Malformed XML, with the position of the problem.
    #[error("{}:{line}:{column}: {problem}", path.display())]
    Xml {
        /// The file.
        path: PathBuf,
        /// 1-based line.
        line: usize,
        /// 1-based column (in bytes).
        column: usize,
        /// What is wrong.
        problem: String,
    },
    /// A parameter that makes no sense (negative size, density outside [0, 1], …).
    #[error("invalid parameter: {0}")]
    InvalidParameter(String),
    /// Treasures or a home base could not be placed.
    #[error("placement failed: {0}")]
    Placement(String),
    /// An error from sim-core (map file, grid).
    #[error(transparent)]
    Core(#[from] sim_core::Error),
}

/// The editor's result type.
pub type Result<T, E = EditorError> = std::result::Result<T, E>;

impl EditorError {
    /// A [`EditorError::BadInput`] for `path`.
    pub fn bad_input(path: impl Into<PathBuf>, problem: impl Into<String>) -> Self {
        Self::BadInput {
            path: path.into(),
            problem: problem.into(),
        }
    }

    /// An [`EditorError::Io`] for `path`.
    pub fn io(path: impl Into<PathBuf>) -> impl FnOnce(std::io::Error) -> Self {
        let path = path.into();
        move |cause| Self::Io { path, cause }
    }
}
