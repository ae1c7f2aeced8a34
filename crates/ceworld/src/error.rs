//! The one error type of the engine; the CLI prints it, the Python bindings map it to exceptions.

use std::path::PathBuf;

/// Everything that can go wrong in `ceworld`, each variant naming the bad value and what was
/// expected.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// An argument outside its domain (`rho = 1.5`, `samples = 0`, a level of size 0, ...).
    #[error("invalid {name}: {message}")]
    InvalidArgument {
        /// The argument's name as the user wrote it.
        name: String,
        /// What was wrong and what was expected.
        message: String,
    },
    /// An argument of the wrong kind (a string where a number is expected, a float where an
    /// integer is, ...); the Python bindings raise it as `TypeError`.
    #[error("invalid {name}: {message}")]
    WrongType {
        /// The argument's name as the user wrote it.
        name: String,
        /// What was found and what was expected.
        message: String,
    },
    /// A policy whose shapes do not fit the world it is used with.
    #[error("policy does not match the world: {0}")]
    Mismatch(String),
    /// A checkpoint made with another world or other settings than the run that would resume
    /// from it; the message names the first that differs.
    #[error("the checkpoint does not match this run: {0}")]
    CheckpointMismatch(String),
    /// A policy file that is not valid cehmm-policy JSON.
    #[error("invalid policy{}: {message}", path.as_ref().map(|p| format!(" file {}", p.display())).unwrap_or_default())]
    PolicyFormat {
        /// The file, when there is one.
        path: Option<PathBuf>,
        /// What is wrong, naming the key and the expected value.
        message: String,
    },
    /// A checkpoint file that is not one, or whose state is not consistent (a history that does
    /// not match its counters, a best that is not in its history, a run index past the runs).
    #[error("invalid checkpoint {}: {message}", path.display())]
    CheckpointFormat {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// A model file (a Cassandra `.pomdp` file) that cannot be read as one; the message names
    /// the file, the line and column, what was found and what was expected.
    #[error("invalid model file {0}")]
    ModelFormat(String),
    /// A world outside the engine (written in Python) that returned something out of its
    /// shape (an observation out of range, a reward that is not a finite number) or failed; the
    /// message names the world, the episode and the step.
    #[error("{0}")]
    World(String),
    /// A table (the Q-learning baseline's) that would not fit in the memory the system reports
    /// available; refused before allocating.
    #[error("{what} needs {needed} bytes ({:.2} GiB) but only {available} bytes ({:.2} GiB) are available (the least of MemAvailable in /proc/meminfo, the cgroup limit and the process limits: ulimit -v, RLIMIT_AS, RLIMIT_DATA)", *needed as f64 / (1u64 << 30) as f64, *available as f64 / (1u64 << 30) as f64)]
    Memory {
        /// What was to be allocated.
        what: String,
        /// Bytes needed.
        needed: u64,
        /// Bytes available.
        available: u64,
    },
    /// A bug: a panic inside the engine (in any thread of a computation), caught and reported
    /// instead of aborting the process. Please report it with the message.
    #[error("internal error (a bug, please report it): {0}")]
    Internal(String),
    /// Work stopped from outside ([`crate::control::Interrupt`]): a second Ctrl-C, or a first
    /// one where nothing done can be kept.
    #[error("interrupted")]
    Interrupted,
    /// Reading or writing a file failed.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The system's error.
        source: std::io::Error,
    },
}

/// Result with the engine's [`Error`].
pub type Result<T, E = Error> = std::result::Result<T, E>;

impl Error {
    /// Shorthand for [`Error::InvalidArgument`].
    pub fn invalid(name: impl Into<String>, message: impl Into<String>) -> Self {
        Error::InvalidArgument { name: name.into(), message: message.into() }
    }

    /// Shorthand for [`Error::WrongType`].
    pub fn wrong_type(name: impl Into<String>, message: impl Into<String>) -> Self {
        Error::WrongType { name: name.into(), message: message.into() }
    }

    /// Shorthand for [`Error::PolicyFormat`] without a path (the loader adds it).
    pub fn format(message: impl Into<String>) -> Self {
        Error::PolicyFormat { path: None, message: message.into() }
    }
}
