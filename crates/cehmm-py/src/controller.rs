//! `cehmm._core.optimize_controller`: the cross-entropy method over deterministic controllers of
//! any world, on exact or sampled values (model §8), its result a frozen `ControllerOutcome`.

use numpy::PyArray1;
use pyo3::prelude::*;
use pyo3::types::PyDict;

use ceworld::ce::controller::{
    ControllerConfig, ControllerIteration, ControllerOutcome, Template, ValueKind, Valued,
    optimize_controller_with as search,
};
use ceworld::progress::LiveLine;
use ceworld::{Checkpointing, Error, PolicyFile, StopReason};

use crate::convert::{count, flag, optional_count, optional_real, real, seed, text};
use crate::errors::{OrRaise, detached};
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
        history.set_item("injected", PyArray1::from_iter(py, h.iter().map(|r| r.injected)))?;
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

/// Searches a deterministic controller of any world (model §8); Ctrl-C stops it between
/// iterations and the result comes back marked interrupted.
#[pyfunction]
#[pyo3(signature = (
    world, *, nodes, samples=None, rho=None, smoothing, patience, max_iterations, time_limit, tolerance, seed, threads, restarts,
    progress, value=None, episodes=None, candidates=None, select_episodes=None, eval_episodes=None, injection=None,
    injections=None, template=None, template_weight=None, target=None, checkpoint=None, checkpoint_every=None,
    resume=None
))]
#[allow(clippy::too_many_arguments)]
pub fn optimize_controller(
    py: Python<'_>,
    world: &Bound<'_, PyAny>,
    nodes: &Bound<'_, PyAny>,
    samples: Option<&Bound<'_, PyAny>>,
    rho: Option<&Bound<'_, PyAny>>,
    smoothing: &Bound<'_, PyAny>,
    patience: &Bound<'_, PyAny>,
    max_iterations: Option<&Bound<'_, PyAny>>,
    time_limit: Option<&Bound<'_, PyAny>>,
    tolerance: &Bound<'_, PyAny>,
    seed: &Bound<'_, PyAny>,
    threads: Option<&Bound<'_, PyAny>>,
    restarts: &Bound<'_, PyAny>,
    progress: &Bound<'_, PyAny>,
    value: Option<&Bound<'_, PyAny>>,
    episodes: Option<&Bound<'_, PyAny>>,
    candidates: Option<&Bound<'_, PyAny>>,
    select_episodes: Option<&Bound<'_, PyAny>>,
    eval_episodes: Option<&Bound<'_, PyAny>>,
    injection: Option<&Bound<'_, PyAny>>,
    injections: Option<&Bound<'_, PyAny>>,
    template: Option<&Bound<'_, PyAny>>,
    template_weight: Option<&Bound<'_, PyAny>>,
    target: Option<&Bound<'_, PyAny>>,
    checkpoint: Option<std::path::PathBuf>,
    checkpoint_every: Option<&Bound<'_, PyAny>>,
    resume: Option<&Bound<'_, PyAny>>,
) -> PyResult<PyControllerOutcome> {
    let kind = value.map(|v| text("value", v)).transpose()?.map(|v| ValueKind::parse(&v)).transpose().or_raise()?;
    let world = WorldArg::of(world)?;
    // The defaults of the kind of value the search will use.
    let resolved = match &world {
        WorldArg::Engine(w) => Valued::of(&w.world, kind).or_raise()?.kind(),
        WorldArg::Outside(_) => ValueKind::Sampled,
    };
    let d = ControllerConfig::defaults_for(resolved);
    let config = ControllerConfig {
        nodes: count("nodes", nodes)?,
        samples: optional_count("samples", samples)?.unwrap_or(d.samples),
        rho: optional_real("rho", rho)?.unwrap_or(d.rho),
        smoothing: real("smoothing", smoothing)?,
        patience: count("patience", patience)?,
        max_iterations: optional_count("max_iterations", max_iterations)?,
        target: optional_real("target", target)?,
        time_limit: optional_real("time_limit", time_limit)?,
        tolerance: real("tolerance", tolerance)?,
        seed: self::seed("seed", seed)?,
        threads: optional_count("threads", threads)?,
        restarts: count("restarts", restarts)?,
        episodes: optional_count("episodes", episodes)?.unwrap_or(d.episodes),
        candidates: optional_count("candidates", candidates)?.unwrap_or(d.candidates),
        select_episodes: optional_count("select_episodes", select_episodes)?.unwrap_or(d.select_episodes),
        eval_episodes: optional_count("eval_episodes", eval_episodes)?.unwrap_or(d.eval_episodes),
        injection: optional_real("injection", injection)?.unwrap_or(d.injection),
        injections: optional_count("injections", injections)?.unwrap_or(d.injections),
        template: match template {
            Some(t) => Template::parse(&text("template", t)?).or_raise()?,
            None => d.template,
        },
        template_weight: optional_real("template_weight", template_weight)?.unwrap_or(d.template_weight),
    };
    let progress = flag("progress", progress)?;
    let every = optional_real("checkpoint_every", checkpoint_every)?.unwrap_or(ceworld::ce::resume::DEFAULT_EVERY);
    let resume = resume.map(|r| flag("resume", r)).transpose()?.unwrap_or(false);
    if checkpoint.is_none() && resume {
        return Err(Error::invalid("resume", "True without a checkpoint (give checkpoint=PATH)")).or_raise();
    }
    let checkpointing = checkpoint.map(|path| Checkpointing { path, every, resume });
    let checkpointing = checkpointing.as_ref();
    let mut signals = Signals::default();
    let outcome = match &world {
        WorldArg::Engine(w) => {
            let any = &w.world;
            detached(py, || run(Valued::of(any, kind)?, &config, checkpointing, progress, &mut signals))
        }
        WorldArg::Outside(_) => {
            if kind == Some(ValueKind::Exact) {
                return Err(Error::invalid(
                    "value",
                    "\"exact\" for a world written in Python (exact values need a cehmm.PomdpWorld; use \"sampled\")",
                ))
                .or_raise();
            }
            world.run(py, |w| run(Valued::Sampled(w), &config, checkpointing, progress, &mut signals))
        }
    };
    signals.finish(py)?;
    outcome
}

/// The search with its progress line.
fn run(
    world: Valued<'_>,
    config: &ControllerConfig,
    checkpointing: Option<&Checkpointing>,
    progress: bool,
    signals: &mut Signals,
) -> ceworld::Result<PyControllerOutcome> {
    let mut line = progress.then(LiveLine::stderr);
    let outcome = search(world, config, checkpointing, |r| {
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
    outcome.map(|outcome| PyControllerOutcome { file: outcome.to_file(world.episodes(), config), outcome })
}
