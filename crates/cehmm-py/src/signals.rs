//! Signals in long runs. The engine runs on a thread of its own while the interpreter's thread
//! runs the signal handlers every [`POLL`]. A handler's exception (`KeyboardInterrupt` on
//! Ctrl-C) asks the run's [`Interrupt`] to stop: a world written in Python stops between two
//! steps, one run by the engine between two calls, the optimisers drop the iteration that was
//! cut and return what they had, marked interrupted. A second one aborts the run
//! (`KeyboardInterrupt`, at once). Any other exception a handler raises (a timeout of the
//! user's own) stops the run too and is raised unchanged once it has returned.

use std::sync::Mutex;
use std::sync::mpsc::{Receiver, RecvTimeoutError, Sender, channel};
use std::time::Duration;

use pyo3::exceptions::{PyKeyboardInterrupt, PyRuntimeError};
use pyo3::prelude::*;

use ceworld::Interrupt;

/// How often the signal handlers run while the engine works.
pub const POLL: Duration = Duration::from_millis(20);

/// The longest the engine's thread waits for the interpreter's to run the handlers at once.
const CHECK_WAIT: Duration = Duration::from_secs(5);

/// What the engine's thread tells the interpreter's.
enum Note {
    /// The run is over (sent however it ended, a panic too).
    Done,
    /// Run the signal handlers now, then answer.
    Check(Sender<()>),
}

/// Sends [`Note::Done`] when dropped: at the end of the engine's thread, however it ends.
struct DoneOnDrop(Sender<Note>);

impl Drop for DoneOnDrop {
    fn drop(&mut self) {
        let _ = self.0.send(Note::Done);
    }
}

/// What the signal handlers said during one run, and the run's interrupt.
pub struct Signals {
    interrupt: Interrupt,
    raised: Option<PyErr>,
    tell: Sender<Note>,
    // Read by this thread alone, with the interpreter released: behind a lock.
    told: Mutex<Receiver<Note>>,
}

impl Default for Signals {
    fn default() -> Signals {
        let (tell, told) = channel();
        Signals { interrupt: Interrupt::default(), raised: None, tell, told: Mutex::new(told) }
    }
}

/// The engine thread's way to have the signal handlers run at once ([`SignalCheck::now`]).
pub struct SignalCheck(Sender<Note>);

impl SignalCheck {
    /// Asks the interpreter's thread to run the signal handlers now and waits (the interpreter
    /// released) until it has, or for [`CHECK_WAIT`] at most: a signal a callback sent to its
    /// own process (delivered to that thread, whose handler runs at once) has then asked the
    /// run's interrupt, before the run goes on, as one from outside would between iterations.
    pub fn now(&self, py: Python<'_>) {
        let (answer, answered) = channel();
        if self.0.send(Note::Check(answer)).is_ok() {
            py.detach(move || {
                let _ = answered.recv_timeout(CHECK_WAIT);
            });
        }
    }
}

impl Signals {
    /// The interrupt the run's episodes obey.
    pub fn interrupt(&self) -> &Interrupt {
        &self.interrupt
    }

    /// A way for the engine's thread to have the handlers run at once (a callback's).
    pub fn check(&self) -> SignalCheck {
        SignalCheck(self.tell.clone())
    }

    /// Runs `f` on a thread of its own (its stack as deep as the engine's workers'), the
    /// interpreter released, while this thread runs the signal handlers every [`POLL`], and
    /// whenever the engine's thread asks ([`SignalCheck::now`]).
    pub fn watch<T: Send>(&mut self, py: Python<'_>, f: impl FnOnce() -> T + Send) -> PyResult<T> {
        let done = DoneOnDrop(self.tell.clone());
        std::thread::scope(|scope| {
            let engine = std::thread::Builder::new()
                .name("cehmm-engine".into())
                .stack_size(ceworld::control::WORKER_STACK_BYTES)
                .spawn_scoped(scope, move || {
                    let _done = done;
                    f()
                })
                .map_err(|e| PyRuntimeError::new_err(format!("cannot start the engine's thread: {e}")))?;
            loop {
                let told = &self.told;
                let note =
                    py.detach(|| told.lock().unwrap_or_else(std::sync::PoisonError::into_inner).recv_timeout(POLL));
                match note {
                    Ok(Note::Done) | Err(RecvTimeoutError::Disconnected) => break,
                    Ok(Note::Check(answer)) => {
                        self.run_handlers(py);
                        let _ = answer.send(());
                    }
                    Err(RecvTimeoutError::Timeout) => self.run_handlers(py),
                }
            }
            match engine.join() {
                Ok(value) => Ok(value),
                Err(panic) => std::panic::resume_unwind(panic),
            }
        })
    }

    /// Runs the signal handlers: an exception one raises stops the run.
    fn run_handlers(&mut self, py: Python<'_>) {
        if let Err(e) = py.check_signals() {
            self.interrupt.request();
            // The first exception is the one kept (a second Ctrl-C only aborts).
            self.raised.get_or_insert(e);
        }
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
