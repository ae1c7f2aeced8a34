//! `cehmm._core.optimize`: the cross-entropy method (model §3) on any registered world, its
//! result a frozen `OptimizeOutcome`.

use pyo3::prelude::*;
use pyo3::types::PyDict;

use ceworld::progress::{LiveLine, Progress};
use std::path::PathBuf;

use ceworld::{CeConfig, CeResult, PolicyFile};

use crate::convert::{apply_settings, checkpointing, flag};
use crate::outside::WorldArg;
use crate::policy::PyPolicy;
use crate::results::PyEvaluation;
use crate::signals::Signals;

/// What `optimize` returns (wrapped by `cehmm.OptimizeResult`).
#[pyclass(module = "cehmm._core", name = "OptimizeOutcome", frozen)]
pub struct PyOptimizeOutcome {
    best: PolicyFile,
    last: PolicyFile,
    result: CeResult,
}

#[pymethods]
impl PyOptimizeOutcome {
    /// The policy that drew the best iteration, with its provenance.
    #[getter]
    fn policy(&self) -> PyPolicy {
        PyPolicy { file: self.best.clone() }
    }

    /// The policy after the last update.
    #[getter]
    fn last_policy(&self) -> PyPolicy {
        PyPolicy { file: self.last.clone() }
    }

    /// One numpy array per statistic, one entry per iteration.
    #[getter]
    fn history<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        crate::convert::columns(py, &self.result.history)
    }

    /// The best policy evaluated on fresh episodes.
    #[getter]
    fn evaluation(&self) -> PyEvaluation {
        PyEvaluation(self.result.evaluation.clone())
    }

    /// Why it stopped.
    #[getter]
    fn stop_reason(&self) -> &'static str {
        self.result.stop.as_str()
    }

    /// Whether Ctrl-C stopped it.
    #[getter]
    fn interrupted(&self) -> bool {
        self.result.interrupted()
    }

    /// Index of the best iteration.
    #[getter]
    fn best_iteration(&self) -> usize {
        self.result.best_iteration
    }

    /// Iterations run.
    #[getter]
    fn iterations(&self) -> usize {
        self.result.history.len()
    }

    /// Wall seconds, evaluation included.
    #[getter]
    fn seconds(&self) -> f64 {
        self.result.seconds
    }
}

/// Runs the cross-entropy method (model §3) from `initial` with `settings` (keyword settings by
/// name; one left out has its default), checkpointed when `checkpoint` is given; Ctrl-C stops it
/// between iterations and the result comes back marked interrupted.
#[pyfunction]
#[pyo3(signature = (world, initial, settings, *, progress, checkpoint=None, checkpoint_every=None, resume=None))]
#[allow(clippy::too_many_arguments)]
pub fn optimize(
    py: Python<'_>,
    world: &Bound<'_, PyAny>,
    initial: &PyPolicy,
    settings: &Bound<'_, PyDict>,
    progress: &Bound<'_, PyAny>,
    checkpoint: Option<PathBuf>,
    checkpoint_every: Option<&Bound<'_, PyAny>>,
    resume: Option<&Bound<'_, PyAny>>,
) -> PyResult<PyOptimizeOutcome> {
    let mut config = CeConfig::default();
    apply_settings(&mut config, settings)?;
    let progress = flag("progress", progress)?;
    let checkpointing = checkpointing::<ceworld::ce::checkpoint::CeRun>(py, checkpoint, checkpoint_every, resume)?;
    let world = WorldArg::of(world)?;
    let initial = initial.file.policy.clone();
    let mut signals = Signals::default();
    let interrupt = signals.interrupt().clone();
    let outcome = world.run_watched(py, &mut signals, |w| {
        let mut line = progress.then(|| Progress::new(config.patience, config.restarts, LiveLine::stderr()));
        let result = ceworld::optimize_with(w, initial, &config, checkpointing.as_ref(), |record| {
            if let Some(line) = &mut line {
                line.update(record);
            }
            interrupt.flow()
        });
        if let Some(line) = line {
            line.finish();
        }
        result.map(|result| PyOptimizeOutcome {
            best: result.to_file(w, &config),
            last: result.last_to_file(w, &config),
            result,
        })
    });
    signals.finish(py)?;
    let outcome = outcome?;
    crate::errors::warn_checkpoint(py, outcome.result.checkpoint_error.as_deref())?;
    Ok(outcome)
}
