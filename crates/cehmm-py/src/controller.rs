//! `cehmm._core.optimize_controller`: the cross-entropy method over deterministic controllers of
//! a tabular world (model §8), its result a frozen `ControllerOutcome`.

use numpy::PyArray1;
use pyo3::prelude::*;
use pyo3::types::PyDict;

use ceworld::ce::controller::{
    ControllerConfig, ControllerIteration, ControllerOutcome, optimize_controller as search,
};
use ceworld::progress::LiveLine;
use ceworld::{AnyWorld, Error, PolicyFile, StopReason};

use crate::convert::{count, flag, optional_count, optional_real, real, seed};
use crate::errors::OrRaise;
use crate::policy::PyPolicy;
use crate::signals::Signals;
use crate::world::PyWorld;

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

    /// Its exact value.
    #[getter]
    fn value(&self) -> f64 {
        self.outcome.value
    }

    /// One numpy array per statistic, one entry per iteration (all runs, in order).
    #[getter]
    fn history<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let h = &self.outcome.history;
        let column = |f: fn(&ControllerIteration) -> f64| PyArray1::from_iter(py, h.iter().map(f));
        let index = |f: fn(&ControllerIteration) -> usize| PyArray1::from_iter(py, h.iter().map(|r| f(r) as i64));
        let history = PyDict::new(py);
        history.set_item("restart", index(|r| r.restart))?;
        history.set_item("iteration", index(|r| r.iteration))?;
        history.set_item("mean", column(|r| r.mean))?;
        history.set_item("elite_min", column(|r| r.elite_min))?;
        history.set_item("max", column(|r| r.max))?;
        history.set_item("best", column(|r| r.best))?;
        history.set_item("concentration", column(|r| r.concentration))?;
        history.set_item("evaluated", index(|r| r.evaluated))?;
        history.set_item("seconds", column(|r| r.seconds))?;
        Ok(history)
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

/// Searches a deterministic controller of a tabular world (model §8); Ctrl-C stops it between
/// iterations and the result comes back marked interrupted.
#[pyfunction]
#[pyo3(signature = (
    world, *, nodes, samples, rho, smoothing, patience, max_iterations, time_limit, tolerance, seed, threads, restarts,
    progress
))]
#[allow(clippy::too_many_arguments)]
pub fn optimize_controller(
    py: Python<'_>,
    world: &PyWorld,
    nodes: &Bound<'_, PyAny>,
    samples: &Bound<'_, PyAny>,
    rho: &Bound<'_, PyAny>,
    smoothing: &Bound<'_, PyAny>,
    patience: &Bound<'_, PyAny>,
    max_iterations: Option<&Bound<'_, PyAny>>,
    time_limit: Option<&Bound<'_, PyAny>>,
    tolerance: &Bound<'_, PyAny>,
    seed: &Bound<'_, PyAny>,
    threads: Option<&Bound<'_, PyAny>>,
    restarts: &Bound<'_, PyAny>,
    progress: &Bound<'_, PyAny>,
) -> PyResult<PyControllerOutcome> {
    let config = ControllerConfig {
        nodes: count("nodes", nodes)?,
        samples: count("samples", samples)?,
        rho: real("rho", rho)?,
        smoothing: real("smoothing", smoothing)?,
        patience: count("patience", patience)?,
        max_iterations: optional_count("max_iterations", max_iterations)?,
        time_limit: optional_real("time_limit", time_limit)?,
        tolerance: real("tolerance", tolerance)?,
        seed: self::seed("seed", seed)?,
        threads: optional_count("threads", threads)?,
        restarts: count("restarts", restarts)?,
    };
    let progress = flag("progress", progress)?;
    let AnyWorld::Pomdp(world) = &world.world else {
        return Err(Error::invalid("world", "not tabular (a controller search needs a cehmm.PomdpWorld)")).or_raise();
    };
    let mut signals = Signals::default();
    let outcome = py.detach(|| {
        ceworld::catch_panics(|| {
            let mut line = progress.then(LiveLine::stderr);
            let outcome = search(world, &config, |r| {
                if let Some(line) = &mut line {
                    line.update(format!(
                        "run {} iter {:>5}  mean {:>10.4}  elite>= {:>10.4}  best {:>10.4}  {:>6.1}s",
                        r.restart, r.iteration, r.mean, r.elite_min, r.best, r.seconds
                    ));
                }
                signals.flow()
            });
            if let Some(line) = line {
                line.finish();
            }
            outcome.map(|outcome| PyControllerOutcome {
                file: PolicyFile::from_controller(world, &outcome, &config),
                outcome,
            })
        })
    });
    signals.finish(py)?;
    outcome.or_raise()
}
