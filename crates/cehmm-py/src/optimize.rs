//! `cehmm._core.optimize`: the cross-entropy method (model §3) on any registered world, its
//! result a dict (wrapped by `cehmm.OptimizeResult`).

use std::path::PathBuf;

use pyo3::prelude::*;
use pyo3::types::PyDict;

use ceworld::CeConfig;
use ceworld::ce::checkpoint::CeRun;
use ceworld::ce::resume::Checkpoint;
use ceworld::run::RunOptions;

use crate::arg::WorldArg;
use crate::convert::{apply_settings, columns, flag};
use crate::policy::PyPolicy;
use crate::run::{checkpointing, watched};

/// Runs the cross-entropy method (model §3) from `initial` with `settings` (keyword settings by
/// name; one left out has its default), checkpointed when `checkpoint` is given; Ctrl-C stops it
/// between iterations and the result comes back marked interrupted; `callback` is called after
/// every iteration (`crate::run::PyCallback`).
#[pyfunction]
#[pyo3(signature = (world, initial, settings, *, progress, checkpoint=None, checkpoint_every=None, resume=None, callback=None))]
#[allow(clippy::too_many_arguments)]
pub fn optimize<'py>(
    py: Python<'py>,
    world: &Bound<'py, PyAny>,
    initial: &PyPolicy,
    settings: &Bound<'py, PyDict>,
    progress: &Bound<'py, PyAny>,
    checkpoint: Option<PathBuf>,
    checkpoint_every: Option<&Bound<'py, PyAny>>,
    resume: Option<&Bound<'py, PyAny>>,
    callback: Option<&Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyDict>> {
    let mut config = CeConfig::default();
    apply_settings(&mut config, settings)?;
    let progress = flag("progress", progress)?;
    let checkpointing = checkpointing(py, Checkpoint::<CeRun>::peek, checkpoint, checkpoint_every, resume)?;
    let (world, initial) = (WorldArg::of(world)?, initial.file.policy.clone());
    let run = |w: &dyn ceworld::Episodes, options: &RunOptions<'_>| {
        let r = ceworld::run::optimize(w, initial, &config, options)?;
        Ok((r.to_file(w, &config), r.last_to_file(w, &config), r))
    };
    let (best, last, r) =
        watched(py, &world, progress, checkpointing.as_ref(), callback, run, |o| o.2.checkpoint_error.as_deref())?;
    let result = crate::results::fields(py, &r.summary())?;
    result.set_item("history", columns(py, &r.history)?)?;
    result.set_item("policy", PyPolicy { file: best })?;
    result.set_item("last_policy", PyPolicy { file: last })?;
    result.set_item("evaluation", crate::results::evaluation(py, &r.evaluation)?)?;
    Ok(result)
}
