//! The error type of sim-core.

use std::path::PathBuf;

/// Everything that can go wrong in sim-core.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A parameter that makes no sense (negative radius, zero-sized map, unknown strategy, …).
    #[error("{0}")]
    InvalidParameter(String),
    /// A problem caused by one group of robots of a scenario (its index lets a config point
    /// at the element that declared it).
    #[error("group '{name}': {message}")]
    Group {
        /// The group's index in the scenario.
        index: usize,
        /// The group's name.
        name: String,
        /// What is wrong.
        message: String,
    },
    /// A data structure that breaks its own invariants (what `validate` reports).
    #[error("{0}")]
    Malformed(String),
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
    /// A config file problem: where (line and column are 0 when unknown) and what.
    #[error("{}{}: {message}", path.display(), if *line > 0 { format!(":{line}:{column}") } else { String::new() })]
    Config {
        /// The config file.
        path: PathBuf,
        /// Line (1-based; 0 if unknown).
        line: usize,
        /// Column (1-based; 0 if unknown).
        column: usize,
        /// What is wrong, and what was expected.
        message: String,
    },
    /// A problem with a command-line argument (for example `--map`): which and what.
    #[error("{argument}: {message}")]
    Argument {
        /// The argument as the user gave it (`--map maps/x.stmap`).
        argument: String,
        /// What is wrong.
        message: String,
    },
    /// A checkpoint file that cannot be used: which and why.
    #[error("checkpoint {}: {problem}", path.display())]
    Checkpoint {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        problem: String,
    },
    /// An I/O failure on a named file.
    #[error("{}: {cause}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The cause (part of the message, not a separate source, so it prints once).
        cause: std::io::Error,
    },
    /// A sweep stopped on request before all its runs were played; the finished ones are
    /// kept, and the same sweep resumes them.
    #[error(
        "stopped after {done} of {total} runs; the finished runs are kept in {}, and the same command resumes the sweep",
        parts.display()
    )]
    Stopped {
        /// Runs finished (those of earlier attempts included).
        done: usize,
        /// Runs of the sweep (or its shard).
        total: usize,
        /// Where the finished runs are kept.
        parts: PathBuf,
    },
}

/// sim-core's result type.
pub type Result<T, E = Error> = std::result::Result<T, E>;
