//! `cehmm._core.World`: any registered world (`ceworld::AnyWorld`), built by name through the
//! core's registry; the Python world classes (`cehmm.TargetTracking`, ...) wrap it.

use pyo3::prelude::*;
use pyo3::types::PyDict;
use serde_json::{Map, Value};

use ceworld::world::registry;
use ceworld::{AnyWorld, World, with_world};

use crate::convert::{to_json, to_py};
use crate::errors::OrRaise;

/// A registered world with its parameters.
#[pyclass(module = "cehmm._core", name = "World", frozen, eq)]
#[derive(PartialEq)]
pub struct PyWorld {
    pub world: AnyWorld,
}

#[pymethods]
impl PyWorld {
    /// The world `name` with the given parameters (the others take their defaults).
    #[new]
    #[pyo3(signature = (name, **params))]
    fn new(name: &str, params: Option<&Bound<'_, PyDict>>) -> PyResult<Self> {
        let mut map = Map::new();
        for (key, value) in params.into_iter().flatten() {
            let key: String = key.extract()?;
            let json = to_json(&format!("{name}.{key}"), &value)?;
            map.insert(key, json);
        }
        Ok(PyWorld { world: AnyWorld::with_params(name, &map).or_raise()? })
    }

    /// The world of a policy file's `"world"` object: `{"name": ..., **params}`.
    #[staticmethod]
    fn from_dict(world: &Bound<'_, PyAny>) -> PyResult<Self> {
        Ok(PyWorld { world: AnyWorld::from_json(&to_json("world", world)?).or_raise()? })
    }

    /// The names of the registered worlds.
    #[staticmethod]
    fn names() -> Vec<&'static str> {
        registry::names()
    }

    /// Every parameter of the world `name` with its default.
    #[staticmethod]
    fn defaults<'py>(py: Python<'py>, name: &str) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &Value::Object((registry::entry(name).or_raise()?.defaults)()))
    }

    /// The world's registered name.
    #[getter]
    fn name(&self) -> &'static str {
        self.world.name()
    }

    /// Number of observations `Y`.
    #[getter]
    fn n_observations(&self) -> usize {
        with_world!(&self.world, w => w.n_observations())
    }

    /// Number of decisions `D`.
    #[getter]
    fn n_decisions(&self) -> usize {
        with_world!(&self.world, w => w.n_decisions())
    }

    /// Steps per episode `T`.
    #[getter]
    fn horizon(&self) -> usize {
        with_world!(&self.world, w => w.horizon())
    }

    /// Every parameter, as a dict (without the name).
    #[getter]
    fn params<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let mut json = self.world.to_json();
        if let Some(map) = json.as_object_mut() {
            map.remove("name");
        }
        to_py(py, &json)
    }

    /// The world as stored in policy files: its name and every parameter.
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.world.to_json())
    }

    /// Names of the numbers of one state in a rollout's `x`.
    fn state_labels(&self) -> Vec<&'static str> {
        with_world!(&self.world, w => w.state_labels())
    }

    /// The best mean reward any policy can reach, where the world knows it exactly.
    fn exact_optimum(&self) -> PyResult<f64> {
        with_world!(&self.world, w => w.exact_optimum()).or_raise()
    }
}
