//! `cehmm._core.cli`: the engine's command line (`ceworld::cli`), run as `cehmm` by the
//! package's console script.

use std::ffi::OsString;

use pyo3::prelude::*;

/// Runs the command line `args` (without the program's name) as `cehmm`, the interpreter
/// released; returns the exit status (0, 2 for an error, 70 for a bug, 128 + a stop signal).
#[pyfunction]
pub fn cli(py: Python<'_>, args: Vec<OsString>) -> u8 {
    let all: Vec<OsString> = std::iter::once(OsString::from("cehmm")).chain(args).collect();
    py.detach(|| ceworld::cli::main("cehmm", all))
}
