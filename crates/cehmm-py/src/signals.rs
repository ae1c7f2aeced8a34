//! Signals in long runs. The engine runs on a thread of its own while the interpreter's thread
//! runs the signal handlers every [`POLL`]. A handler's exception (`KeyboardInterrupt` on
//! Ctrl-C) asks the run's [`Interrupt`] to stop: a world written in Python stops between two
//! steps, one run by the engine between two calls, the optimisers drop the iteration that was
//! cut and return what they had, marked interrupted. A second one aborts the run
//! (`KeyboardInterrupt`, at once). Any other exception a handler raises (a timeout of the
//! user's own) stops the run too and is raised unchanged once it has returned.

use std::sync::Mutex;
use std::sync::mpsc::{RecvTimeoutError, channel};
use std::time::Duration;

use pyo3::exceptions::{PyKeyboardInterrupt, PyRuntimeError};
use pyo3::prelude::*;

use ceworld::Interrupt;

/// How often the signal handlers run while the engine works.
pub const POLL: Duration = Duration::from_millis(20);

/// What the signal handlers said during one run, and the run's interrupt.
#[derive(Default)]
pub struct Signals {
    interrupt: Interrupt,
    raised: Option<PyErr>,
}

impl Signals {
    /// The interrupt the run's episodes obey.
    pub fn interrupt(&self) -> &Interrupt {
        &self.interrupt
    }

    /// Runs `f` on a thread of its own (its stack as deep as the engine's workers'), the
    /// interpreter released, while this thread runs the signal handlers every [`POLL`].
    pub fn watch<T: Send>(&mut self, py: Python<'_>, f: impl FnOnce() -> T + Send) -> PyResult<T> {
        let (done, finished) = channel::<()>();
        // Shared with the interpreter released, so behind a lock (only this thread takes it).
        let finished = Mutex::new(finished);
        std::thread::scope(|scope| {
            let engine = std::thread::Builder::new()
                .name("cehmm-engine".into())
                .stack_size(ceworld::control::WORKER_STACK_BYTES)
                .spawn_scoped(scope, move || {
                    let value = f();
                    drop(done);
                    value
                })
                .map_err(|e| PyRuntimeError::new_err(format!("cannot start the engine's thread: {e}")))?;
            loop {
                let over = py.detach(|| {
                    let finished = finished.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
                    !matches!(finished.recv_timeout(POLL), Err(RecvTimeoutError::Timeout))
                });
                if over {
                    break;
                }
                if let Err(e) = py.check_signals() {
                    self.interrupt.request();
                    // The first exception is the one kept (a second Ctrl-C only aborts).
                    self.raised.get_or_insert(e);
                }
            }
            match engine.join() {
                Ok(value) => Ok(value),
                Err(panic) => std::panic::resume_unwind(panic),
            }
        })
    }

    /// After the run: the exception a handler raised, unless it was a `KeyboardInterrupt` (which
    /// the run's result reports as interrupted, or the run raised itself).
    pub fn finish(self, py: Python<'_>) -> PyResult<()> {
        match self.raised {
            Some(e) if !e.is_instance_of::<PyKeyboardInterrupt>(py) => Err(e),
            _ => Ok(()),
        }
    }
}
