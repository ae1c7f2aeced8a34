//! `cehmm._core.World`: any registered world (`ceworld::AnyWorld`), built by name through the
//! core's registry; the Python world classes (`cehmm.TargetTracking`, ...) wrap it.

use numpy::ndarray::{Array2, Array3};
use numpy::{IntoPyArray, PyArray1};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use serde_json::{Map, Value};

use ceworld::world::registry;
use ceworld::{AnyWorld, Error, World, with_world};

use crate::convert::{to_json, to_py};
use crate::errors::{OrRaise, raise};

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

    /// The model of a tabular world (model §7): names, the discount, the start distribution and
    /// the tables `T[a, s, s']`, `O[a, s', o]` and the expected reward `R[a, s]` (costs negated).
    fn model<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let Some(world) = self.world.tabular() else {
            return Err(raise(Error::invalid("world", format!("{} (not a tabular world)", self.world.name()))));
        };
        let t = world.tables();
        let p = &t.pomdp;
        let (n_s, n_a, n_o) = (t.n_states(), t.n_actions(), t.n_observations());
        let d = PyDict::new(py);
        d.set_item("states", p.states.clone())?;
        d.set_item("actions", p.actions.clone())?;
        d.set_item("observations", p.observations.clone())?;
        d.set_item("discount", t.gamma)?;
        d.set_item("start", PyArray1::from_slice(py, &t.start))?;
        let shaped = |values: Vec<f64>, dims: [usize; 3]| {
            Array3::from_shape_vec(dims, values).expect("the table's shape").into_pyarray(py)
        };
        d.set_item("transition", shaped(p.transition.clone(), [n_a, n_s, n_s]))?;
        d.set_item("observation", shaped(p.observation.clone(), [n_a, n_s, n_o]))?;
        let reward: Vec<f64> = (0..n_a * n_s).map(|i| t.expected_reward(i % n_s, i / n_s)).collect();
        d.set_item("reward", Array2::from_shape_vec((n_a, n_s), reward).expect("A × S").into_pyarray(py))?;
        d.set_item("renormalised", p.renormalised.clone())?;
        Ok(d)
    }
}
