//! Episodes sampled elsewhere (model §9): `cehmm._core.RemoteWorld`, a world whose episodes a
//! backend written in Python (`cehmm.ray_backend`) samples on other processes or machines (the
//! worker's side is `shards`). The driver's
//! optimisers run unchanged on a [`Remote`]: only tables, controllers, episode numbers,
//! rewards, values and counts cross.
//!
//! The backend is typed on both sides: here [`METHODS`] (exported as `_core.BACKEND_METHODS`),
//! in Python the protocol `cehmm.backend.Sampler`, checked against each other by
//! `tests/test_backend.py`. It has `rewards(policy, seed, purpose, iteration, first, n)`,
//! `counts(policy, seed, iteration, episodes)`,
//! `controller_values(controllers, seed, purpose, iteration, episodes)`,
//! `controller_credit(controllers, seed, purpose, iteration, episodes)` (the values with each
//! controller's credit within its episodes, model §8), `controller_steps(controllers, seed,
//! purpose, iteration, episodes)` (the values with every step of each episode, model §10) and
//! `exact_values(controllers, tolerance)` (a policy and the controllers as JSON text), each
//! returning at once a pending answer ([`PENDING`]: `wait(seconds) -> bool`,
//! `result() -> numpy array` and `cancel()`), waited for by `ceworld::episodes::wait_for`, so
//! that Ctrl-C cancels what is still running. On the engine's side the same six are the [`Episodes`]
//! methods `run`, `run_controllers` and `run_controllers_credited` and the trait
//! [`ceworld::episodes::Remote`].

use std::sync::Mutex;

use numpy::{PyArray1, PyReadonlyArray1};
use pyo3::prelude::*;
use pyo3::types::PyTuple;
use serde_json::{Value, json};

use ceworld::episodes::credit::StepCredit;
use ceworld::episodes::{Batch, Episodes, Pending, Shape, Streams, wait_for};
use ceworld::policy::controller::Controller;
use ceworld::rng::Purpose;
use ceworld::{Error, Hhmm, Interrupt, PolicyFile, PomdpWorld};

/// What the engine asks of a backend, by name: rewards, counts, controller values (alone, with
/// credit, with steps), exact values.
pub const METHODS: [&str; 6] = [REWARDS, COUNTS, CONTROLLER_VALUES, CONTROLLER_CREDIT, CONTROLLER_STEPS, EXACT_VALUES];
const REWARDS: &str = "rewards";
const COUNTS: &str = "counts";
const CONTROLLER_VALUES: &str = "controller_values";
const CONTROLLER_CREDIT: &str = "controller_credit";
const CONTROLLER_STEPS: &str = "controller_steps";
const EXACT_VALUES: &str = "exact_values";
/// What a backend's pending answer has: wait, result, cancel.
pub const PENDING: [&str; 3] = [WAIT_FOR, RESULT, CANCEL];
const WAIT_FOR: &str = "wait";
const RESULT: &str = "result";
const CANCEL: &str = "cancel";

/// A world sampled by `backend`: its shape and description, taken from the world itself.
#[pyclass(module = "cehmm._core", name = "RemoteWorld", frozen)]
pub struct PyRemoteWorld {
    backend: Py<PyAny>,
    shape: Shape,
    description: Value,
    /// The world, where it is tabular (a `.pomdp` file): its controllers have exact values and a
    /// model start.
    model: Option<PomdpWorld>,
    /// Whether the world's value is the sum of its steps' rewards (`Episodes::additive`).
    additive: bool,
}

#[pymethods]
impl PyRemoteWorld {
    /// `world` (an engine world or a world written in Python) sampled by `backend`.
    #[new]
    fn new(backend: Py<PyAny>, world: &Bound<'_, PyAny>) -> PyResult<Self> {
        let (shape, description, model, additive) = if let Ok(w) = world.extract::<PyRef<'_, crate::world::PyWorld>>() {
            let (shape, description, additive) =
                ceworld::with_world!(&w.world, x => (x.shape(), x.description(), x.additive()));
            (shape, description, w.world.tabular().cloned(), additive)
        } else if let Ok(w) = world.extract::<PyRef<'_, crate::outside::PyOutsideWorld>>() {
            let (shape, description) = w.described();
            (shape, description, None, w.additive())
        } else {
            return Err(pyo3::exceptions::PyTypeError::new_err(format!(
                "invalid world: {} (expected a cehmm world or a world written in Python)",
                crate::convert::shown(world)
            )));
        };
        Ok(PyRemoteWorld { backend, shape, description, model, additive })
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
            model: self.model.clone(),
            additive: self.additive,
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
    model: Option<PomdpWorld>,
    additive: bool,
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
        let reported = crate::errors::raised(py, &error);
        self.raised.lock().unwrap_or_else(std::sync::PoisonError::into_inner).get_or_insert(error);
        reported
    }

    /// The backend's answer to `method(args)`: `len` numbers, waited for by [`wait_for`] (a stop
    /// asked meanwhile cancels it).
    fn ask<T: numpy::Element + Copy>(
        &self,
        method: &str,
        args: impl FnOnce(Python<'_>) -> PyResult<Py<PyTuple>>,
        len: Option<usize>,
    ) -> ceworld::Result<Vec<T>> {
        self.interrupt.check()?;
        let pending = Python::attach(|py| {
            let args = args(py).map_err(|e| self.keep(py, e))?;
            self.backend.bind(py).call_method1(method, args.bind(py)).map(Bound::unbind).map_err(|e| self.keep(py, e))
        })?;
        let pending = Waiting { pending, remote: self };
        wait_for(&pending, &self.interrupt)?;
        let pending = pending.pending;
        Python::attach(|py| {
            let answer = pending.bind(py).call_method0(RESULT).map_err(|e| self.keep(py, e))?;
            let array: PyReadonlyArray1<'_, T> = answer.extract().map_err(|e| self.keep(py, e))?;
            let values = array.as_slice().map_err(|e| self.keep(py, e.into()))?;
            if let Some(len) = len.filter(|&len| values.len() != len) {
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
        PolicyFile { policy: policy.clone(), world: self.description.clone(), provenance: json!({}) }.to_text()
    }
}

/// A backend's pending answer, its exceptions kept by `remote`.
struct Waiting<'a> {
    pending: Py<PyAny>,
    remote: &'a Remote,
}

impl Pending for Waiting<'_> {
    fn wait(&self, seconds: f64) -> ceworld::Result<bool> {
        Python::attach(|py| {
            let done = self.pending.bind(py).call_method1(WAIT_FOR, (seconds,)).map_err(|e| self.remote.keep(py, e))?;
            done.extract::<bool>().map_err(|e| self.remote.keep(py, e))
        })
    }

    fn cancel(&self) -> ceworld::Result<()> {
        Python::attach(|py| self.pending.bind(py).call_method0(CANCEL).map(drop).map_err(|e| self.remote.keep(py, e)))
    }
}

/// A backend's answer of episodes, then the world's steps they took (a whole number, as a
/// float): the two apart.
fn with_steps<'a>(answer: &'a [f64], method: &str) -> ceworld::Result<(&'a [f64], u64)> {
    let (&steps, values) =
        answer.split_last().ok_or_else(|| Error::World(format!("the backend's {method} gave no number")))?;
    if !(steps >= 0.0 && steps.fract() == 0.0 && steps < 2f64.powi(53)) {
        return Err(Error::World(format!(
            "the backend's {method} ended with {steps} steps (expected the world's steps: a whole number >= 0)"
        )));
    }
    Ok((values, steps as u64))
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

    fn run(&self, policy: &Hhmm, streams: Streams, first: usize, batch: Batch<'_>) -> ceworld::Result<u64> {
        if batch.records.is_some() {
            return Err(Error::invalid("records", "asked of episodes sampled elsewhere (they stay where they ran)"));
        }
        let (text, purpose, n) = (self.policy_json(policy), purpose_name(streams.purpose)?, batch.values.len());
        let answer = self.ask::<f64>(
            REWARDS,
            |py| Ok((text, streams.seed, purpose, streams.iteration, first, n).into_pyobject(py)?.unbind()),
            Some(n + 1),
        )?;
        let (rewards, steps) = with_steps(&answer, REWARDS)?;
        batch.values.copy_from_slice(rewards);
        Ok(steps)
    }

    fn run_controllers(
        &self,
        controllers: &[Controller],
        streams: Streams,
        episodes: usize,
        values: &mut [f64],
    ) -> ceworld::Result<u64> {
        let text = serde_json::to_string(controllers).expect("controllers serialise");
        let purpose = purpose_name(streams.purpose)?;
        let answer = self.ask::<f64>(
            CONTROLLER_VALUES,
            |py| Ok((text, streams.seed, purpose, streams.iteration, episodes).into_pyobject(py)?.unbind()),
            Some(values.len() + 1),
        )?;
        let (answer, steps) = with_steps(&answer, CONTROLLER_VALUES)?;
        values.copy_from_slice(answer);
        Ok(steps)
    }

    fn run_controllers_credited(
        &self,
        controllers: &[Controller],
        streams: Streams,
        episodes: usize,
        values: &mut [f64],
        credit: &mut StepCredit,
    ) -> ceworld::Result<(u64, bool)> {
        let text = serde_json::to_string(controllers).expect("controllers serialise");
        let purpose = purpose_name(streams.purpose)?;
        if credit.traces.is_some() {
            // Every step comes back (model §10), as many as the episodes took.
            let args = |py: Python<'_>| {
                Ok((text, streams.seed, purpose, streams.iteration, episodes).into_pyobject(py)?.unbind())
            };
            let answer = self.ask::<f64>(CONTROLLER_STEPS, args, None)?;
            let (answer, steps) = with_steps(&answer, CONTROLLER_STEPS)?;
            let credited = credit.add_steps(answer, controllers, self.shape.observations, values, episodes)?;
            return Ok((steps, credited));
        }
        let answer = self.ask::<f64>(
            CONTROLLER_CREDIT,
            |py| Ok((text, streams.seed, purpose, streams.iteration, episodes).into_pyobject(py)?.unbind()),
            Some(controllers.len() * StepCredit::block(episodes, credit.rows) + 1),
        )?;
        let (answer, steps) = with_steps(&answer, CONTROLLER_CREDIT)?;
        Ok((steps, credit.add_blocks(answer, values, episodes)))
    }

    fn interrupt(&self) -> Option<&Interrupt> {
        Some(&self.interrupt)
    }

    fn additive(&self) -> bool {
        self.additive
    }

    fn remote(&self) -> Option<&dyn ceworld::episodes::Remote> {
        Some(self)
    }
}

impl ceworld::episodes::Remote for Remote {
    fn model(&self) -> Option<&PomdpWorld> {
        self.model.as_ref()
    }

    fn counts(&self, policy: &Hhmm, streams: Streams, episodes: &[usize]) -> ceworld::Result<Vec<u32>> {
        let text = self.policy_json(policy);
        let episodes: Vec<u64> = episodes.iter().map(|&k| k as u64).collect();
        let args = move |py: Python<'_>| {
            let episodes = PyArray1::from_vec(py, episodes);
            Ok((text, streams.seed, streams.iteration, episodes).into_pyobject(py)?.unbind())
        };
        self.ask::<u32>(COUNTS, args, Some(policy.layout().len))
    }

    fn exact_values(&self, controllers: &[Controller], tolerance: f64) -> ceworld::Result<Vec<f64>> {
        let text = serde_json::to_string(controllers).expect("controllers serialise");
        let args = |py: Python<'_>| Ok((text, tolerance).into_pyobject(py)?.unbind());
        self.ask::<f64>(EXACT_VALUES, args, Some(controllers.len()))
    }
}
