//! Results as Python values: dicts of numbers, strings and numpy arrays, which `cehmm.results`
//! makes into its classes (`cehmm.Evaluation`, `cehmm.Rollout`, ...) by their keys. A result's
//! plain fields are the core's `Serialize` structs ([`fields`]: each field named once, in the core,
//! and once in the Python class a user reads); what needs translating (policies, histories as numpy
//! columns, quantiles keyed by numbers) is added here. The lines they show (`repr`) are the core's
//! (`ceworld::progress`).

use numpy::ndarray::Array2;
use numpy::{IntoPyArray, PyArray1};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use serde::Serialize;

use ceworld::episodes::run::Rollout;
use ceworld::exact::ExactValue;
use ceworld::qlearn::WindowReport;
use ceworld::{Evaluation, progress};

/// The fields of `value` (a struct) as a dict, as serde names them.
pub fn fields<'py>(py: Python<'py>, value: &impl Serialize) -> PyResult<Bound<'py, PyDict>> {
    let value = serde_json::to_value(value).expect("a result serialises");
    Ok(crate::convert::to_py(py, &value)?.cast_into::<PyDict>()?)
}

/// The fields of [`Evaluation`], its quantiles as `{q: value}`, and the line it shows (`shown`).
pub fn evaluation<'py>(py: Python<'py>, e: &Evaluation) -> PyResult<Bound<'py, PyDict>> {
    let quantiles = PyDict::new(py);
    for &(q, v) in &e.quantiles {
        quantiles.set_item(q, v)?;
    }
    let d = fields(py, e)?;
    d.set_item("quantiles", quantiles)?;
    d.set_item("shown", progress::evaluation(e))?;
    Ok(d)
}

/// `{x, x_labels, y, d, memory, reward}`: `x` and `memory` of one row a step.
pub fn rollout(py: Python<'_>, r: Rollout) -> PyResult<Bound<'_, PyDict>> {
    let (steps, width) = (r.len(), r.x_labels.len());
    let d = PyDict::new(py);
    d.set_item("x", Array2::from_shape_vec((steps, width), r.x).expect("one state per step").into_pyarray(py))?;
    d.set_item("x_labels", r.x_labels)?;
    d.set_item("y", PyArray1::from_vec(py, r.y))?;
    d.set_item("d", PyArray1::from_vec(py, r.d))?;
    let memory = Array2::from_shape_vec((steps, r.levels), r.memory).expect("Λ states per step");
    d.set_item("memory", memory.into_pyarray(py))?;
    d.set_item("reward", r.reward)?;
    Ok(d)
}

/// The fields of [`ExactValue`].
pub fn exact_value<'py>(py: Python<'py>, v: &ExactValue) -> PyResult<Bound<'py, PyDict>> {
    fields(py, v)
}

/// `{from_start, continuing, reference, shown}`, each evaluation as [`evaluation`] makes it.
pub fn windows<'py>(py: Python<'py>, report: &WindowReport, reference: f64) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("from_start", evaluation(py, &report.from_start)?)?;
    d.set_item("continuing", evaluation(py, &report.continuing)?)?;
    d.set_item("reference", reference)?;
    d.set_item("shown", progress::windows(report, reference))?;
    Ok(d)
}
