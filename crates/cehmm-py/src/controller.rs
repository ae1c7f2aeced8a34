//! `cehmm._core.optimize_controller`: the cross-entropy method over deterministic controllers of
//! any world, on exact or sampled values (model §8), its result a dict (wrapped by
//! `cehmm.ControllerResult`).

use pyo3::prelude::*;
use pyo3::types::PyDict;

use ceworld::ce::controller::ValueKind;
use ceworld::ce::controller::checkpoint::ControllerSearch;
use ceworld::ce::resume::Checkpoint;
use ceworld::run::{self, RunOptions};
use ceworld::settings::apply;

use crate::arg::WorldArg;
use crate::convert::{columns, flag, named, text};
use crate::errors::OrRaise;
use crate::policy::PyPolicy;
use crate::run::{checkpointing, watched};

/// Searches a deterministic controller of any world (model §8) with `settings` (keyword
/// settings by name; one left out, or `None` for `samples`, `rho`, `smoothing`, `template`,
/// `decisions`, `memoryless_patience` and `memory`, has the default of the kind of value used); Ctrl-C stops
/// it between iterations and the result comes back marked interrupted; `callback` is called
/// after every iteration (`crate::run::PyCallback`).
#[pyfunction]
#[pyo3(signature = (world, settings, *, value=None, progress, checkpoint=None, checkpoint_every=None, resume=None, callback=None))]
#[allow(clippy::too_many_arguments)]
pub fn optimize_controller<'py>(
    py: Python<'py>,
    world: &Bound<'py, PyAny>,
    settings: &Bound<'py, PyDict>,
    value: Option<&Bound<'py, PyAny>>,
    progress: &Bound<'py, PyAny>,
    checkpoint: Option<std::path::PathBuf>,
    checkpoint_every: Option<&Bound<'py, PyAny>>,
    resume: Option<&Bound<'py, PyAny>>,
    callback: Option<&Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyDict>> {
    let kind = value.map(|v| text("value", v)).transpose()?.map(|v| ValueKind::parse(&v)).transpose().or_raise()?;
    let settings = named(settings)?;
    let progress = flag("progress", progress)?;
    let checkpointing = checkpointing(py, Checkpoint::<ControllerSearch>::peek, checkpoint, checkpoint_every, resume)?;
    let world = WorldArg::of(world)?;
    // The settings are checked before any episode is run.
    world.run(py, |w| run::controller_setup(w, kind, |c| apply(c, &settings)).map(drop))?;
    let search = |w: &dyn ceworld::Episodes, options: &RunOptions<'_>| {
        let (valued, config) = run::controller_setup(w, kind, |c| apply(c, &settings))?;
        let outcome = run::controller(valued, &config, options)?;
        Ok((outcome.to_file(valued.episodes(), &config), outcome))
    };
    let (file, o) =
        watched(py, &world, progress, checkpointing.as_ref(), callback, search, |o| o.1.checkpoint_error.as_deref())?;
    let result = crate::results::fields(py, &o.summary())?;
    result.set_item("history", columns(py, &o.history)?)?;
    result.set_item("policy", PyPolicy { file })?;
    result.set_item("evaluation", o.evaluation.as_ref().map(|e| crate::results::evaluation(py, e)).transpose()?)?;
    Ok(result)
}
