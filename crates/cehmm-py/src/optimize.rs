//! `cehmm._core.optimize`: the cross-entropy method (model §3) on any registered world, its
//! result a frozen `OptimizeOutcome`.

use numpy::PyArray1;
use pyo3::prelude::*;
use pyo3::types::PyDict;

use ceworld::progress::{CeProgress, LiveLine};
use std::path::PathBuf;

use ceworld::{CeConfig, CeResult, Checkpointing, IterationRecord, PolicyFile};

use crate::convert::{count, flag, optional_count, optional_real, real, seed, text};
use crate::errors::OrRaise;
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
        let h = &self.result.history;
        let column = |f: fn(&IterationRecord) -> f64| PyArray1::from_iter(py, h.iter().map(f));
        let history = PyDict::new(py);
        history.set_item("iteration", PyArray1::from_iter(py, h.iter().map(|r| r.iteration as i64)))?;
        history.set_item("mean", column(|r| r.mean))?;
        history.set_item("best", column(|r| r.best))?;
        history.set_item("elite_threshold", column(|r| r.elite_threshold))?;
        history.set_item("elite_mean", column(|r| r.elite_mean))?;
        history.set_item("seconds", column(|r| r.seconds))?;
        history.set_item("successful", PyArray1::from_iter(py, h.iter().map(|r| r.successful)))?;
        Ok(history)
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

/// Runs the cross-entropy method (model §3) from `initial`, checkpointed when `checkpoint` is
/// given; Ctrl-C stops it between iterations and the result comes back marked interrupted.
#[pyfunction]
#[pyo3(signature = (
    world, initial, *, samples, rho, smoothing, decision_smoothing, patience, max_iterations, time_limit, target, seed, threads,
    eval_episodes, progress, memory_update, restarts, checkpoint=None, checkpoint_every=None, resume=None
))]
#[allow(clippy::too_many_arguments)]
pub fn optimize(
    py: Python<'_>,
    world: &Bound<'_, PyAny>,
    initial: &PyPolicy,
    samples: &Bound<'_, PyAny>,
    rho: &Bound<'_, PyAny>,
    smoothing: &Bound<'_, PyAny>,
    decision_smoothing: Option<&Bound<'_, PyAny>>,
    patience: &Bound<'_, PyAny>,
    max_iterations: Option<&Bound<'_, PyAny>>,
    time_limit: Option<&Bound<'_, PyAny>>,
    target: Option<&Bound<'_, PyAny>>,
    seed: &Bound<'_, PyAny>,
    threads: Option<&Bound<'_, PyAny>>,
    eval_episodes: &Bound<'_, PyAny>,
    progress: &Bound<'_, PyAny>,
    memory_update: &Bound<'_, PyAny>,
    restarts: &Bound<'_, PyAny>,
    checkpoint: Option<PathBuf>,
    checkpoint_every: Option<&Bound<'_, PyAny>>,
    resume: Option<&Bound<'_, PyAny>>,
) -> PyResult<PyOptimizeOutcome> {
    let config = CeConfig {
        samples: count("samples", samples)?,
        rho: real("rho", rho)?,
        smoothing: real("smoothing", smoothing)?,
        decision_smoothing: optional_real("decision_smoothing", decision_smoothing)?,
        patience: count("patience", patience)?,
        max_iterations: optional_count("max_iterations", max_iterations)?,
        time_limit: optional_real("time_limit", time_limit)?,
        target: optional_real("target", target)?,
        seed: self::seed("seed", seed)?,
        threads: optional_count("threads", threads)?,
        eval_episodes: count("eval_episodes", eval_episodes)?,
        memory_update: text("memory_update", memory_update)?.parse().or_raise()?,
        restarts: count("restarts", restarts)?,
    };
    let progress = flag("progress", progress)?;
    let every = optional_real("checkpoint_every", checkpoint_every)?.unwrap_or(ceworld::ce::resume::DEFAULT_EVERY);
    let resume = resume.map(|r| flag("resume", r)).transpose()?.unwrap_or(false);
    let checkpointing = checkpoint.map(|path| Checkpointing { path, every, resume });
    if checkpointing.is_none() && resume {
        return Err(ceworld::Error::invalid("resume", "True without a checkpoint (give checkpoint=PATH)")).or_raise();
    }
    let world = WorldArg::of(world)?;
    let initial = initial.file.policy.clone();
    let mut signals = Signals::default();
    let outcome = world.run(py, |w| {
        let mut line = progress.then(|| CeProgress::new(config.patience, LiveLine::stderr()));
        let result = ceworld::optimize_with(w, initial, &config, checkpointing.as_ref(), |record| {
            if let Some(line) = &mut line {
                line.update(record);
            }
            signals.flow()
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
    outcome
}
