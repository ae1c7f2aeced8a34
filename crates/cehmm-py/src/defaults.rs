//! The engine's defaults, constants and schedules, exported to Python: defined once in the core, read by
//! the Python layer (`cehmm.optimizer.CE_DEFAULTS`, `cehmm.qlearning.Q_DEFAULTS`, ...).

use ceworld::CeConfig;
use ceworld::qlearn::{QConfig, WindowConfig};
use pyo3::prelude::*;
use pyo3::types::PyDict;

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
    let ce = CeConfig::default();
    let defaults = PyDict::new(py);
    defaults.set_item("samples", ce.samples)?;
    defaults.set_item("rho", ce.rho)?;
    defaults.set_item("smoothing", ce.smoothing)?;
    defaults.set_item("patience", ce.patience)?;
    defaults.set_item("seed", ce.seed)?;
    defaults.set_item("eval_episodes", ce.eval_episodes)?;
    defaults.set_item("memory_update", ce.memory_update.as_str())?;
    defaults.set_item("restarts", ce.restarts)?;
    defaults.set_item("checkpoint_every", ceworld::ce::resume::DEFAULT_EVERY)?;
    m.add("CE_DEFAULTS", defaults)?;
    let c = ceworld::ControllerConfig::default();
    let controller = PyDict::new(py);
    controller.set_item("nodes", c.nodes)?;
    controller.set_item("samples", c.samples)?;
    controller.set_item("rho", c.rho)?;
    controller.set_item("smoothing", c.smoothing)?;
    controller.set_item("patience", c.patience)?;
    controller.set_item("tolerance", c.tolerance)?;
    controller.set_item("seed", c.seed)?;
    controller.set_item("restarts", c.restarts)?;
    controller.set_item("episodes", c.episodes)?;
    controller.set_item("candidates", c.candidates)?;
    controller.set_item("select_episodes", c.select_episodes)?;
    controller.set_item("eval_episodes", c.eval_episodes)?;
    controller.set_item("injection", c.injection)?;
    controller.set_item("injections", c.injections)?;
    controller.set_item("template", c.template.as_str())?;
    controller.set_item("template_weight", c.template_weight)?;
    let s = ceworld::ControllerConfig::defaults_for(ceworld::ce::controller::ValueKind::Sampled);
    let sampled = PyDict::new(py);
    sampled.set_item("samples", s.samples)?;
    sampled.set_item("rho", s.rho)?;
    sampled.set_item("template", s.template.as_str())?;
    controller.set_item("sampled", sampled)?;
    m.add("CONTROLLER_DEFAULTS", controller)?;
    m.add("INIT_CHOICES", ceworld::Init::ALL.map(ceworld::Init::as_str).to_vec())?;
    m.add("MEMORY_UPDATES", ceworld::MemoryUpdate::ALL.map(ceworld::MemoryUpdate::as_str).to_vec())?;
    m.add("TIES", ceworld::Ties::ALL.map(ceworld::Ties::as_str).to_vec())?;
    m.add("DEFAULT_LEVELS", ceworld::DEFAULT_LEVELS.to_vec())?;
    m.add("WEAK_PATIENCE", ceworld::WEAK_PATIENCE)?;
    m.add("STRONG_PATIENCE", ceworld::STRONG_PATIENCE)?;
    let w = WindowConfig::default();
    let windows = PyDict::new(py);
    windows.set_item("window", w.window)?;
    windows.set_item("episodes", w.episodes)?;
    windows.set_item("chains", w.chains)?;
    windows.set_item("burn_in", w.burn_in)?;
    windows.set_item("windows_per_chain", w.windows_per_chain)?;
    m.add("WINDOW_DEFAULTS", windows)?;
    let q = QConfig::default();
    let qdefaults = PyDict::new(py);
    qdefaults.set_item("gamma", q.gamma)?;
    qdefaults.set_item("alpha", q.alpha)?;
    qdefaults.set_item("ties", q.ties.as_str())?;
    qdefaults.set_item("checkpoint_every", ceworld::qlearn::CHECKPOINT_EVERY)?;
    m.add("Q_DEFAULTS", qdefaults)?;
    m.add("PAPER_REFERENCE", ceworld::qlearn::PAPER_REFERENCE)?;
    Ok(())
}
