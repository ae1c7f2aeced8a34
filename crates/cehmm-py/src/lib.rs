//! Python bindings of the `ceworld` engine, built by maturin as the private module `cehmm._core`.
//!
//! Each function converts its arguments, calls the core and converts the result (`defaults.rs`
//! exports the core's defaults and constants). Optimisation, evaluation and rollouts run detached from the interpreter
//! (`py.detach`); an optimisation checks for Ctrl-C between iterations and then returns what it
//! has, marked interrupted. The documented public API is the Python layer in `python/cehmm/`;
//! the stub `python/cehmm/_core.pyi` lists what this module exports.

#![allow(clippy::needless_pass_by_value)] // pyo3 extracts arguments by value
#![allow(clippy::redundant_closure_for_method_calls)] // `Python::attach` needs a closure, not a path

mod defaults;

use std::path::PathBuf;

use numpy::ndarray::{Array2, ArrayD, IxDyn};
use numpy::{IntoPyArray, PyArray1, PyArray2, PyReadonlyArrayDyn, PyUntypedArrayMethods};
use pyo3::create_exception;
use pyo3::exceptions::{PyMemoryError, PyOSError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict};
use serde_json::{Value, json};

use ceworld::ce::episode::run_with;
use ceworld::evaluate::check_fits;
use ceworld::progress::{CeProgress, LiveLine};
use ceworld::qlearn::{Greedy, KnownState, QConfig, QLearner, Ties, WindowConfig, WindowReport, evaluate_windows};
use ceworld::rng::{Purpose, stream};
use ceworld::thread_pool;
use ceworld::{
    CeConfig, Error, Evaluation, Flow, Hhmm, IterationRecord, Layout, PolicyFile, TrackingParams, World, random_policy,
    uniform_policy,
};

create_exception!(cehmm, CehmmError, PyValueError, "Base class of the errors raised by cehmm (a ValueError).");
create_exception!(
    cehmm,
    InvalidArgumentError,
    CehmmError,
    "An argument outside its domain or of the wrong type; the message names it and what was expected."
);
create_exception!(
    cehmm,
    PolicyFormatError,
    CehmmError,
    "A policy file or table that is not a valid cehmm policy (model §6): wrong shape, negative or \
     non-finite entry, row not summing to 1, bad JSON."
);
create_exception!(
    cehmm,
    PolicyMismatchError,
    CehmmError,
    "A policy used with a world whose numbers of observations or decisions differ from the policy's."
);

/// The one mapping of core errors to Python exceptions. `Error::Io` becomes the built-in
/// `OSError` subclass of its errno (`FileNotFoundError`, `PermissionError`, ...), with `filename`.
fn raise(error: Error) -> PyErr {
    let message = error.to_string();
    match error {
        Error::InvalidArgument { .. } => InvalidArgumentError::new_err(message),
        Error::PolicyFormat { .. } => PolicyFormatError::new_err(message),
        Error::Mismatch(_) => PolicyMismatchError::new_err(message),
        Error::Memory { .. } => PyMemoryError::new_err(message),
        Error::Io { path, source } => match source.raw_os_error() {
            Some(errno) => {
                let text = source.to_string();
                let text = text.strip_suffix(&format!(" (os error {errno})")).unwrap_or(&text).to_string();
                PyOSError::new_err((errno, text, path.display().to_string()))
            }
            None => PyOSError::new_err(message),
        },
    }
}

/// A JSON value as the Python object `json.loads` makes of it.
fn to_python<'py>(py: Python<'py>, value: &Value) -> PyResult<Bound<'py, PyAny>> {
    py.import("json")?.call_method1("loads", (value.to_string(),))
}

/// A JSON object from its text (`None`: an empty object).
fn parse_object(name: &str, text: Option<&str>) -> PyResult<Value> {
    match text {
        None => Ok(json!({})),
        Some(t) => match serde_json::from_str::<Value>(t) {
            Ok(v @ Value::Object(_)) => Ok(v),
            Ok(other) => Err(raise(Error::invalid(name, format!("{other} (expected a JSON object)")))),
            Err(e) => Err(raise(Error::invalid(name, format!("not JSON ({e})")))),
        },
    }
}

/// `(16, 16)`: a shape as Python prints it.
fn shape_text(dims: &[usize]) -> String {
    match dims {
        [one] => format!("({one},)"),
        _ => format!("({})", dims.iter().map(ToString::to_string).collect::<Vec<_>>().join(", ")),
    }
}

/// An int from a Python value (a bool is refused, though Python counts it as an int).
fn int_param(value: &Bound<'_, PyAny>) -> Option<i64> {
    if value.is_instance_of::<PyBool>() { None } else { value.extract::<i64>().ok() }
}

/// A world parameter's JSON value from its Python value, typed after its default.
fn param_value(key: &str, default: &Value, value: &Bound<'_, PyAny>) -> PyResult<Value> {
    let shown = value.repr().map_or_else(|_| "?".into(), |r| r.to_string());
    let wrong = |expected: String| raise(Error::invalid(key, format!("{shown} (expected {expected})")));
    match default {
        Value::Array(items) => {
            let n = items.len();
            let expected = || wrong(format!("a list of {n} ints"));
            if value.is_instance_of::<pyo3::types::PyString>() {
                return Err(expected());
            }
            let elements: Vec<Bound<'_, PyAny>> = value.extract().map_err(|_| expected())?;
            if elements.len() != n {
                return Err(expected());
            }
            elements.iter().map(|e| int_param(e).map(Value::from).ok_or_else(expected)).collect()
        }
        _ => int_param(value).map(Value::from).ok_or_else(|| wrong("an int".into())),
    }
}

/// The target-tracking world of model §4 (wrapped by `cehmm.TargetTracking`).
#[pyclass(module = "cehmm._core", name = "TargetTracking", frozen)]
struct PyTargetTracking {
    world: ceworld::TargetTracking,
}

#[pymethods]
impl PyTargetTracking {
    /// The world of `case` with the given parameters (the fields of `TrackingParams`).
    #[new]
    #[pyo3(signature = (case = None, **params))]
    fn new(case: Option<&Bound<'_, PyAny>>, params: Option<&Bound<'_, PyDict>>) -> PyResult<Self> {
        let defaults = serde_json::to_value(TrackingParams::default()).expect("parameters serialise");
        let mut values = defaults.clone();
        let mut given: Vec<(String, Bound<'_, PyAny>)> = Vec::new();
        if let Some(case) = case {
            given.push(("case".into(), case.clone()));
        }
        for (key, value) in params.into_iter().flatten() {
            given.push((key.extract()?, value));
        }
        for (key, value) in &given {
            let Some(default) = defaults.get(key) else {
                let known: Vec<&str> = defaults.as_object().expect("an object").keys().map(String::as_str).collect();
                let known = known.join(", ");
                return Err(raise(Error::invalid(
                    "world parameter",
                    format!("unknown {key:?} (expected one of: {known})"),
                )));
            };
            let json = param_value(key, default, value)?;
            // Deserialising the defaults with only this key changed names the key that is out of range.
            let mut probe = defaults.clone();
            probe[key.as_str()] = json.clone();
            if let Err(e) = serde_json::from_value::<TrackingParams>(probe) {
                return Err(raise(Error::invalid(key.as_str(), format!("{json} is out of range ({e})"))));
            }
            values[key.as_str()] = json;
        }
        let params: TrackingParams =
            serde_json::from_value(values).map_err(|e| raise(Error::invalid("world", e.to_string())))?;
        Ok(PyTargetTracking { world: ceworld::TargetTracking::with_params(params).map_err(raise)? })
    }

    /// 1: fixed target; 2: moving target, no observation; 3: moving target, observed.
    #[getter]
    fn case(&self) -> u8 {
        self.world.params().case
    }

    /// Number of observations `Y`.
    #[getter]
    fn n_observations(&self) -> usize {
        self.world.n_observations()
    }

    /// Number of decisions `D`.
    #[getter]
    fn n_decisions(&self) -> usize {
        self.world.n_decisions()
    }

    /// Steps per episode `T`.
    #[getter]
    fn horizon(&self) -> usize {
        self.world.horizon()
    }

    /// Every parameter, `case` included, as a dict.
    #[getter]
    fn params<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_python(py, &serde_json::to_value(self.world.params()).expect("parameters serialise"))
    }

    /// The world as stored in policy files: its name and every parameter.
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_python(py, &self.world.to_json())
    }

    /// Names of the numbers of one state in a rollout's `x`.
    fn state_labels(&self) -> Vec<&'static str> {
        self.world.state_labels()
    }

    /// The exact optimum (case 1 only).
    fn optimum(&self) -> PyResult<u32> {
        self.world.case1_optimum().map_err(raise)
    }
}

/// A policy with its world and provenance (a `ceworld::PolicyFile`; wrapped by `cehmm.Policy`).
#[pyclass(module = "cehmm._core", name = "Policy", frozen)]
struct PyPolicy {
    file: PolicyFile,
}

impl PyPolicy {
    fn new(policy: Hhmm, world: Value, provenance: Value) -> Self {
        PyPolicy { file: PolicyFile { policy, world, provenance } }
    }
}

/// A policy table read from numpy, checked against its expected shape.
fn table_entries(name: &str, array: &PyReadonlyArrayDyn<'_, f64>, dims: &[usize], out: &mut Vec<f64>) -> PyResult<()> {
    if array.shape() != dims {
        return Err(raise(Error::format(format!(
            "{name} has shape {} (expected {})",
            shape_text(array.shape()),
            shape_text(dims)
        ))));
    }
    out.extend(array.as_array().iter().copied());
    Ok(())
}

/// A table's size, or a format error naming the table and the rank it needs.
fn dim(name: &str, array: &PyReadonlyArrayDyn<'_, f64>, rank: usize, axes: &str, axis: usize) -> PyResult<usize> {
    if array.ndim() != rank {
        return Err(raise(Error::format(format!(
            "{name} has shape {} (expected {rank} axes {axes})",
            shape_text(array.shape())
        ))));
    }
    Ok(array.shape()[axis])
}

fn evaluation_dict<'py>(py: Python<'py>, e: &Evaluation) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("episodes", e.episodes)?;
    d.set_item("mean", e.mean)?;
    d.set_item("std_error", e.std_error)?;
    d.set_item("std", e.std)?;
    d.set_item("min", e.min)?;
    d.set_item("max", e.max)?;
    let q = PyDict::new(py);
    for &(k, v) in &e.quantiles {
        q.set_item(k, v)?;
    }
    d.set_item("quantiles", q)?;
    Ok(d)
}

#[pymethods]
impl PyPolicy {
    /// Every row uniform (the CE starting point).
    #[staticmethod]
    fn uniform(world: &PyTargetTracking, levels: Vec<usize>) -> PyResult<Self> {
        let policy = uniform_policy(&world.world, &levels).map_err(raise)?;
        Ok(Self::new(policy, world.world.to_json(), json!({})))
    }

    /// A two-level clock: the memory counts the steps, `h0` is uniform (see `Hhmm::clock`).
    #[staticmethod]
    fn clock(world: &PyTargetTracking, levels: Vec<usize>) -> PyResult<Self> {
        let policy = ceworld::clock_policy(&world.world, &levels).map_err(raise)?;
        Ok(Self::new(policy, world.world.to_json(), json!({})))
    }

    /// Random rows drawn from `seed`.
    #[staticmethod]
    fn random(world: &PyTargetTracking, levels: Vec<usize>, seed: u64) -> PyResult<Self> {
        let policy = random_policy(&world.world, &levels, seed).map_err(raise)?;
        Ok(Self::new(policy, world.world.to_json(), json!({})))
    }

    /// A policy from float64 tables; the layout is read from the shapes, then every shape and
    /// row is checked. With a world, the policy must fit it.
    #[staticmethod]
    #[pyo3(signature = (h0, h1, upper, world = None, provenance_json = None))]
    fn from_tables(
        h0: PyReadonlyArrayDyn<'_, f64>,
        h1: PyReadonlyArrayDyn<'_, f64>,
        upper: Vec<(PyReadonlyArrayDyn<'_, f64>, PyReadonlyArrayDyn<'_, f64>)>,
        world: Option<&PyTargetTracking>,
        provenance_json: Option<&str>,
    ) -> PyResult<Self> {
        let mut levels = vec![dim("h0", &h0, 2, "(|M_1|, D)", 0)?];
        let n_actions = dim("h0", &h0, 2, "(|M_1|, D)", 1)?;
        let n_obs = dim("h1", &h1, 3, "(Y, U, |M_1|)", 0)?;
        for (k, (start, step)) in upper.iter().enumerate() {
            levels.push(dim(&format!("upper[{k}].start"), start, 2, "(U, |M_l|)", 1)?);
            dim(&format!("upper[{k}].step"), step, 3, "(|M_l-1|, U, |M_l|)", 0)?;
        }
        let layout = Layout::new(n_obs, n_actions, &levels).map_err(|e| raise(Error::format(e.to_string())))?;
        let mut probs = Vec::with_capacity(layout.len);
        table_entries("h0", &h0, &layout.tables[0].dims, &mut probs)?;
        table_entries("h1", &h1, &layout.tables[1].dims, &mut probs)?;
        for (k, (start, step)) in upper.iter().enumerate() {
            let level = k + 2;
            table_entries(
                &format!("upper[{k}].start"),
                start,
                &layout.tables[Layout::start_table(level)].dims,
                &mut probs,
            )?;
            table_entries(
                &format!("upper[{k}].step"),
                step,
                &layout.tables[Layout::step_table(level)].dims,
                &mut probs,
            )?;
        }
        let policy = Hhmm::from_flat(layout, probs).map_err(raise)?;
        let world = match world {
            Some(w) => {
                check_fits(&w.world, &policy).map_err(raise)?;
                w.world.to_json()
            }
            None => json!({}),
        };
        Ok(Self::new(policy, world, parse_object("provenance", provenance_json)?))
    }

    /// Reads and checks a policy file (model §6).
    #[staticmethod]
    fn load(path: PathBuf) -> PyResult<Self> {
        Ok(PyPolicy { file: PolicyFile::load(path).map_err(raise)? })
    }

    /// Reads and checks a policy document (model §6) from its JSON text.
    #[staticmethod]
    fn from_json(text: &str) -> PyResult<Self> {
        let doc: Value = serde_json::from_str(text).map_err(|e| raise(Error::format(format!("not JSON: {e}"))))?;
        Ok(PyPolicy { file: PolicyFile::from_json(&doc).map_err(raise)? })
    }

    /// Writes the policy file (model §6).
    fn save(&self, path: PathBuf) -> PyResult<()> {
        self.file.save(path).map_err(raise)
    }

    /// The policy document (model §6) as JSON text.
    fn to_json(&self) -> String {
        self.file.to_json().to_string()
    }

    /// Memory sizes per level, bottom first.
    #[getter]
    fn levels(&self) -> Vec<usize> {
        self.file.policy.levels().to_vec()
    }

    /// Number of observations `Y`.
    #[getter]
    fn n_obs(&self) -> usize {
        self.file.policy.layout().n_obs
    }

    /// Number of decisions `D`.
    #[getter]
    fn n_actions(&self) -> usize {
        self.file.policy.layout().n_actions
    }

    /// The paper's count of free parameters (start tables excluded).
    #[getter]
    fn parameter_count(&self) -> usize {
        self.file.policy.layout().parameter_count()
    }

    /// The `"world"` object of the file.
    #[getter]
    fn world<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_python(py, &self.file.world)
    }

    /// The `"provenance"` object of the file.
    #[getter]
    fn provenance<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_python(py, &self.file.provenance)
    }

    /// `{"h0": array, "h1": array, "upper": [{"start": array, "step": array}, ...]}`, float64,
    /// shapes as in model §6.
    fn tables<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let h = &self.file.policy;
        let layout = h.layout();
        let array = |index: usize| {
            let dims = &layout.tables[index].dims;
            ArrayD::from_shape_vec(IxDyn(dims), h.table(index).to_vec()).expect("table sizes match").into_pyarray(py)
        };
        let d = PyDict::new(py);
        d.set_item("h0", array(0))?;
        d.set_item("h1", array(1))?;
        let mut upper = Vec::new();
        for level in 2..=layout.depth() {
            let entry = PyDict::new(py);
            entry.set_item("start", array(Layout::start_table(level)))?;
            entry.set_item("step", array(Layout::step_table(level)))?;
            upper.push(entry);
        }
        d.set_item("upper", upper)?;
        Ok(d)
    }

    /// Reward statistics over `episodes` fresh episodes (streams `(seed, Evaluate, 0, k)`).
    #[pyo3(signature = (world, episodes, seed, threads = None))]
    fn evaluate<'py>(
        &self,
        py: Python<'py>,
        world: &PyTargetTracking,
        episodes: usize,
        seed: u64,
        threads: Option<usize>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let (world, policy) = (&world.world, &self.file.policy);
        let evaluation = py
            .detach(|| thread_pool(threads)?.install(|| ceworld::evaluate(world, policy, episodes, seed)))
            .map_err(raise)?;
        evaluation_dict(py, &evaluation)
    }

    /// One recorded episode: episode `episode` of `evaluate(world, _, seed)`.
    #[pyo3(signature = (world, seed, episode = 0))]
    fn rollout<'py>(
        &self,
        py: Python<'py>,
        world: &PyTargetTracking,
        seed: u64,
        episode: u64,
    ) -> PyResult<Bound<'py, PyDict>> {
        let (world, policy) = (&world.world, &self.file.policy);
        let (x, y, d, memory, reward) = py
            .detach(|| {
                check_fits(world, policy)?;
                let mut rng = stream(seed, Purpose::Evaluate, 0, episode);
                let (mut x, mut y, mut d, mut memory) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
                let reward = run_with(world, policy, &mut rng, |_, yt, dt, m, state| {
                    world.describe(state, &mut x);
                    y.push(yt as i64);
                    d.push(dt as i64);
                    memory.extend(m.iter().map(|&v| i64::from(v)));
                });
                Ok::<_, Error>((x, y, d, memory, reward))
            })
            .map_err(raise)?;
        let steps = y.len();
        let labels = world.state_labels();
        let out = PyDict::new(py);
        out.set_item(
            "x",
            Array2::from_shape_vec((steps, labels.len()), x).expect("one state per step").into_pyarray(py),
        )?;
        out.set_item("x_labels", labels)?;
        out.set_item("y", PyArray1::from_vec(py, y))?;
        out.set_item("d", PyArray1::from_vec(py, d))?;
        let depth = policy.levels().len();
        out.set_item(
            "memory",
            Array2::from_shape_vec((steps, depth), memory).expect("Λ states per step").into_pyarray(py),
        )?;
        out.set_item("reward", reward)?;
        Ok(out)
    }
}

/// Runs the cross-entropy method (model §3) from `initial`; Ctrl-C stops it between iterations
/// and the result comes back marked interrupted.
#[pyfunction]
#[pyo3(signature = (
    world, initial, *, samples, rho, smoothing, patience, max_iterations, time_limit, target, seed, threads,
    eval_episodes, progress, memory_update = "sampled", restarts = 1
))]
#[allow(clippy::too_many_arguments)]
fn optimize<'py>(
    py: Python<'py>,
    world: &PyTargetTracking,
    initial: &PyPolicy,
    samples: usize,
    rho: f64,
    smoothing: f64,
    patience: usize,
    max_iterations: Option<usize>,
    time_limit: Option<f64>,
    target: Option<f64>,
    seed: u64,
    threads: Option<usize>,
    eval_episodes: usize,
    progress: bool,
    memory_update: &str,
    restarts: usize,
) -> PyResult<Bound<'py, PyDict>> {
    let memory_update = memory_update.parse().map_err(raise)?;
    let config = CeConfig {
        samples,
        rho,
        smoothing,
        patience,
        max_iterations,
        time_limit,
        target,
        seed,
        threads,
        eval_episodes,
        memory_update,
        restarts,
    };
    let world = &world.world;
    let initial = initial.file.policy.clone();
    let result = py
        .detach(|| {
            let mut line = progress.then(|| CeProgress::new(config.patience, LiveLine::stderr()));
            let result = ceworld::optimize(world, initial, &config, |record| {
                if let Some(line) = &mut line {
                    line.update(record);
                }
                // A pending KeyboardInterrupt is consumed here: the caller gets the result so far.
                match Python::attach(|py| py.check_signals()) {
                    Ok(()) => Flow::Continue,
                    Err(_) => Flow::Stop,
                }
            });
            if let Some(line) = line {
                line.finish();
            }
            result
        })
        .map_err(raise)?;

    let best = PolicyFile::from_result(world, &result, &config);
    let mut provenance = best.provenance.clone();
    if let Some(map) = provenance.as_object_mut() {
        // The evaluation and best-iteration figures describe the best policy, not the last one.
        map.retain(|k, _| !(k == "mean_reward" || k.starts_with("evaluation") || k.starts_with("best_iteration")));
        map.insert("policy".into(), json!("last"));
    }
    let last = PyPolicy::new(result.last_policy.clone(), best.world.clone(), provenance);

    let h = &result.history;
    let column = |f: fn(&IterationRecord) -> f64| PyArray1::from_iter(py, h.iter().map(f));
    let history = PyDict::new(py);
    history.set_item("iteration", PyArray1::from_iter(py, h.iter().map(|r| r.iteration as i64)))?;
    history.set_item("mean", column(|r| r.mean))?;
    history.set_item("best", column(|r| r.best))?;
    history.set_item("elite_threshold", column(|r| r.elite_threshold))?;
    history.set_item("elite_mean", column(|r| r.elite_mean))?;
    history.set_item("seconds", column(|r| r.seconds))?;
    history.set_item("successful", PyArray1::from_iter(py, h.iter().map(|r| r.successful)))?;

    let out = PyDict::new(py);
    out.set_item("policy", PyPolicy { file: best })?;
    out.set_item("last_policy", last)?;
    out.set_item("history", history)?;
    out.set_item("evaluation", evaluation_dict(py, &result.evaluation)?)?;
    out.set_item("stop_reason", result.stop.as_str())?;
    out.set_item("interrupted", result.interrupted())?;
    out.set_item("best_iteration", result.best_iteration)?;
    out.set_item("iterations", h.len())?;
    out.set_item("seconds", result.seconds)?;
    Ok(out)
}

/// A window configuration from its keyword arguments.
fn window_config(
    window: usize,
    episodes: usize,
    chains: usize,
    burn_in: u64,
    windows_per_chain: usize,
) -> WindowConfig {
    WindowConfig { window, episodes, chains, burn_in, windows_per_chain }
}

fn window_report_dict<'py>(py: Python<'py>, report: &WindowReport) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("from_start", evaluation_dict(py, &report.from_start)?)?;
    d.set_item("continuing", evaluation_dict(py, &report.continuing)?)?;
    Ok(d)
}

/// An HHMM policy evaluated on 100-step windows as the paper compares policies (see
/// `ceworld::qlearn::evaluate_windows`).
#[pyfunction]
#[pyo3(signature = (policy, world, *, window, episodes, chains, burn_in, windows_per_chain, seed, threads = None))]
#[allow(clippy::too_many_arguments)]
fn evaluate_policy_windows<'py>(
    py: Python<'py>,
    policy: &PyPolicy,
    world: &PyTargetTracking,
    window: usize,
    episodes: usize,
    chains: usize,
    burn_in: u64,
    windows_per_chain: usize,
    seed: u64,
    threads: Option<usize>,
) -> PyResult<Bound<'py, PyDict>> {
    let config = window_config(window, episodes, chains, burn_in, windows_per_chain);
    let (world, policy) = (&world.world, &policy.file.policy);
    let report = py
        .detach(|| thread_pool(threads)?.install(|| evaluate_windows(world, policy, &config, seed)))
        .map_err(raise)?;
    window_report_dict(py, &report)
}

/// A Q-learning run on the target-tracking world (a `ceworld::QLearner`; wrapped by
/// `cehmm.QLearner`).
#[pyclass(module = "cehmm._core", name = "QLearner")]
struct PyQLearner {
    learner: QLearner<ceworld::TargetTracking>,
}

#[pymethods]
impl PyQLearner {
    /// A fresh run with a zero table (refused with `MemoryError` when it would not fit).
    #[new]
    #[pyo3(signature = (world, *, gamma, alpha, seed, ties))]
    fn new(py: Python<'_>, world: &PyTargetTracking, gamma: f64, alpha: f64, seed: u64, ties: &str) -> PyResult<Self> {
        let world = world.world.clone();
        let ties = Ties::parse(ties).map_err(raise)?;
        let learner = py.detach(|| QLearner::new(world, QConfig { gamma, alpha, seed, ties })).map_err(raise)?;
        Ok(PyQLearner { learner })
    }

    /// Reads a run saved by `save` (or a `ceworld qlearn` checkpoint).
    #[staticmethod]
    fn load(py: Python<'_>, path: PathBuf) -> PyResult<Self> {
        let learner = py.detach(|| ceworld::qlearn::load_tracking(path)).map_err(raise)?;
        Ok(PyQLearner { learner })
    }

    /// Writes the run (header and table), atomically.
    fn save(&self, py: Python<'_>, path: PathBuf) -> PyResult<()> {
        let learner = &self.learner;
        py.detach(|| learner.save(path)).map_err(raise)
    }

    /// Runs until `until` updates in all; Ctrl-C stops between chunks of updates (after saving
    /// the checkpoint, when there is one) and the outcome says `interrupted`.
    #[pyo3(signature = (until, *, progress, checkpoint = None, checkpoint_every = None))]
    fn train<'py>(
        &mut self,
        py: Python<'py>,
        until: u64,
        progress: bool,
        checkpoint: Option<PathBuf>,
        checkpoint_every: Option<f64>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let learner = &mut self.learner;
        let outcome = py
            .detach(|| {
                let mut line = progress.then(LiveLine::stderr);
                let outcome = learner.train(until, checkpoint.as_deref(), checkpoint_every, |p| {
                    if let Some(line) = &mut line {
                        line.update(p.line());
                    }
                    // A pending KeyboardInterrupt is consumed here: the caller gets the run so far.
                    match Python::attach(|py| py.check_signals()) {
                        Ok(()) => Flow::Continue,
                        Err(_) => Flow::Stop,
                    }
                });
                if let Some(line) = line {
                    line.finish();
                }
                outcome
            })
            .map_err(raise)?;
        let d = PyDict::new(py);
        d.set_item("updates", outcome.updates)?;
        d.set_item("seconds", outcome.seconds)?;
        d.set_item("interrupted", outcome.interrupted)?;
        d.set_item("checkpoints", outcome.checkpoints)?;
        Ok(d)
    }

    /// The greedy policy evaluated on windows: `{"from_start": ..., "continuing": ...}`; ties
    /// broken as in learning unless `ties` says otherwise.
    #[pyo3(signature = (world, *, window, episodes, chains, burn_in, windows_per_chain, seed, threads = None, ties = None))]
    #[allow(clippy::too_many_arguments)]
    fn evaluate_windows<'py>(
        &self,
        py: Python<'py>,
        world: &PyTargetTracking,
        window: usize,
        episodes: usize,
        chains: usize,
        burn_in: u64,
        windows_per_chain: usize,
        seed: u64,
        threads: Option<usize>,
        ties: Option<&str>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let config = window_config(window, episodes, chains, burn_in, windows_per_chain);
        let ties = match ties {
            Some(t) => Ties::parse(t).map_err(raise)?,
            None => self.learner.config().ties,
        };
        let (world, greedy) = (&world.world, Greedy { table: self.learner.table(), ties });
        let report = py
            .detach(|| thread_pool(threads)?.install(|| evaluate_windows(world, &greedy, &config, seed)))
            .map_err(raise)?;
        window_report_dict(py, &report)
    }

    /// Updates run so far.
    #[getter]
    fn updates(&self) -> u64 {
        self.learner.updates()
    }

    /// Number of known states (rows of the table).
    #[getter]
    fn n_states(&self) -> usize {
        self.learner.table().n_states()
    }

    /// Number of actions (columns of the table).
    #[getter]
    fn n_actions(&self) -> usize {
        self.learner.table().n_actions()
    }

    /// Size of the table in bytes.
    #[getter]
    fn table_bytes(&self) -> u64 {
        self.learner.table().bytes()
    }

    /// Discount `γ`.
    #[getter]
    fn gamma(&self) -> f64 {
        self.learner.config().gamma
    }

    /// Learning rate `α`.
    #[getter]
    fn alpha(&self) -> f64 {
        self.learner.config().alpha
    }

    /// Seed of the run's random stream.
    #[getter]
    fn seed(&self) -> u64 {
        self.learner.config().seed
    }

    /// How greedy ties are broken: `"random"` or `"lowest"`.
    #[getter]
    fn ties(&self) -> &'static str {
        self.learner.config().ties.as_str()
    }

    /// Sum of the rewards of every update so far.
    #[getter]
    fn reward_total(&self) -> f64 {
        self.learner.reward_total()
    }

    /// Seconds spent learning, over every session.
    #[getter]
    fn seconds(&self) -> f64 {
        self.learner.seconds()
    }

    /// The header of the run's file (settings, counters, random stream, world state) as a dict.
    fn header<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_python(py, &self.learner.header())
    }

    /// The world's parameters (with its name), as stored in policy files.
    fn world<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_python(py, &self.learner.world().to_json())
    }

    /// A copy of the table, float32, shape `(n_states, n_actions)`.
    fn table<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f32>> {
        let t = self.learner.table();
        let values = py.detach(|| t.values().to_vec());
        Array2::from_shape_vec((t.n_states(), t.n_actions()), values).expect("the table's shape").into_pyarray(py)
    }

    /// `Q(s, ·)`, float32, shape `(n_actions,)`.
    fn row<'py>(&self, py: Python<'py>, state: usize) -> PyResult<Bound<'py, PyArray1<f32>>> {
        let t = self.learner.table();
        if state >= t.n_states() {
            return Err(raise(Error::invalid("state", format!("{state} (expected < {})", t.n_states()))));
        }
        Ok(PyArray1::from_slice(py, t.row(state)))
    }

    /// The known state of a world state (`b_i, b_j, b_heading, c_i, c_j, c_heading, target_i,
    /// target_j`) seen through observation `y`: `(y·P + B)·P + C`.
    fn state_index(&self, state: Vec<i64>, y: usize) -> PyResult<usize> {
        let world = self.learner.world();
        if y >= world.n_observations() {
            return Err(raise(Error::invalid("y", format!("{y} (expected < {})", world.n_observations()))));
        }
        let state = world.restore(&state).map_err(|e| raise(Error::invalid("state", e.to_string())))?;
        Ok(world.known_state(&state, y))
    }
}

/// `cehmm._core`: the compiled engine; use the `cehmm` package instead.
#[pymodule(gil_used = false)]
fn _core(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    // Import numpy's C API now: done lazily, the first array made after a Ctrl-C would find
    // the import interrupted and panic.
    let _ = PyArray1::<f64>::from_vec(py, Vec::new());
    m.add("CehmmError", py.get_type::<CehmmError>())?;
    m.add("InvalidArgumentError", py.get_type::<InvalidArgumentError>())?;
    m.add("PolicyFormatError", py.get_type::<PolicyFormatError>())?;
    m.add("PolicyMismatchError", py.get_type::<PolicyMismatchError>())?;
    m.add_class::<PyTargetTracking>()?;
    m.add_class::<PyPolicy>()?;
    m.add_function(wrap_pyfunction!(optimize, m)?)?;
    m.add_class::<PyQLearner>()?;
    m.add_function(wrap_pyfunction!(evaluate_policy_windows, m)?)?;
    m.add("ENGINE_VERSION", ceworld::VERSION)?;
    defaults::add(m)?;
    Ok(())
}
