//! `cehmm._core.optimize_controller`: a deterministic controller of any world, by the
//! cross-entropy method over controllers on exact or sampled values (model §8) or by the model
//! search on sampled ones (model §10), its result a dict (wrapped by `cehmm.ControllerResult`).

use pyo3::prelude::*;
use pyo3::types::PyDict;

use ceworld::ce::controller::checkpoint::ControllerSearch;
use ceworld::ce::controller::model_search::ModelSearch;
use ceworld::ce::controller::{ControllerSummary, ValueKind};
use ceworld::ce::resume::Checkpoint;
use ceworld::ce::stepped::Stepped;
use ceworld::run::{self, RunOptions, Search};
use ceworld::settings::{Given, Named, apply};

use crate::arg::WorldArg;
use crate::convert::{columns, flag, named, text};
use crate::errors::OrRaise;
use crate::policy::PyPolicy;
use crate::run::{checkpointing, stepped_result, watched};

/// Searches a deterministic controller of any world with `settings` (keyword settings by name;
/// one left out, or `None`, has the default of the search and of the kind of value used): by
/// `search` (`"ce"`, the cross-entropy method over controllers of model §8, or `"model"`, the
/// model search of model §10; default: the engine's for the kind of value, `run::Search`);
/// Ctrl-C stops it between iterations and the result comes back marked interrupted; `callback`
/// is called after every iteration (`crate::run::PyCallback`).
#[pyfunction]
#[pyo3(signature = (world, settings, *, value=None, search=None, progress, checkpoint=None, checkpoint_every=None, resume=None, callback=None))]
#[allow(clippy::too_many_arguments)]
pub fn optimize_controller<'py>(
    py: Python<'py>,
    world: &Bound<'py, PyAny>,
    settings: &Bound<'py, PyDict>,
    value: Option<&Bound<'py, PyAny>>,
    search: Option<&Bound<'py, PyAny>>,
    progress: &Bound<'py, PyAny>,
    checkpoint: Option<std::path::PathBuf>,
    checkpoint_every: Option<&Bound<'py, PyAny>>,
    resume: Option<&Bound<'py, PyAny>>,
    callback: Option<&Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyDict>> {
    let kind = value.map(|v| text("value", v)).transpose()?.map(|v| ValueKind::parse(&v)).transpose().or_raise()?;
    let search = search.map(|v| text("search", v)).transpose()?.map(|v| Search::parse(&v)).transpose().or_raise()?;
    let settings: Vec<Named> = named(settings)?.into_iter().filter(|s| s.value != Given::Nothing).collect();
    let progress = flag("progress", progress)?;
    let world = WorldArg::of(world)?;
    let search = world.run(py, |w| Search::resolve(w, kind, search))?;
    if search == Search::Model {
        let peek = run::optimiser(ModelSearch::NAME).or_raise()?.peek;
        let checkpointing = checkpointing(py, peek, checkpoint, checkpoint_every, resume)?;
        let searched = |w: &dyn ceworld::Episodes, options: &RunOptions<'_>| run::model_search(w, &settings, options);
        let (o, file) = watched(py, &world, progress, checkpointing.as_ref(), callback, searched, |o| {
            o.0.checkpoint_error.as_deref()
        })?;
        return stepped_result(py, &ControllerSummary::of_stepped(&o), &o, file);
    }
    let checkpointing = checkpointing(py, Checkpoint::<ControllerSearch>::peek, checkpoint, checkpoint_every, resume)?;
    // The settings are checked before any episode is run.
    world.run(py, |w| run::controller_setup(w, kind, |c| apply(c, &settings)).map(drop))?;
    let searched = |w: &dyn ceworld::Episodes, options: &RunOptions<'_>| {
        let (valued, config) = run::controller_setup(w, kind, |c| apply(c, &settings))?;
        let outcome = run::controller(valued, &config, options)?;
        Ok((outcome.to_file(valued.episodes(), &config), outcome))
    };
    let (file, o) =
        watched(py, &world, progress, checkpointing.as_ref(), callback, searched, |o| o.1.checkpoint_error.as_deref())?;
    let result = crate::results::fields(py, &o.summary())?;
    result.set_item("history", columns(py, &o.history)?)?;
    result.set_item("policy", PyPolicy { file })?;
    result.set_item("evaluation", o.evaluation.as_ref().map(|e| crate::results::evaluation(py, e)).transpose()?)?;
    Ok(result)
}
