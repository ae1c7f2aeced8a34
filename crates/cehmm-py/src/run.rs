//! What every optimiser's binding shares: its checkpoint arguments, and `cehmm._core.run`, any
//! optimiser given by its step (`ceworld::run::OPTIMISERS`) by name.

use std::path::{Path, PathBuf};

use pyo3::prelude::*;
use pyo3::types::PyDict;

use ceworld::ce::resume::Peek;
use ceworld::run::RunOptions;
use ceworld::{Checkpointing, Episodes, Error};

use crate::arg::WorldArg;
use crate::convert::{columns, flag, named, optional_real, to_py};
use crate::errors::raise;
use crate::policy::PyPolicy;
use crate::signals::Signals;

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

/// Runs `f` on `world`'s episodes with the run options of `progress` and `checkpointing`,
/// Ctrl-C watched meanwhile (it stops the run, which returns what it has); warns of a last
/// checkpoint that could not be written (`checkpoint_error` of the result).
pub fn watched<T: Send>(
    py: Python<'_>,
    world: &WorldArg<'_>,
    progress: bool,
    checkpointing: Option<&Checkpointing>,
    f: impl FnOnce(&dyn Episodes, &RunOptions<'_>) -> ceworld::Result<T> + Send,
    checkpoint_error: impl FnOnce(&T) -> Option<&str>,
) -> PyResult<T> {
    let mut signals = Signals::default();
    let interrupt = signals.interrupt().clone();
    let stop = move || interrupt.flow();
    let options = RunOptions { progress, checkpointing, stop: &stop };
    let outcome = world.run_watched(py, &mut signals, |w| f(w, &options));
    signals.finish(py)?;
    let outcome = outcome?;
    crate::errors::warn_checkpoint(py, checkpoint_error(&outcome))?;
    Ok(outcome)
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
/// interrupted. Returns a dict: `policy`, `history`, `evaluation`, `stop_reason`, `seconds`.
#[pyfunction]
#[pyo3(signature = (name, world, settings, *, progress, checkpoint=None, checkpoint_every=None, resume=None))]
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
        |w, options| (optimiser.run)(w, &settings, options),
        |(o, _)| o.checkpoint_error.as_deref(),
    )?;
    let result = PyDict::new(py);
    result.set_item("history", columns(py, &outcome.history)?)?;
    result.set_item("policy", PyPolicy { file })?;
    result.set_item("evaluation", crate::results::evaluation(py, &outcome.evaluation)?)?;
    result.set_item("stop_reason", outcome.stop.as_str())?;
    result.set_item("seconds", outcome.seconds)?;
    Ok(result)
}
