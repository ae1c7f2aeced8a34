//! Signals in long runs: the interpreter's signal handlers run between iterations (or slices of
//! evaluation episodes). A `KeyboardInterrupt` stops the run, which returns what it has marked
//! interrupted; any other exception a handler raises (a timeout of the user's own) stops it too
//! and is raised unchanged once the run has returned.

use pyo3::exceptions::PyKeyboardInterrupt;
use pyo3::prelude::*;

use ceworld::Flow;

/// What the signal handlers said during one run.
#[derive(Default)]
pub struct Signals {
    raised: Option<PyErr>,
}

impl Signals {
    /// Runs the handlers: go on, or stop (keeping what a handler raised).
    pub fn flow(&mut self) -> Flow {
        match Python::attach(|py| py.check_signals()) {
            Ok(()) => Flow::Continue,
            Err(e) => {
                self.raised = Some(e);
                Flow::Stop
            }
        }
    }

    /// After the run: the exception a handler raised, unless it was a `KeyboardInterrupt` (which
    /// the run's result reports as interrupted).
    pub fn finish(self, py: Python<'_>) -> PyResult<()> {
        match self.raised {
            Some(e) if !e.is_instance_of::<PyKeyboardInterrupt>(py) => Err(e),
            _ => Ok(()),
        }
    }
}
