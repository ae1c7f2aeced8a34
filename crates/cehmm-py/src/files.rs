//! The engine's rules for a user's files (`ceworld::files`) for the commands, readers and
//! callbacks written in Python (`cehmm plot`, history files, `SaveBest`): `read_file`, the
//! bounded read of a regular file, `check_distinct`, no output written over an input or another
//! output, and `check_writable`; so that they refuse what the engine's own commands refuse.

use std::path::{Path, PathBuf};

use pyo3::prelude::*;
use pyo3::types::PyBytes;

use crate::errors::OrRaise;

/// The bytes of the regular file `path` (`ceworld::files::read_limited`), the interpreter
/// released: a directory, a device, a FIFO (at once, without waiting for a writer) or a link to
/// one is refused, and so is a file of more than `max_bytes`; `what` names the file in the
/// errors (`InvalidArgumentError`, or the `OSError` of a file that cannot be opened).
#[pyfunction]
pub fn read_file<'py>(py: Python<'py>, path: PathBuf, max_bytes: u64, what: &str) -> PyResult<Bound<'py, PyBytes>> {
    let bytes = py.detach(|| ceworld::files::read_limited(&path, max_bytes, what)).or_raise()?;
    Ok(PyBytes::new(py, &bytes))
}

/// Refuses an output that is the same file as an input or another output
/// (`ceworld::files::check_distinct`: links followed, hard links seen); each path comes with the
/// option or argument that gave it, which the error names.
#[pyfunction]
pub fn check_distinct(inputs: Vec<(String, PathBuf)>, outputs: Vec<(String, PathBuf)>) -> PyResult<()> {
    ceworld::files::check_distinct(&named(&inputs), &named(&outputs)).or_raise()
}

/// Refuses a file `path` (given as `option`, which the error names) that cannot be written
/// (`ceworld::files::check_writable`: links followed; a directory, a device, a FIFO, a missing
/// or read-only folder), creating and removing a temporary file beside it.
#[pyfunction]
pub fn check_writable(option: &str, path: PathBuf) -> PyResult<()> {
    ceworld::files::check_writable(option, &path).or_raise()
}

/// `(option, path)` pairs as the core takes them.
fn named(given: &[(String, PathBuf)]) -> Vec<(&str, &Path)> {
    given.iter().map(|(option, path)| (option.as_str(), path.as_path())).collect()
}
