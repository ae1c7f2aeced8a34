//! Episodes sampled elsewhere (model §9): `cehmm._core.RemoteWorld`, a world whose episodes a
//! backend written in Python (`cehmm.ray_backend`) samples on other processes or machines, and
//! the worker's side of it, `controller_values` and `controller_exact_values`. The driver's
//! optimisers run unchanged on a [`Remote`]: only tables, controllers, episode numbers,
//! rewards, values and counts cross.
//!
//! The backend has `rewards(policy, seed, purpose, iteration, first, n)`,
//! `counts(policy, seed, iteration, episodes)`,
//! `controller_values(controllers, seed, purpose, iteration, episodes)` and
//! `exact_values(controllers, tolerance)` (a policy and the controllers as JSON text), each
//! returning at once a pending answer with `wait(seconds) -> bool`, `result() -> numpy array`
//! and `cancel()`: the engine waits in short slices, so that Ctrl-C cancels what is still
//! running.

use std::sync::Mutex;

use numpy::{PyArray1, PyReadonlyArray1};
use pyo3::prelude::*;
use pyo3::types::PyTuple;
use serde_json::{Value, json};

use ceworld::ce::controller::ControllerValue;
use ceworld::episodes::{Batch, Episodes, Shape, Streams};
use ceworld::policy::controller::Controller;
use ceworld::rng::Purpose;
use ceworld::{Error, Hhmm, Interrupt, PolicyFile};

use crate::convert::{count, seed};
use crate::errors::{OrRaise, raise};
use crate::outside::WorldArg;

/// How long the engine waits for a pending answer before it looks for Ctrl-C again (seconds).
const WAIT: f64 = 0.05;

/// A world sampled by `backend`: its shape and description, taken from the world itself.
#[pyclass(module = "cehmm._core", name = "RemoteWorld", frozen)]
pub struct PyRemoteWorld {
    backend: Py<PyAny>,
    shape: Shape,
    description: Value,
    /// Whether the world is tabular (a `.pomdp` file): its controllers have exact values.
    pub tabular: bool,
}

#[pymethods]
impl PyRemoteWorld {
    /// `world` (an engine world or a world written in Python) sampled by `backend`.
    #[new]
    fn new(py: Python<'_>, backend: Py<PyAny>, world: &Bound<'_, PyAny>) -> PyResult<Self> {
        let world = WorldArg::of(world)?;
        let tabular = world.tabular().is_some();
        let (shape, description) = world.run(py, |w| Ok((w.shape(), w.description())))?;
        Ok(PyRemoteWorld { backend, shape, description, tabular })
    }

    /// The backend that samples the episodes.
    #[getter]
    fn backend(&self, py: Python<'_>) -> Py<PyAny> {
        self.backend.clone_ref(py)
    }

    /// What policy files record of the world.
    #[getter]
    fn description<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        crate::convert::to_py(py, &self.description)
    }
}

impl PyRemoteWorld {
    /// The episodes of one run, stopped by `interrupt`.
    pub fn episodes(&self, py: Python<'_>, interrupt: Interrupt) -> Remote {
        Remote {
            backend: self.backend.clone_ref(py),
            shape: self.shape,
            description: self.description.clone(),
            interrupt,
            raised: Mutex::new(None),
        }
    }
}

/// The episodes of one run on a backend, keeping the first exception the backend raised.
pub struct Remote {
    backend: Py<PyAny>,
    shape: Shape,
    description: Value,
    interrupt: Interrupt,
    raised: Mutex<Option<PyErr>>,
}

impl Remote {
    /// The first exception the backend raised (a world's on a worker among them), if any.
    pub fn into_raised(self) -> Option<PyErr> {
        self.raised.into_inner().unwrap_or_else(std::sync::PoisonError::into_inner)
    }

    /// Keeps `error` and reports it to the engine.
    fn keep(&self, py: Python<'_>, error: PyErr) -> Error {
        let reported = crate::outside::raised(py, &error);
        self.raised.lock().unwrap_or_else(std::sync::PoisonError::into_inner).get_or_insert(error);
        reported
    }

    /// The backend's answer to `method(args)`: `len` numbers, waited for in slices of [`WAIT`]
    /// seconds; a stop asked meanwhile cancels it.
    fn ask<T: numpy::Element + Copy>(
        &self,
        method: &str,
        args: impl FnOnce(Python<'_>) -> PyResult<Py<PyTuple>>,
        len: usize,
    ) -> ceworld::Result<Vec<T>> {
        self.interrupt.check()?;
        let pending = Python::attach(|py| {
            let args = args(py).map_err(|e| self.keep(py, e))?;
            self.backend.bind(py).call_method1(method, args.bind(py)).map(Bound::unbind).map_err(|e| self.keep(py, e))
        })?;
        loop {
            if let Err(stop) = self.interrupt.check() {
                Python::attach(|py| pending.bind(py).call_method0("cancel").map(drop).map_err(|e| self.keep(py, e)))?;
                return Err(stop);
            }
            let done = Python::attach(|py| {
                let done = pending.bind(py).call_method1("wait", (WAIT,)).map_err(|e| self.keep(py, e))?;
                done.extract::<bool>().map_err(|e| self.keep(py, e))
            })?;
            if done {
                break;
            }
        }
        Python::attach(|py| {
            let answer = pending.bind(py).call_method0("result").map_err(|e| self.keep(py, e))?;
            let array: PyReadonlyArray1<'_, T> = answer.extract().map_err(|e| self.keep(py, e))?;
            let values = array.as_slice().map_err(|e| self.keep(py, e.into()))?;
            if values.len() != len {
                return Err(Error::World(format!(
                    "the backend's {method} gave {} numbers (expected {len})",
                    values.len()
                )));
            }
            Ok(values.to_vec())
        })
    }

    /// `policy` as a policy document: what the workers read.
    fn policy_json(&self, policy: &Hhmm) -> String {
        PolicyFile { policy: policy.clone(), world: self.description.clone(), provenance: json!({}) }
            .to_json()
            .to_string()
    }
}

/// The name of `purpose` as the workers read it.
fn purpose_name(purpose: Purpose) -> ceworld::Result<&'static str> {
    purpose.episodes_name().ok_or_else(|| Error::invalid("purpose", format!("{purpose:?} (not run elsewhere)")))
}

impl Episodes for Remote {
    fn shape(&self) -> Shape {
        self.shape
    }

    fn description(&self) -> Value {
        self.description.clone()
    }

    fn run(&self, policy: &Hhmm, streams: Streams, first: usize, batch: Batch<'_>) -> ceworld::Result<()> {
        if batch.records.is_some() {
            return Err(Error::invalid("records", "asked of episodes sampled elsewhere (they stay where they ran)"));
        }
        let (text, purpose, n) = (self.policy_json(policy), purpose_name(streams.purpose)?, batch.values.len());
        let rewards = self.ask::<f64>(
            "rewards",
            |py| Ok((text, streams.seed, purpose, streams.iteration, first, n).into_pyobject(py)?.unbind()),
            n,
        )?;
        batch.values.copy_from_slice(&rewards);
        Ok(())
    }

    fn run_controllers(
        &self,
        controllers: &[Controller],
        streams: Streams,
        episodes: usize,
        values: &mut [f64],
    ) -> ceworld::Result<()> {
        let text = serde_json::to_string(controllers).expect("controllers serialise");
        let purpose = purpose_name(streams.purpose)?;
        let answer = self.ask::<f64>(
            "controller_values",
            |py| Ok((text, streams.seed, purpose, streams.iteration, episodes).into_pyobject(py)?.unbind()),
            values.len(),
        )?;
        values.copy_from_slice(&answer);
        Ok(())
    }

    fn interrupt(&self) -> Option<&Interrupt> {
        Some(&self.interrupt)
    }

    fn remote(&self) -> Option<&dyn ceworld::episodes::Remote> {
        Some(self)
    }
}

impl ceworld::episodes::Remote for Remote {
    fn counts(&self, policy: &Hhmm, streams: Streams, episodes: &[usize]) -> ceworld::Result<Vec<u32>> {
        let text = self.policy_json(policy);
        let episodes: Vec<u64> = episodes.iter().map(|&k| k as u64).collect();
        let args = move |py: Python<'_>| {
            let episodes = PyArray1::from_vec(py, episodes);
            Ok((text, streams.seed, streams.iteration, episodes).into_pyobject(py)?.unbind())
        };
        self.ask::<u32>("counts", args, policy.layout().len)
    }

    fn exact_values(&self, controllers: &[Controller], tolerance: f64) -> ceworld::Result<Vec<f64>> {
        let text = serde_json::to_string(controllers).expect("controllers serialise");
        let args = |py: Python<'_>| Ok((text, tolerance).into_pyobject(py)?.unbind());
        self.ask::<f64>("exact_values", args, controllers.len())
    }
}

/// `controllers` (JSON text: a list of `{"act": [...], "next": [...]}`), checked against
/// `shape`.
fn read_controllers(text: &str, shape: Shape) -> PyResult<Vec<Controller>> {
    let controllers: Vec<Controller> = serde_json::from_str(text)
        .map_err(|e| raise(Error::invalid("controllers", format!("{e} (expected a JSON list of controllers)"))))?;
    controllers.iter().try_for_each(|c| c.check(shape.observations, shape.decisions)).or_raise()?;
    Ok(controllers)
}

/// The values of episodes `0..episodes` of `(seed, purpose, iteration)` of each controller of
/// `controllers` (JSON text: a list of `{"act": [...], "next": [...]}`), controller by
/// controller: a shard of a controller search's iteration or selection, as a worker runs it.
#[pyfunction]
#[pyo3(signature = (world, controllers, seed, purpose, iteration, episodes, threads = None))]
#[allow(clippy::too_many_arguments)]
pub fn controller_values<'py>(
    py: Python<'py>,
    world: &Bound<'py, PyAny>,
    controllers: &str,
    seed: &Bound<'py, PyAny>,
    purpose: &str,
    iteration: &Bound<'py, PyAny>,
    episodes: &Bound<'py, PyAny>,
    threads: Option<&Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyArray1<f64>>> {
    let streams = Streams {
        seed: self::seed("seed", seed)?,
        purpose: Purpose::of_episodes(purpose).or_raise()?,
        iteration: self::seed("iteration", iteration)?,
    };
    let episodes = count("episodes", episodes)?;
    ceworld::evaluate::check_episodes(episodes).or_raise()?;
    let pool = ceworld::control::thread_pool(crate::convert::optional_count("threads", threads)?).or_raise()?;
    let world = WorldArg::of(world)?;
    let controllers = read_controllers(controllers, world.run(py, |w| Ok(w.shape()))?)?;
    let values = world.run(py, |w| {
        let mut values = vec![0.0; controllers.len() * episodes];
        pool.install(|| w.run_controllers(&controllers, streams, episodes, &mut values)).map(|()| values)
    })?;
    Ok(PyArray1::from_vec(py, values))
}

/// The exact values of `controllers` (JSON text, as for [`controller_values`]) on a tabular
/// world, to `tolerance` (model §8): a shard of an iteration of a search on exact values, as a
/// worker runs it.
#[pyfunction]
#[pyo3(signature = (world, controllers, tolerance, threads = None))]
pub fn controller_exact_values<'py>(
    py: Python<'py>,
    world: &Bound<'py, PyAny>,
    controllers: &str,
    tolerance: &Bound<'py, PyAny>,
    threads: Option<&Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyArray1<f64>>> {
    let tolerance = crate::convert::real("tolerance", tolerance)?;
    ceworld::ce::controller::ControllerConfig { tolerance, ..Default::default() }.validate().or_raise()?;
    let pool = ceworld::control::thread_pool(crate::convert::optional_count("threads", threads)?).or_raise()?;
    let world = WorldArg::of(world)?;
    let tabular = world
        .tabular()
        .ok_or_else(|| raise(Error::invalid("world", "not tabular (exact values need a cehmm.PomdpWorld)")))?;
    let controllers = read_controllers(controllers, ceworld::episodes::Episodes::shape(tabular))?;
    let exact = ControllerValue::new(tabular, tolerance);
    let values = py.detach(|| pool.install(|| exact.values(&controllers)));
    Ok(PyArray1::from_vec(py, values))
}
