//! `cehmm._core.Agent` and `cehmm._core.Session`: a policy and a world run one step at a time
//! from Python (Gymnasium loops, `cehmm.gym`), translating `ceworld::policy::agent::Agent` and
//! `ceworld::world::session::Session`.

use pyo3::prelude::*;

use ceworld::policy::agent::Agent;
use ceworld::world::session::Session;

use crate::convert::{count, seed};
use crate::errors::OrRaise;
use crate::policy::PyPolicy;
use crate::world::PyWorld;

/// A policy acting in an outside loop: `reset()`, then `act(observation) -> decision`.
#[pyclass(module = "cehmm._core", name = "Agent")]
pub struct PyAgent(Agent);

#[pymethods]
impl PyAgent {
    #[new]
    fn new(policy: &PyPolicy, seed: &Bound<'_, PyAny>) -> PyResult<Self> {
        Ok(PyAgent(Agent::new(policy.file.policy.clone(), self::seed("seed", seed)?)))
    }

    /// Starts a new episode (the next observation is the first).
    fn reset(&mut self) {
        self.0.reset();
    }

    /// The decision for `observation`, moving the memory on.
    fn act(&mut self, observation: &Bound<'_, PyAny>) -> PyResult<usize> {
        self.0.act(count("observation", observation)?).or_raise()
    }

    /// The memory after the last decision, bottom level first.
    #[getter]
    fn memory(&self) -> Vec<u16> {
        self.0.memory().to_vec()
    }
}

/// An episode of a world stepped from outside.
#[pyclass(module = "cehmm._core", name = "Session")]
pub struct PySession(Session);

#[pymethods]
impl PySession {
    #[new]
    fn new(world: &PyWorld, seed: &Bound<'_, PyAny>, episode: &Bound<'_, PyAny>) -> PyResult<Self> {
        Ok(PySession(Session::start(&world.world, self::seed("seed", seed)?, self::seed("episode", episode)?)))
    }

    /// The current observation.
    #[getter]
    fn observation(&self) -> usize {
        self.0.observation()
    }

    /// The step the next decision is for (horizon + 1 once over).
    #[getter]
    fn t(&self) -> usize {
        self.0.t()
    }

    /// The episode's reward so far.
    #[getter]
    fn reward(&self) -> f64 {
        self.0.reward()
    }

    /// Takes `decision`: `(observation, reward gained, over)`.
    fn step(&mut self, decision: &Bound<'_, PyAny>) -> PyResult<(usize, f64, bool)> {
        self.0.step(count("decision", decision)?).or_raise()
    }

    /// The state as numbers (the world's state labels).
    fn describe(&self) -> Vec<i64> {
        self.0.describe()
    }
}
