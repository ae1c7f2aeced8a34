//! The engine's defaults, constants and schedules, exported to Python: defined once in the core, read by
//! the Python layer (`cehmm.optimizer.CE_DEFAULTS`, `cehmm.qlearning.Q_DEFAULTS`, ...).

use ceworld::CeConfig;
use ceworld::qlearn::{QConfig, WindowConfig};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::convert::to_py;

/// The exploration rate of Q-learning update `t` (`ceworld::qlearn::epsilon`).
#[pyfunction]
fn epsilon(t: &Bound<'_, PyAny>) -> PyResult<f64> {
    Ok(ceworld::qlearn::epsilon(crate::convert::seed("t", t)?))
}

/// Adds `epsilon`, `CE_DEFAULTS`, `CONTROLLER_DEFAULTS`, `INIT_CHOICES`, `MEMORY_UPDATES`, `TIES`, `DEFAULT_LEVELS`, `WEAK_PATIENCE`, `STRONG_PATIENCE`, `WINDOW_DEFAULTS`,
/// `Q_DEFAULTS` and `PAPER_REFERENCE` to the module.
pub fn add(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add_function(wrap_pyfunction!(epsilon, m)?)?;
    // Every setting of each config, by name, as it serialises (a new setting needs no line here).
    let json = |v: serde_json::Result<serde_json::Value>| {
        v.map_err(|e| pyo3::exceptions::PyRuntimeError::new_err(e.to_string()))
    };
    let defaults = to_py(py, &json(serde_json::to_value(CeConfig::default()))?)?.cast_into::<PyDict>()?;
    defaults.set_item("checkpoint_every", ceworld::ce::resume::DEFAULT_EVERY)?;
    m.add("CE_DEFAULTS", defaults)?;
    let exact = json(serde_json::to_value(ceworld::ControllerConfig::default()))?;
    let sampled = json(serde_json::to_value(ceworld::ControllerConfig::defaults_for(
        ceworld::ce::controller::ValueKind::Sampled,
    )))?;
    let controller = to_py(py, &exact)?.cast_into::<PyDict>()?;
    // The settings whose default differs on sampled values.
    let differ = PyDict::new(py);
    if let (serde_json::Value::Object(e), serde_json::Value::Object(s)) = (&exact, &sampled) {
        for (key, value) in s {
            if e.get(key) != Some(value) {
                differ.set_item(key, to_py(py, value)?)?;
            }
        }
    }
    controller.set_item("sampled", differ)?;
    m.add("CONTROLLER_DEFAULTS", controller)?;
    m.add("INIT_CHOICES", ceworld::Init::ALL.map(ceworld::Init::as_str).to_vec())?;
    m.add("MEMORY_UPDATES", ceworld::MemoryUpdate::ALL.map(ceworld::MemoryUpdate::as_str).to_vec())?;
    m.add("TIES", ceworld::Ties::ALL.map(ceworld::Ties::as_str).to_vec())?;
    m.add("DEFAULT_LEVELS", ceworld::DEFAULT_LEVELS.to_vec())?;
    m.add("WEAK_PATIENCE", ceworld::WEAK_PATIENCE)?;
    m.add("STRONG_PATIENCE", ceworld::STRONG_PATIENCE)?;
    let windows = to_py(py, &json(serde_json::to_value(WindowConfig::default()))?)?;
    m.add("WINDOW_DEFAULTS", windows)?;
    let qdefaults = to_py(py, &json(serde_json::to_value(QConfig::default()))?)?.cast_into::<PyDict>()?;
    qdefaults.set_item("checkpoint_every", ceworld::qlearn::CHECKPOINT_EVERY)?;
    m.add("Q_DEFAULTS", qdefaults)?;
    m.add("PAPER_REFERENCE", ceworld::qlearn::PAPER_REFERENCE)?;
    Ok(())
}
