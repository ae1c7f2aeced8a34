//! `cehmm._core.OutsideWorld`: a world written in Python (the episode or the batched protocol,
//! `cehmm.outside` puts every other form into one of them), translated into
//! `ceworld::episodes::outside::BatchWorld`.

use numpy::{PyArray1, PyArrayMethods};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyTuple};
use serde_json::Value;

use ceworld::Error;
use ceworld::episodes::Shape;
use ceworld::episodes::outside::{BatchWorld, Lockstep, Recorded, StepOut, discounted};

use crate::convert::{count, object, real};
use crate::errors::{raise, raised};
use crate::signals::Signals;

/// A world written in Python, checked once: its shape, protocol, batch size and score.
#[pyclass(module = "cehmm._core", name = "OutsideWorld", frozen)]
pub struct PyOutsideWorld {
    world: Py<PyAny>,
    shape: Shape,
    batched: bool,
    batch: usize,
    description: Value,
    discount: f64,
    score: Option<Py<PyAny>>,
}

#[pymethods]
impl PyOutsideWorld {
    /// `world` has `reset(seed) -> observation` and `step(decision) -> (observation, reward,
    /// done)` (`batched=False`), or `reset(n, seed) -> observations[n]` and
    /// `step(decisions[n]) -> (observations[n], rewards[n], done[n])` (`batched=True`, at most
    /// `batch` episodes at once). `description` is a dict of str keys recorded in policy files;
    /// `score(observations, decisions, rewards) -> float`, if given, is an episode's value, else
    /// the sum of its rewards discounted by `discount`.
    #[new]
    #[pyo3(signature = (world, *, observations, decisions, horizon, batched, batch, description, discount, score))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        world: Py<PyAny>,
        observations: &Bound<'_, PyAny>,
        decisions: &Bound<'_, PyAny>,
        horizon: &Bound<'_, PyAny>,
        batched: bool,
        batch: &Bound<'_, PyAny>,
        description: &Bound<'_, PyAny>,
        discount: &Bound<'_, PyAny>,
        score: Option<Py<PyAny>>,
    ) -> PyResult<Self> {
        let shape = Shape {
            observations: count("n_observations", observations)?,
            decisions: count("n_decisions", decisions)?,
            horizon: count("horizon", horizon)?,
        };
        let batch = if batched { count("batch", batch)? } else { 1 };
        let (discount, description) = (real("discount", discount)?, object("description", Some(description))?);
        let description = ceworld::episodes::outside::describe(description, shape);
        let world = PyOutsideWorld { world, shape, batched, batch, description, discount, score };
        // The checks of the engine (sizes, batch, discount), now rather than at the first run.
        Lockstep::new(world.batch_world()).map_err(raise)?;
        Ok(world)
    }

    /// What policy files record of the world.
    #[getter]
    fn description<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        crate::convert::to_py(py, &self.description)
    }

    /// Episodes stepped at once (1 for the episode protocol).
    #[getter]
    fn batch(&self) -> usize {
        self.batch
    }
}

impl PyOutsideWorld {
    /// Its shape and what policy files record of it.
    pub fn described(&self) -> (Shape, Value) {
        (self.shape, self.description.clone())
    }

    /// Whether its value is the sum of its steps' rewards (no score of its own).
    pub fn additive(&self) -> bool {
        self.score.is_none()
    }

    fn batch_world(&self) -> PyBatch {
        let world = Python::attach(|py| PyOutsideWorld {
            world: self.world.clone_ref(py),
            shape: self.shape,
            batched: self.batched,
            batch: self.batch,
            description: self.description.clone(),
            discount: self.discount,
            score: self.score.as_ref().map(|s| s.clone_ref(py)),
        });
        PyBatch { world, raised: None }
    }
}

/// The world of one run, keeping the first exception its Python code raised.
pub struct PyBatch {
    world: PyOutsideWorld,
    raised: Option<PyErr>,
}

impl PyBatch {
    /// Keeps `error` (raised by the world's code) and reports it to the engine.
    fn keep(&mut self, py: Python<'_>, error: PyErr) -> Error {
        let reported = raised(py, &error);
        self.raised = Some(error);
        reported
    }

    /// `value` as `n` int64 numbers: ints (not bools, floats or strings), as one episode's
    /// observation must be.
    fn ints(py: Python<'_>, what: &str, value: &Bound<'_, PyAny>, out: &mut [i64]) -> Result<(), String> {
        let expected = || format!("{what} {} (expected ints)", short(value));
        if dtype_kind(py, value).as_deref() == Some("b") {
            return Err(expected());
        }
        let array = array(py, value, "int64", "safe").map_err(|_| expected())?;
        copy(what, &array, out)
    }
}

/// The kind of `numpy.asarray(value).dtype` (`"b"` bool, `"i"` int, `"c"` complex, ...).
fn dtype_kind(py: Python<'_>, value: &Bound<'_, PyAny>) -> Option<String> {
    let array = py.import("numpy").ok()?.call_method1("asarray", (value,)).ok()?;
    array.getattr("dtype").ok()?.getattr("kind").ok()?.extract().ok()
}

/// A real number (Python's or numpy's, a bool as 0 or 1; not a complex, even of imaginary part
/// 0, nor a str), as one step's reward must be.
fn scalar_real(value: &Bound<'_, PyAny>) -> Option<f64> {
    let type_name = value.get_type().name().map(|n| n.to_string()).unwrap_or_default();
    if value.is_instance_of::<pyo3::types::PyComplex>()
        || type_name.starts_with("complex")
        || type_name == "clongdouble"
    {
        return None;
    }
    value.extract::<f64>().ok()
}

/// An int (Python's or numpy's; not a bool, a float or a str).
fn scalar_int(value: &Bound<'_, PyAny>) -> Option<i64> {
    if value.is_instance_of::<pyo3::types::PyBool>() || value.is_instance_of::<pyo3::types::PyFloat>() {
        return None;
    }
    value.extract::<i64>().ok()
}

/// A flag (`done`, `terminated`, `truncated`): a bool, numpy's too, or the int 0 or 1; not a
/// string, a float or any other object whose truthiness would be taken.
fn scalar_flag(value: &Bound<'_, PyAny>) -> Option<bool> {
    if value.is_instance_of::<pyo3::types::PyBool>() {
        return value.extract::<bool>().ok();
    }
    let type_name = value.get_type().name().map(|n| n.to_string()).unwrap_or_default();
    if type_name == "bool" || type_name == "bool_" {
        return value.extract::<bool>().ok();
    }
    match scalar_int(value) {
        Some(0) => Some(false),
        Some(1) => Some(true),
        _ => None,
    }
}

/// Flags of a batch into `out`: an array of bools, or of the ints 0 and 1.
fn batch_flags(py: Python<'_>, what: &str, value: &Bound<'_, PyAny>, out: &mut [bool]) -> Result<(), String> {
    let expected = || format!("{what} {} (expected bools, or the ints 0 and 1)", short(value));
    if let Ok(a) = array(py, value, "bool", "safe") {
        return copy(what, &a, out);
    }
    let ints = array(py, value, "int64", "same_kind").map_err(|_| expected())?;
    let mut values = vec![0i64; out.len()];
    copy(what, &ints, &mut values)?;
    if values.iter().any(|&v| v != 0 && v != 1) {
        return Err(expected());
    }
    out.iter_mut().zip(values).for_each(|(o, v)| *o = v == 1);
    Ok(())
}

fn short(value: &Bound<'_, PyAny>) -> String {
    let text = crate::convert::shown(value);
    if text.chars().count() > 60 { format!("{}…", text.chars().take(60).collect::<String>()) } else { text }
}

/// `numpy.asarray(value).astype(dtype, casting=casting)`, one-dimensional.
fn array<'py>(py: Python<'py>, value: &Bound<'py, PyAny>, dtype: &str, casting: &str) -> PyResult<Bound<'py, PyAny>> {
    let numpy = py.import("numpy")?;
    let array = numpy.call_method1("atleast_1d", (value,))?;
    let kwargs = PyDict::new(py);
    kwargs.set_item("casting", casting)?;
    kwargs.set_item("copy", false)?;
    array.call_method("astype", (dtype,), Some(&kwargs))
}

fn copy<T: numpy::Element + Copy>(what: &str, array: &Bound<'_, PyAny>, out: &mut [T]) -> Result<(), String> {
    let array = array
        .cast::<PyArray1<T>>()
        .map_err(|_| format!("{what} of shape {} (expected {} numbers)", shape_of(array), out.len()))?;
    let view = array.readonly();
    let values = view.as_array();
    if values.len() != out.len() {
        return Err(format!("{what}: {} values (expected {}, one per episode)", values.len(), out.len()));
    }
    // Whatever the strides (a column of a 2-D array is a valid batch).
    out.iter_mut().zip(values.iter()).for_each(|(o, v)| *o = *v);
    Ok(())
}

fn shape_of(array: &Bound<'_, PyAny>) -> String {
    array.getattr("shape").map_or_else(|_| "?".into(), |s| crate::convert::shown(&s))
}

impl BatchWorld for PyBatch {
    fn shape(&self) -> Shape {
        self.world.shape
    }

    fn description(&self) -> Value {
        self.world.description.clone()
    }

    fn max_batch(&self) -> usize {
        self.world.batch
    }

    fn reset(&mut self, seed: u64, observations: &mut [i64]) -> ceworld::Result<()> {
        Python::attach(|py| {
            let world = self.world.world.bind(py);
            let result = if self.world.batched {
                world.call_method1("reset", (observations.len(), seed))
            } else {
                world.call_method1("reset", (seed,))
            };
            let value = match result {
                Ok(v) => v,
                Err(e) => return Err(self.keep(py, e)),
            };
            // Gymnasium's reset returns (observation, info).
            let value = match value.cast::<PyTuple>() {
                Ok(t) if t.len() == 2 => t.get_item(0).map_err(|e| self.keep(py, e))?,
                _ => value,
            };
            if !self.world.batched {
                observations[0] = scalar_int(&value).ok_or_else(|| {
                    Error::World(format!("reset returned observation {} (expected an int)", short(&value)))
                })?;
                return Ok(());
            }
            PyBatch::ints(py, "reset returned observations", &value, observations).map_err(Error::World)
        })
    }

    fn step(&mut self, decisions: &[i64], out: StepOut<'_>) -> ceworld::Result<()> {
        Python::attach(|py| {
            let world = self.world.world.bind(py);
            let result = if self.world.batched {
                world.call_method1("step", (PyArray1::from_slice(py, decisions),))
            } else {
                world.call_method1("step", (decisions[0],))
            };
            let value = result.map_err(|e| self.keep(py, e))?;
            let parts = value.cast::<PyTuple>().ok().filter(|t| t.len() == 3 || t.len() == 5).ok_or_else(|| {
                Error::World(format!(
                    "step returned {} (expected (observation, reward, done) or Gymnasium's five-tuple)",
                    short(&value)
                ))
            })?;
            let item = |k: usize| parts.get_item(k).map_err(|e| Error::World(e.to_string()));
            let (obs, reward, terminated) = (item(0)?, item(1)?, item(2)?);
            let truncated = if parts.len() == 5 { Some(item(3)?) } else { None };
            if !self.world.batched {
                // One episode: Python scalars (or numpy ones), read directly.
                let bad = |what: &str, v: &Bound<'_, PyAny>, expected: &str| {
                    Error::World(format!("step returned {what} {} (expected {expected})", short(v)))
                };
                out.observations[0] = scalar_int(&obs).ok_or_else(|| bad("observation", &obs, "an int"))?;
                out.rewards[0] = scalar_real(&reward).ok_or_else(|| bad("reward", &reward, "a real number"))?;
                let flag = |v: &Bound<'_, PyAny>| scalar_flag(v).ok_or_else(|| bad("done", v, "a bool"));
                out.done[0] = flag(&terminated)? || truncated.as_ref().map(flag).transpose()?.unwrap_or(false);
                return Ok(());
            }
            PyBatch::ints(py, "step returned observation", &obs, out.observations).map_err(Error::World)?;
            let rewards = array(py, &reward, "float64", "same_kind").map_err(|_| {
                Error::World(format!("step returned reward {} (expected real numbers)", short(&reward)))
            })?;
            copy("step returned rewards", &rewards, out.rewards).map_err(Error::World)?;
            let flags = |v: &Bound<'_, PyAny>, out: &mut [bool]| -> ceworld::Result<()> {
                batch_flags(py, "step returned done", v, out).map_err(Error::World)
            };
            flags(&terminated, out.done)?;
            if let Some(truncated) = truncated {
                let mut cut = vec![false; out.done.len()];
                flags(&truncated, &mut cut)?;
                out.done.iter_mut().zip(cut).for_each(|(d, c)| *d |= c);
            }
            Ok(())
        })
    }

    fn on_thread<R: Send>(f: impl FnOnce() -> R + Send) -> R {
        // A thread state made once for the whole batch, the interpreter released meanwhile:
        // each call of the world's code then only takes the GIL (≈ 0.1 µs, not ≈ 8 µs).
        Python::attach(|py| py.detach(f))
    }

    fn discount(&self) -> f64 {
        self.world.discount
    }

    fn additive(&self) -> bool {
        self.world.score.is_none()
    }

    fn score(&mut self, episode: &Recorded<'_>) -> ceworld::Result<f64> {
        if self.world.score.is_none() {
            return Ok(discounted(episode.rewards, self.world.discount));
        }
        Python::attach(|py| {
            let score = self.world.score.as_ref().map(|s| s.clone_ref(py)).expect("checked above");
            let column = |values: Vec<i64>| PyArray1::from_vec(py, values);
            let args = (
                column(episode.observations().map(|y| y as i64).collect()),
                column(episode.decisions().map(|d| d as i64).collect()),
                PyArray1::from_slice(py, episode.rewards),
            );
            let value = score.bind(py).call1(args).map_err(|e| self.keep(py, e))?;
            value
                .extract::<f64>()
                .map_err(|_| Error::World(format!("score returned {} (expected a number)", short(&value))))
        })
    }
}

/// Runs `f` detached from the interpreter, or on the engine's thread while `signals` are
/// watched; a panic in it caught.
pub fn detached_or_watched<T: Send>(
    py: Python<'_>,
    signals: Option<&mut Signals>,
    f: impl FnOnce() -> ceworld::Result<T> + Send,
) -> PyResult<ceworld::Result<T>> {
    match signals {
        None => Ok(py.detach(|| ceworld::catch_panics(f))),
        Some(signals) => signals.watch(py, || ceworld::catch_panics(f)),
    }
}

/// `result`, or the exception the world's code raised (with its traceback) where that is what
/// failed, a note naming where it happened.
pub fn surface<T>(py: Python<'_>, result: ceworld::Result<T>, raised: Option<PyErr>) -> PyResult<T> {
    match (result, raised) {
        (Err(error), Some(exception)) => {
            let _ = exception.value(py).call_method1("add_note", (error.to_string(),));
            Err(exception)
        }
        (result, _) => result.map_err(raise),
    }
}

/// Runs `f` on a world written in Python (see [`WorldArg::run`] and [`WorldArg::run_watched`]).
pub fn run_outside<T: Send>(
    py: Python<'_>,
    world: &PyOutsideWorld,
    signals: Option<&mut Signals>,
    f: impl FnOnce(&Lockstep<PyBatch>) -> ceworld::Result<T> + Send,
) -> PyResult<T> {
    let mut lockstep = Lockstep::new(world.batch_world()).map_err(raise)?;
    if let Some(signals) = &signals {
        lockstep = lockstep.interruptible(signals.interrupt().clone());
    }
    let result = detached_or_watched(py, signals, || f(&lockstep))?;
    surface(py, result, lockstep.into_inner().raised)
}
