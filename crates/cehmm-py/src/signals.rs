//! Ctrl-C in long runs: the interpreter's signal handlers, asked between iterations.

use pyo3::prelude::*;

/// Whether a long run goes on, asked between its iterations: the interpreter's signal handlers
/// run here, and a pending `KeyboardInterrupt` is consumed, so that the caller gets the run so
/// far, marked interrupted.
pub fn flow_after_signals() -> ceworld::Flow {
    match Python::attach(|py| py.check_signals()) {
        Ok(()) => ceworld::Flow::Continue,
        Err(_) => ceworld::Flow::Stop,
    }
}
