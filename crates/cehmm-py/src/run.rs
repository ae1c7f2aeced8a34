//! What every optimiser's binding shares: its checkpoint arguments, its per-iteration callback,
//! and `cehmm._core.run`, any optimiser given by its step (`ceworld::run::OPTIMISERS`) by name.

use std::path::{Path, PathBuf};
use std::sync::{Mutex, PoisonError};

use pyo3::exceptions::PyTypeError;
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict};

use ceworld::ce::resume::Peek;
use ceworld::ce::stepped::SteppedOutcome;
use ceworld::policy::file::PolicyFile;
use ceworld::run::{Iteration, RunOptions};
use ceworld::{Checkpointing, Episodes, Error, Flow, Interrupt};

use crate::arg::WorldArg;
use crate::convert::{columns, flag, named, optional_real, to_py};
use crate::errors::raise;
use crate::policy::PyPolicy;
use crate::signals::{SignalCheck, Signals};

/// Every optimiser's checkpoint arguments: where, how often (seconds), whether to resume; a
/// `RuntimeWarning` when the checkpoint to resume from (read by `peek`) is of an earlier version
/// that carries no digest (its content unverified).
pub fn checkpointing(
    py: Python<'_>,
    peek: fn(&Path) -> ceworld::Result<Peek>,
    checkpoint: Option<PathBuf>,
    every: Option<&Bound<'_, PyAny>>,
    resume: Option<&Bound<'_, PyAny>>,
) -> PyResult<Option<Checkpointing>> {
    let every = optional_real("checkpoint_every", every)?.unwrap_or(ceworld::ce::resume::DEFAULT_EVERY);
    let resume = resume.map(|r| flag("resume", r)).transpose()?.unwrap_or(false);
    if checkpoint.is_none() && resume {
        return Err(raise(Error::invalid("resume", "True without a checkpoint (give checkpoint=PATH)")));
    }
    if let Some(path) = checkpoint.as_ref().filter(|p| resume && p.exists()) {
        crate::errors::warn(py, peek(path).map_err(raise)?.unverified.as_deref())?;
    }
    Ok(checkpoint.map(|path| Checkpointing { path, every, resume, outputs: Vec::new() }))
}

/// Runs `f` on `world`'s episodes with the run options of `progress`, `checkpointing` and
/// `callback` ([`PyCallback`]), Ctrl-C watched meanwhile (it stops the run, which returns what it
/// has); raises what the callback raised; warns of a last checkpoint that could not be written
/// (`checkpoint_error` of the result).
#[allow(clippy::too_many_arguments)]
pub fn watched<T: Send>(
    py: Python<'_>,
    world: &WorldArg<'_>,
    progress: bool,
    checkpointing: Option<&Checkpointing>,
    callback: Option<&Bound<'_, PyAny>>,
    f: impl FnOnce(&dyn Episodes, &RunOptions<'_>) -> ceworld::Result<T> + Send,
    checkpoint_error: impl FnOnce(&T) -> Option<&str>,
) -> PyResult<T> {
    let mut signals = Signals::default();
    let callback = PyCallback::new(callback, &signals)?;
    let interrupt = signals.interrupt().clone();
    let stop = move || interrupt.flow();
    let call = callback.as_ref().map(|c| move |it: &Iteration<'_>| c.call(it));
    let options = RunOptions { progress, checkpointing, stop: &stop, callback: call.as_ref().map(|c| c as _) };
    let outcome = world.run_watched(py, &mut signals, |w| f(w, &options));
    callback.map(PyCallback::finish).transpose()?;
    signals.finish(py)?;
    let outcome = outcome?;
    crate::errors::warn_checkpoint(py, checkpoint_error(&outcome))?;
    Ok(outcome)
}

/// A Python callable called after every iteration, on the engine's thread, as
/// `callback(record, policy)`: the iteration's record (a dict, `ceworld::run::Iteration`) and
/// the best policy so far (a `_core.Policy`, made again only when it may have changed; `None`
/// for Q-learning). `False` finishes the run ([`Flow::Finish`]: stop reason `"callback"`),
/// `None` or `True` goes on; an exception (or another answer) stops the run as Ctrl-C does
/// (its checkpoint saved, its evaluation cut short) and is raised once it has returned.
pub struct PyCallback {
    callable: Py<PyAny>,
    interrupt: Interrupt,
    check: SignalCheck,
    raised: Mutex<Option<PyErr>>,
    best: Mutex<Option<Py<PyPolicy>>>,
}

impl PyCallback {
    /// `callable` as a run's callback (`None`: none), stopping the run through the interrupt of
    /// `signals` when it raises; a `TypeError` when it cannot be called.
    pub fn new(callable: Option<&Bound<'_, PyAny>>, signals: &Signals) -> PyResult<Option<PyCallback>> {
        let Some(callable) = callable.filter(|c| !c.is_none()) else { return Ok(None) };
        if !callable.is_callable() {
            return Err(PyTypeError::new_err(format!(
                "invalid callback: {} (expected a callable taking (record, policy), or None)",
                crate::convert::shown(callable)
            )));
        }
        Ok(Some(PyCallback {
            callable: callable.clone().unbind(),
            interrupt: signals.interrupt().clone(),
            check: signals.check(),
            raised: Mutex::new(None),
            best: Mutex::new(None),
        }))
    }

    /// Calls it on `iteration` (with the interpreter) and translates its answer; then has the
    /// signal handlers run at once, so that a signal it sent to its own process (SIGINT: Ctrl-C)
    /// stops the run here, as one from outside would.
    pub fn call(&self, iteration: &Iteration<'_>) -> Flow {
        Python::attach(|py| {
            let flow = match self.answer(py, iteration) {
                Ok(flow) => flow,
                Err(e) => {
                    self.raised.lock().unwrap_or_else(PoisonError::into_inner).get_or_insert(e);
                    self.interrupt.request();
                    Flow::Stop
                }
            };
            self.check.now(py);
            if self.interrupt.stopping() { Flow::Stop } else { flow }
        })
    }

    fn answer(&self, py: Python<'_>, iteration: &Iteration<'_>) -> PyResult<Flow> {
        let record = to_py(py, &serde_json::Value::Object(iteration.record.clone()))?;
        let policy = {
            let mut best = self.best.lock().unwrap_or_else(PoisonError::into_inner);
            if iteration.best_changed || best.is_none() {
                let file = iteration.best_policy().map_err(raise)?;
                *best = file.map(|file| Py::new(py, PyPolicy { file })).transpose()?;
            }
            best.as_ref().map(|p| p.clone_ref(py))
        };
        let answer = self.callable.bind(py).call1((record, policy))?;
        if answer.is_none() {
            return Ok(Flow::Continue);
        }
        match answer.cast::<PyBool>() {
            Ok(b) if b.is_true() => Ok(Flow::Continue),
            Ok(_) => Ok(Flow::Finish),
            Err(_) => Err(PyTypeError::new_err(format!(
                "invalid callback answer: {} (expected True or None to go on, False to stop)",
                crate::convert::shown(&answer)
            ))),
        }
    }

    /// After the run: the exception the callback raised, if it raised one.
    pub fn finish(self) -> PyResult<()> {
        match self.raised.into_inner().unwrap_or_else(PoisonError::into_inner) {
            Some(e) => Err(e),
            None => Ok(()),
        }
    }
}

/// The settings of every optimiser given by its step, with their defaults: name -> dict.
pub fn add(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let optimisers = PyDict::new(m.py());
    for o in ceworld::run::OPTIMISERS {
        optimisers.set_item(o.name, to_py(m.py(), &serde_json::Value::Object((o.defaults)()))?)?;
    }
    m.add("OPTIMISERS", optimisers)
}

/// Runs the optimiser `name` (given by its step) on `world` with `settings` (by name; one left
/// out has its default); Ctrl-C stops it between iterations and the result comes back marked
/// interrupted; `callback` is called after every iteration ([`PyCallback`]). Returns a dict:
/// `policy`, `history`, `evaluation`, `stop_reason`, `seconds`.
#[pyfunction]
#[pyo3(signature = (name, world, settings, *, progress, checkpoint=None, checkpoint_every=None, resume=None, callback=None))]
#[allow(clippy::too_many_arguments)]
pub fn run<'py>(
    py: Python<'py>,
    name: &str,
    world: &Bound<'py, PyAny>,
    settings: &Bound<'py, PyDict>,
    progress: &Bound<'py, PyAny>,
    checkpoint: Option<PathBuf>,
    checkpoint_every: Option<&Bound<'py, PyAny>>,
    resume: Option<&Bound<'py, PyAny>>,
    callback: Option<&Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyDict>> {
    let optimiser = ceworld::run::optimiser(name).map_err(raise)?;
    let settings = named(settings)?;
    let progress = flag("progress", progress)?;
    let checkpointing = checkpointing(py, optimiser.peek, checkpoint, checkpoint_every, resume)?;
    let world = WorldArg::of(world)?;
    let (outcome, file) = watched(
        py,
        &world,
        progress,
        checkpointing.as_ref(),
        callback,
        |w, options| (optimiser.run)(w, &settings, options),
        |(o, _)| o.checkpoint_error.as_deref(),
    )?;
    stepped_result(py, &outcome.ending(), &outcome, file)
}

/// A stepped optimiser's result as a dict: the fields of `head` (its ending, or a controller
/// search's summary of it), its history, its policy file and its evaluation.
pub fn stepped_result<'py>(
    py: Python<'py>,
    head: &impl serde::Serialize,
    outcome: &SteppedOutcome,
    file: PolicyFile,
) -> PyResult<Bound<'py, PyDict>> {
    let result = crate::results::fields(py, head)?;
    let history = columns(py, &outcome.history)?;
    // A stepped optimiser's `best` is its best so far: also under the name every search's
    // history gives that (what plots draw as the best so far).
    history.set_item("best_so_far", history.get_item("best")?)?;
    result.set_item("history", history)?;
    result.set_item("policy", PyPolicy { file })?;
    result.set_item("evaluation", crate::results::evaluation(py, &outcome.evaluation)?)?;
    Ok(result)
}
