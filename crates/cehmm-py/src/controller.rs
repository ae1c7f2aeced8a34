//! `cehmm._core.optimize_controller`: the cross-entropy method over deterministic controllers of
//! any world, on exact or sampled values (model §8), its result a frozen `ControllerOutcome`.

use pyo3::prelude::*;
use pyo3::types::PyDict;

use ceworld::ce::controller::{
    ControllerConfig, ControllerOutcome, ValueKind, Valued, optimize_controller_with as search,
};
use ceworld::episodes::Interruptible;
use ceworld::progress::{LiveLine, Progress};
use ceworld::{Checkpointing, Error, Interrupt, PolicyFile, StopReason};

use crate::convert::{apply_settings, checkpointing, flag, text};
use crate::errors::OrRaise;
use crate::outside::WorldArg;
use crate::policy::PyPolicy;
use crate::results::PyEvaluation;
use crate::signals::Signals;

/// What `optimize_controller` returns (wrapped by `cehmm.ControllerResult`).
#[pyclass(module = "cehmm._core", name = "ControllerOutcome", frozen)]
pub struct PyControllerOutcome {
    file: PolicyFile,
    outcome: ControllerOutcome,
}

#[pymethods]
impl PyControllerOutcome {
    /// The best controller, as a two-level policy with one-hot tables.
    #[getter]
    fn policy(&self) -> PyPolicy {
        PyPolicy { file: self.file.clone() }
    }

    /// Its value: exact, or the mean of `evaluation`.
    #[getter]
    fn value(&self) -> f64 {
        self.outcome.value
    }

    /// `"exact"` or `"sampled"`.
    #[getter]
    fn kind(&self) -> &'static str {
        self.outcome.kind.as_str()
    }

    /// Sampled values: the controller on fresh episodes.
    #[getter]
    fn evaluation(&self) -> Option<PyEvaluation> {
        self.outcome.evaluation.clone().map(PyEvaluation)
    }

    /// One numpy array per statistic, one entry per iteration (all runs, in order).
    #[getter]
    fn history<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        crate::convert::columns(py, &self.outcome.history)
    }

    /// Why the last run stopped.
    #[getter]
    fn stop_reason(&self) -> &'static str {
        self.outcome.stop.as_str()
    }

    /// Whether Ctrl-C stopped it.
    #[getter]
    fn interrupted(&self) -> bool {
        self.outcome.stop == StopReason::Interrupted
    }

    /// The iteration that drew the best controller, within its run.
    #[getter]
    fn best_iteration(&self) -> usize {
        self.outcome.best_iteration
    }

    /// The run that found it.
    #[getter]
    fn restart(&self) -> usize {
        self.outcome.restart
    }

    /// The best value of each run.
    #[getter]
    fn run_values(&self) -> Vec<f64> {
        self.outcome.run_values.clone()
    }

    /// Wall seconds.
    #[getter]
    fn seconds(&self) -> f64 {
        self.outcome.seconds
    }
}

/// Searches a deterministic controller of any world (model §8) with `settings` (keyword
/// settings by name; one left out has the default of the kind of value used); Ctrl-C stops it
/// between iterations and the result comes back marked interrupted.
#[pyfunction]
#[pyo3(signature = (world, settings, *, value=None, progress, checkpoint=None, checkpoint_every=None, resume=None))]
#[allow(clippy::too_many_arguments)]
pub fn optimize_controller(
    py: Python<'_>,
    world: &Bound<'_, PyAny>,
    settings: &Bound<'_, PyDict>,
    value: Option<&Bound<'_, PyAny>>,
    progress: &Bound<'_, PyAny>,
    checkpoint: Option<std::path::PathBuf>,
    checkpoint_every: Option<&Bound<'_, PyAny>>,
    resume: Option<&Bound<'_, PyAny>>,
) -> PyResult<PyControllerOutcome> {
    let kind = value.map(|v| text("value", v)).transpose()?.map(|v| ValueKind::parse(&v)).transpose().or_raise()?;
    let world = WorldArg::of(world)?;
    // The defaults of the kind of value the search will use.
    let resolved = match &world {
        WorldArg::Engine(w) => Valued::of(&w.world, kind).or_raise()?.kind(),
        // A tabular world sampled elsewhere is valued as it would be here.
        WorldArg::Remote(r) if r.tabular => kind.unwrap_or(ValueKind::Exact),
        WorldArg::Outside(_) | WorldArg::Remote(_) => ValueKind::Sampled,
    };
    let mut config = ControllerConfig::defaults_for(resolved);
    apply_settings(&mut config, settings)?;
    let progress = flag("progress", progress)?;
    let checkpointing = checkpointing::<ceworld::ce::controller::checkpoint::ControllerSearch>(
        py,
        checkpoint,
        checkpoint_every,
        resume,
    )?;
    let checkpointing = checkpointing.as_ref();
    let mut signals = Signals::default();
    let interrupt = signals.interrupt().clone();
    let outcome = match &world {
        WorldArg::Engine(w) => {
            let any = &w.world;
            let search = || {
                ceworld::catch_panics(|| match Valued::of(any, kind)? {
                    Valued::Sampled(w) => {
                        let w = Interruptible::new(w, interrupt.clone());
                        run(Valued::Sampled(&w), &config, checkpointing, progress, &interrupt)
                    }
                    exact => run(exact, &config, checkpointing, progress, &interrupt),
                })
            };
            signals.watch(py, search)?.or_raise()
        }
        WorldArg::Outside(_) | WorldArg::Remote(_) => {
            if resolved == ValueKind::Exact {
                return world.run_watched(py, &mut signals, |w| {
                    let remote = w.remote().expect("a world sampled elsewhere");
                    run(Valued::ExactElsewhere(w, remote), &config, checkpointing, progress, &interrupt)
                });
            }
            if kind == Some(ValueKind::Exact) {
                let what = if matches!(world, WorldArg::Remote(_)) {
                    "a world sampled elsewhere that is not tabular (exact values need a cehmm.PomdpWorld; use \"sampled\")"
                } else {
                    "a world written in Python (exact values need a cehmm.PomdpWorld; use \"sampled\")"
                };
                return Err(Error::invalid("value", format!("\"exact\" for {what}"))).or_raise();
            }
            world.run_watched(py, &mut signals, |w| {
                run(Valued::Sampled(w), &config, checkpointing, progress, &interrupt)
            })
        }
    };
    signals.finish(py)?;
    let outcome = outcome?;
    crate::errors::warn_checkpoint(py, outcome.outcome.checkpoint_error.as_deref())?;
    Ok(outcome)
}

/// The search with its progress line.
fn run(
    world: Valued<'_>,
    config: &ControllerConfig,
    checkpointing: Option<&Checkpointing>,
    progress: bool,
    interrupt: &Interrupt,
) -> ceworld::Result<PyControllerOutcome> {
    let mut line = progress.then(|| Progress::new(config.patience, config.restarts, LiveLine::stderr()));
    let outcome = search(world, config, checkpointing, |r| {
        if let Some(line) = &mut line {
            line.update(r);
        }
        interrupt.flow()
    });
    if let Some(line) = line {
        line.finish();
    }
    outcome.map(|outcome| PyControllerOutcome { file: outcome.to_file(world.episodes(), config), outcome })
}
