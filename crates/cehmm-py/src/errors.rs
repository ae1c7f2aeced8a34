//! The exceptions of `cehmm` and the one mapping of core errors to them.

use pyo3::create_exception;
use pyo3::exceptions::{PyKeyboardInterrupt, PyMemoryError, PyOSError, PyTypeError, PyValueError};
use pyo3::prelude::*;

use ceworld::Error;

create_exception!(cehmm, CehmmError, PyValueError, "Base class of the errors raised by cehmm (a ValueError).");
create_exception!(
    cehmm,
    InvalidArgumentError,
    CehmmError,
    "An argument outside its domain; the message names it, its value and what was expected."
);
create_exception!(
    cehmm,
    PolicyFormatError,
    CehmmError,
    "A policy file or table that is not a valid cehmm policy (model §6): wrong shape, negative or \
     non-finite entry, row not summing to 1, bad JSON."
);
create_exception!(
    cehmm,
    ModelFormatError,
    CehmmError,
    "A model file (a Cassandra .pomdp file) that cannot be read as one; the message names the file, \
     line and column, what was found and what was expected."
);
create_exception!(
    cehmm,
    InternalError,
    CehmmError,
    "A bug: a panic inside the engine, caught and reported instead of crashing; please report it."
);
create_exception!(
    cehmm,
    PolicyMismatchError,
    CehmmError,
    "A policy used with a world whose numbers of observations or decisions differ from the policy's."
);
create_exception!(
    cehmm,
    WorldError,
    CehmmError,
    "A world written in Python returned something outside its shape (an observation out of range, \
     a reward that is not a finite number); the message names the world, the episode and the step."
);

/// The one mapping of core errors to Python exceptions. `Error::WrongType` becomes `TypeError`;
/// `Error::Interrupted` (Ctrl-C where nothing can be kept) `KeyboardInterrupt`;
/// `Error::Io` the built-in `OSError` subclass of its errno (`FileNotFoundError`, ...), with
/// `filename`.
pub fn raise(error: Error) -> PyErr {
    let message = error.to_string();
    match error {
        Error::InvalidArgument { .. } => InvalidArgumentError::new_err(message),
        Error::WrongType { .. } => PyTypeError::new_err(message),
        Error::PolicyFormat { .. } | Error::CheckpointFormat { .. } => PolicyFormatError::new_err(message),
        Error::Mismatch(_) | Error::CheckpointMismatch(_) => PolicyMismatchError::new_err(message),
        Error::ModelFormat(_) => ModelFormatError::new_err(message),
        Error::Internal(_) => InternalError::new_err(message),
        Error::World(_) => WorldError::new_err(message),
        Error::Memory { .. } => PyMemoryError::new_err(message),
        Error::Interrupted => PyKeyboardInterrupt::new_err(()),
        Error::Io { path, source } => match source.raw_os_error() {
            Some(errno) => {
                let text = source.to_string();
                let text = text.strip_suffix(&format!(" (os error {errno})")).unwrap_or(&text).to_string();
                PyOSError::new_err((errno, text, path.display().to_string()))
            }
            None => PyOSError::new_err(message),
        },
    }
}

/// A `RuntimeWarning` that the last checkpoint of a run could not be written (`error`): the run
/// went on and its result is returned.
pub fn warn_checkpoint(py: Python<'_>, error: Option<&str>) -> PyResult<()> {
    let message = error.map(|e| format!("{} and its result is returned", ceworld::ce::resume::checkpoint_warning(e)));
    warn(py, message.as_deref())
}

/// A `RuntimeWarning` of `message`, if any, at the caller's line.
pub fn warn(py: Python<'_>, message: Option<&str>) -> PyResult<()> {
    let Some(message) = message else { return Ok(()) };
    let message = std::ffi::CString::new(message.replace('\0', " ")).expect("no NUL left");
    PyErr::warn(py, &py.get_type::<pyo3::exceptions::PyRuntimeWarning>(), &message, 2)
}

/// `.map_err(raise)` for a core result.
pub trait OrRaise<T> {
    /// The value, or the error as a Python exception.
    fn or_raise(self) -> PyResult<T>;
}

impl<T> OrRaise<T> for Result<T, Error> {
    fn or_raise(self) -> PyResult<T> {
        self.map_err(raise)
    }
}

/// Runs `f` detached from the interpreter, a panic in it (or in its rayon tasks) raised as
/// `InternalError` and its error as the matching exception.
pub fn detached<T: Send>(py: Python<'_>, f: impl FnOnce() -> Result<T, Error> + Send) -> PyResult<T> {
    py.detach(|| ceworld::catch_panics(f)).map_err(raise)
}

/// What the engine is told of `error`, an exception the world's code (or a backend) raised and
/// that is kept to be raised again as itself.
pub fn raised(py: Python<'_>, error: &PyErr) -> Error {
    Error::World(format!("raised {}", error.value(py).repr().map_or_else(|_| "an exception".into(), |r| r.to_string())))
}
