//! `cehmm._core.QLearner` (a `ceworld::qlearn::AnyLearner`: Q-learning on any registered world
//! with a known state) and the window evaluation of any policy; wrapped by `cehmm.qlearning`.

use std::path::PathBuf;

use numpy::ndarray::Array2;
use numpy::{IntoPyArray, PyArray1, PyArray2};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use ceworld::qlearn::{AnyLearner, QConfig, Ties, WindowConfig};
use ceworld::{thread_pool, with_learner};

use crate::convert::{apply_settings, count, flag, optional_count, optional_real, real, seed, text, to_py};
use crate::errors::{OrRaise, detached};
use crate::policy::PyPolicy;
use crate::run::PyCallback;
use crate::signals::Signals;
use crate::world::PyWorld;

/// The window settings: the core's defaults, overridden by the settings given.
fn window_config(settings: &Bound<'_, PyDict>) -> PyResult<WindowConfig> {
    let mut config = WindowConfig::default();
    apply_settings(&mut config, settings)?;
    config.validate().or_raise()?;
    Ok(config)
}

/// The learning settings: the core's defaults, overridden by the settings given.
fn q_config(settings: &Bound<'_, PyDict>) -> PyResult<QConfig> {
    let mut config = QConfig::default();
    apply_settings(&mut config, settings)?;
    config.validate().or_raise()?;
    Ok(config)
}

/// The report of `evaluate` with `reference` as 100 % (`cehmm.WindowEvaluation`'s fields).
fn windows(
    py: Python<'_>,
    threads: Option<usize>,
    reference: f64,
    evaluate: impl FnOnce() -> ceworld::Result<ceworld::WindowReport> + Send,
) -> PyResult<Bound<'_, PyDict>> {
    let report = detached(py, || thread_pool(threads)?.install(evaluate))?;
    crate::results::windows(py, &report, reference)
}

/// An HHMM policy evaluated on windows of a continuing run, as the paper compares policies (see
/// `ceworld::qlearn::evaluate_windows`).
#[pyfunction]
#[pyo3(signature = (policy, world, settings, *, seed, threads, reference))]
pub fn evaluate_policy_windows<'py>(
    py: Python<'py>,
    policy: &PyPolicy,
    world: &PyWorld,
    settings: &Bound<'_, PyDict>,
    seed: &Bound<'_, PyAny>,
    threads: Option<&Bound<'_, PyAny>>,
    reference: &Bound<'_, PyAny>,
) -> PyResult<Bound<'py, PyDict>> {
    let (config, seed) = (window_config(settings)?, self::seed("seed", seed)?);
    let (world, policy) = (&world.world, &policy.file.policy);
    let threads = optional_count("threads", threads)?;
    windows(py, threads, real("reference", reference)?, || {
        ceworld::qlearn::evaluate_policy_windows(world, policy, &config, seed)
    })
}

/// A Q-learning run: table, counters, random stream and world state.
#[pyclass(module = "cehmm._core", name = "QLearner")]
pub struct PyQLearner {
    learner: AnyLearner,
}

#[pymethods]
impl PyQLearner {
    /// A fresh run with a zero table (refused with `MemoryError` when it would not fit).
    #[new]
    fn new(py: Python<'_>, world: &PyWorld, settings: &Bound<'_, PyDict>) -> PyResult<Self> {
        let config = q_config(settings)?;
        let world = world.world.clone();
        Ok(PyQLearner { learner: detached(py, || AnyLearner::new(world, config))? })
    }

    /// Reads a run saved by `save` (or a `ceworld qlearn` checkpoint).
    #[staticmethod]
    fn load(py: Python<'_>, path: PathBuf) -> PyResult<Self> {
        Ok(PyQLearner { learner: detached(py, || AnyLearner::load(path))? })
    }

    /// Reads the run saved in `path` to continue it: it must have been made in `world` with
    /// these settings.
    #[staticmethod]
    fn resume(py: Python<'_>, path: PathBuf, world: &PyWorld, settings: &Bound<'_, PyDict>) -> PyResult<Self> {
        let config = q_config(settings)?;
        let world = &world.world;
        Ok(PyQLearner { learner: detached(py, || AnyLearner::resume(path, world, &config))? })
    }

    /// Writes the run (header and table), atomically; an existing file is replaced only when
    /// `overwrite`.
    #[pyo3(signature = (path, *, overwrite = false))]
    fn save(&self, py: Python<'_>, path: PathBuf, overwrite: bool) -> PyResult<()> {
        if !overwrite {
            ceworld::files::check_new("path", &path, "give overwrite=True").or_raise()?;
        }
        let learner = &self.learner;
        detached(py, || with_learner!(learner, q => q.save(path)))
    }

    /// Runs until `until` updates in all; Ctrl-C stops between chunks of updates (after saving
    /// the checkpoint, when there is one), and so does `callback` (called after every chunk:
    /// `crate::run::PyCallback`); returns why it stopped early (`"interrupted"`, `"callback"`)
    /// or `None`.
    #[pyo3(signature = (until, *, progress, checkpoint = None, checkpoint_every = None, callback = None))]
    fn train(
        &mut self,
        py: Python<'_>,
        until: &Bound<'_, PyAny>,
        progress: &Bound<'_, PyAny>,
        checkpoint: Option<PathBuf>,
        checkpoint_every: Option<&Bound<'_, PyAny>>,
        callback: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Option<&'static str>> {
        let until = self::seed("iterations", until)?;
        let progress = flag("progress", progress)?;
        let every = optional_real("checkpoint_every", checkpoint_every)?;
        let learner = &mut self.learner;
        let mut signals = Signals::default();
        let callback = PyCallback::new(callback, &signals)?;
        let interrupt = signals.interrupt().clone();
        let outcome = signals.watch(py, || {
            ceworld::catch_panics(|| {
                let stop = || interrupt.flow();
                let call = callback.as_ref().map(|c| move |it: &ceworld::run::Iteration<'_>| c.call(it));
                let callback = call.as_ref().map(|c| c as _);
                let options = ceworld::run::RunOptions { progress, checkpointing: None, stop: &stop, callback };
                with_learner!(learner, q => ceworld::run::qlearn(q, until, checkpoint.as_deref(), every, &options))
            })
        })?;
        callback.map(PyCallback::finish).transpose()?;
        signals.finish(py)?;
        let outcome = outcome.or_raise()?;
        crate::errors::warn_checkpoint(py, outcome.checkpoint_error.as_deref())?;
        Ok(outcome.stop.map(ceworld::StopReason::as_str))
    }

    /// The greedy policy evaluated on windows of `world`; ties broken as in learning unless
    /// `ties` says otherwise.
    #[pyo3(signature = (world, settings, *, seed, threads, reference, ties))]
    #[allow(clippy::too_many_arguments)]
    fn evaluate_windows<'py>(
        &self,
        py: Python<'py>,
        world: &PyWorld,
        settings: &Bound<'_, PyDict>,
        seed: &Bound<'_, PyAny>,
        threads: Option<&Bound<'_, PyAny>>,
        reference: &Bound<'_, PyAny>,
        ties: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let (config, seed) = (window_config(settings)?, self::seed("seed", seed)?);
        let ties = match ties.filter(|t| !t.is_none()) {
            Some(t) => Some(Ties::parse(&text("ties", t)?).or_raise()?),
            None => None,
        };
        let (learner, world) = (&self.learner, &world.world);
        let threads = optional_count("threads", threads)?;
        windows(py, threads, real("reference", reference)?, || learner.evaluate_windows(world, ties, &config, seed))
    }

    /// Size of the table in bytes.
    #[getter]
    fn table_bytes(&self) -> u64 {
        with_learner!(&self.learner, q => q.table().bytes())
    }

    /// The header of the run's file (settings, counters, random stream, world state) as a dict.
    fn header<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &with_learner!(&self.learner, q => q.header()))
    }

    /// The world the table was learnt in.
    fn world(&self) -> PyWorld {
        PyWorld { world: self.learner.world() }
    }

    /// A copy of the table, float32, shape `(n_states, n_actions)`.
    fn table<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f32>> {
        with_learner!(&self.learner, q => {
            let t = q.table();
            let values = py.detach(|| t.values().to_vec());
            Array2::from_shape_vec((t.n_states(), t.n_actions()), values).expect("the table's shape").into_pyarray(py)
        })
    }

    /// `Q(s, ·)`, float32, shape `(n_actions,)`.
    fn row<'py>(&self, py: Python<'py>, state: &Bound<'_, PyAny>) -> PyResult<Bound<'py, PyArray1<f32>>> {
        Ok(PyArray1::from_vec(py, self.learner.row(count("state", state)?).or_raise()?))
    }

    /// The known state of a world state (as `World::describe` writes it) seen through
    /// observation `y`.
    fn state_index(&self, state: Vec<i64>, y: &Bound<'_, PyAny>) -> PyResult<usize> {
        self.learner.state_index(&state, count("y", y)?).or_raise()
    }
}
