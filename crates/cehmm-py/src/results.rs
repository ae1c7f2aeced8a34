//! Results as frozen Python classes: `Evaluation`, `Rollout` and `WindowEvaluation` (exported as
//! `cehmm.Evaluation`, ...), each wrapping the core's own type.

use numpy::ndarray::Array2;
use numpy::{IntoPyArray, PyArray1, PyArray2};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use ceworld::episodes::run::Rollout;
use ceworld::exact::ExactValue;
use ceworld::progress::{decimals, fixed};
use ceworld::qlearn::{WindowReport, percent};
use ceworld::{Error, Evaluation};

use crate::errors::raise;

/// The reward of a policy over fresh episodes.
#[pyclass(module = "cehmm", name = "Evaluation", frozen, eq)]
#[derive(PartialEq)]
pub struct PyEvaluation(pub Evaluation);

#[pymethods]
impl PyEvaluation {
    /// Number of episodes.
    #[getter]
    fn episodes(&self) -> usize {
        self.0.episodes
    }

    /// Mean reward.
    #[getter]
    fn mean(&self) -> f64 {
        self.0.mean
    }

    /// Standard error of the mean (`std / sqrt(episodes)`).
    #[getter]
    fn std_error(&self) -> f64 {
        self.0.std_error
    }

    /// Sample standard deviation of the reward.
    #[getter]
    fn std(&self) -> f64 {
        self.0.std
    }

    /// Smallest reward.
    #[getter]
    fn min(&self) -> f64 {
        self.0.min
    }

    /// Largest reward.
    #[getter]
    fn max(&self) -> f64 {
        self.0.max
    }

    /// `{q: value}` for q = 0.05, 0.25, 0.5, 0.75, 0.95 (nearest rank).
    #[getter]
    fn quantiles<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        for &(q, v) in &self.0.quantiles {
            d.set_item(q, v)?;
        }
        Ok(d)
    }

    fn __repr__(&self) -> String {
        let e = &self.0;
        let median = e.quantiles.iter().find(|(q, _)| *q == 0.5).map_or(f64::NAN, |&(_, v)| v);
        // Every figure to the precision of the standard error (two significant digits of it).
        let f = |x: f64| fixed(x, decimals(e.std_error));
        format!(
            "Evaluation(mean={} ± {}, episodes={}, std={}, min={}, max={}, median={})",
            f(e.mean),
            f(e.std_error),
            e.episodes,
            f(e.std),
            f(e.min),
            f(e.max),
            f(median)
        )
    }
}

/// One recorded episode of a policy in a world; step `t` is row `t` of every array.
#[pyclass(module = "cehmm", name = "Rollout", frozen)]
pub struct PyRollout(pub Rollout);

#[pymethods]
impl PyRollout {
    /// Hidden state `x_t`, shape `(T, k)`, int64; columns named by `x_labels`.
    #[getter]
    fn x<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<i64>> {
        let r = &self.0;
        Array2::from_shape_vec((r.len(), r.x_labels.len()), r.x.clone()).expect("one state per step").into_pyarray(py)
    }

    /// Names of the columns of `x`.
    #[getter]
    fn x_labels(&self) -> Vec<&'static str> {
        self.0.x_labels.clone()
    }

    /// Observation `y_t`, shape `(T,)`, int64.
    #[getter]
    fn y<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<i64>> {
        PyArray1::from_slice(py, &self.0.y)
    }

    /// Decision `d_t`, shape `(T,)`, int64.
    #[getter]
    fn d<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<i64>> {
        PyArray1::from_slice(py, &self.0.d)
    }

    /// Memory states `m_1[t] .. m_Λ[t]`, shape `(T, Λ)`, int64.
    #[getter]
    fn memory<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<i64>> {
        let r = &self.0;
        Array2::from_shape_vec((r.len(), r.levels), r.memory.clone()).expect("Λ states per step").into_pyarray(py)
    }

    /// The episode's reward `V`.
    #[getter]
    fn reward(&self) -> f64 {
        self.0.reward
    }

    fn __len__(&self) -> usize {
        self.0.len()
    }

    /// The column of `x` named `label` (e.g. `"target_i"`).
    fn column<'py>(&self, py: Python<'py>, label: &str) -> PyResult<Bound<'py, PyArray1<i64>>> {
        let r = &self.0;
        let Some(k) = r.x_labels.iter().position(|l| *l == label) else {
            return Err(raise(Error::invalid("label", format!("{label:?} (expected one of {:?})", r.x_labels))));
        };
        let width = r.x_labels.len();
        Ok(PyArray1::from_iter(py, r.x.iter().skip(k).step_by(width).copied()))
    }

    fn __repr__(&self) -> String {
        format!("Rollout(steps={}, levels={}, reward={})", self.0.len(), self.0.levels, self.0.reward)
    }
}

/// The non-discounted reward of windows of a policy's runs, as the paper compares policies:
/// `from_start`, one window from each fresh start of the world, and `continuing`, consecutive
/// windows of long continuing runs after a burn-in (correlated: its `std_error` is optimistic);
/// `reference` is the reward that counts as 100 %.
#[pyclass(module = "cehmm", name = "WindowEvaluation", frozen, eq)]
#[derive(PartialEq)]
pub struct PyWindowEvaluation {
    pub report: WindowReport,
    pub reference: f64,
}

#[pymethods]
impl PyWindowEvaluation {
    /// (a) One window from each fresh start; `min` is the worst window, `max` the best.
    #[getter]
    #[allow(clippy::wrong_self_convention)] // the name of the Python attribute
    fn from_start(&self) -> PyEvaluation {
        PyEvaluation(self.report.from_start.clone())
    }

    /// (b) Consecutive windows of continuing runs after the burn-in.
    #[getter]
    fn continuing(&self) -> PyEvaluation {
        PyEvaluation(self.report.continuing.clone())
    }

    /// The reward that counts as 100 % (the paper: 69).
    #[getter]
    fn reference(&self) -> f64 {
        self.reference
    }

    /// `{"from_start": (worst, mean, best), "continuing": (...)}` in % of `reference`.
    fn percent<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        for (name, e) in [("from_start", &self.report.from_start), ("continuing", &self.report.continuing)] {
            let r = self.reference;
            d.set_item(name, (percent(e.min, r), percent(e.mean, r), percent(e.max, r)))?;
        }
        Ok(d)
    }

    fn __repr__(&self) -> String {
        let r = self.reference;
        let p = |e: &Evaluation| (percent(e.min, r), percent(e.mean, r), percent(e.max, r));
        let (a, b) = (p(&self.report.from_start), p(&self.report.continuing));
        format!(
            "WindowEvaluation(from_start: worst/mean/best {:.0}/{:.0}/{:.0} % over {} windows; continuing: \
             {:.0}/{:.0}/{:.0} % over {} windows; of {r})",
            a.0, a.1, a.2, self.report.from_start.episodes, b.0, b.1, b.2, self.report.continuing.episodes
        )
    }
}

/// An exact value of a policy on a tabular world (model §7): the expected (discounted) reward,
/// the steps of the recursion, and a bound on what the steps not taken could add (0 at a
/// finite horizon).
#[pyclass(module = "cehmm", name = "ExactValue", frozen, eq)]
#[derive(PartialEq)]
pub struct PyExactValue(pub ExactValue);

#[pymethods]
impl PyExactValue {
    /// The expected (discounted) reward.
    #[getter]
    fn value(&self) -> f64 {
        self.0.value
    }

    /// Steps of the recursion (the horizon, or the steps taken to reach the tolerance).
    #[getter]
    fn steps(&self) -> usize {
        self.0.steps
    }

    /// A bound on what the steps not taken could add (0 at a finite horizon).
    #[getter]
    fn tail_bound(&self) -> f64 {
        self.0.tail_bound
    }

    fn __float__(&self) -> f64 {
        self.0.value
    }

    fn __repr__(&self) -> String {
        format!("ExactValue(value={}, steps={}, tail_bound={:.1e})", self.0.value, self.0.steps, self.0.tail_bound)
    }
}
