//! Python bindings of the `ceworld` engine, built by maturin as the private module `cehmm._core`.
//!
//! The bindings only translate: Python values into the core's types (`convert`), core errors
//! into exceptions (`errors`), core results into frozen classes (`results`); every rule, default
//! and check is the core's. One module per concept: worlds through the core's registry
//! (`world`), policies (`policy`), the CE method (`optimize`) and its search over deterministic
//! controllers of tabular worlds (`controller`), Q-learning and the window
//! evaluation (`qlearn`), the core's defaults and constants (`defaults`). Optimisation,
//! evaluation and rollouts run detached from the interpreter (`py.detach`); long runs check for
//! Ctrl-C between iterations and then return what they have, marked interrupted. The documented
//! public API is the Python layer in `python/cehmm/`; the stub `python/cehmm/_core.pyi` lists
//! what this module exports.

#![allow(clippy::needless_pass_by_value)] // pyo3 extracts arguments by value
#![allow(clippy::redundant_closure_for_method_calls)] // `Python::attach` needs a closure, not a path

mod arg;
mod cli;
mod controller;
mod convert;
mod defaults;
mod errors;
mod files;
mod optimize;
mod outside;
mod policy;
mod qlearn;
mod remote;
mod results;
mod run;
mod shards;
mod signals;
mod stepping;
mod world;

use pyo3::prelude::*;

/// `cehmm._core`: the compiled engine; use the `cehmm` package instead.
#[pymodule(gil_used = false)]
mod _core {
    #[pymodule_export]
    use super::cli::cli;
    #[pymodule_export]
    use super::controller::optimize_controller;
    #[pymodule_export]
    use super::errors::{
        CehmmError, InternalError, InvalidArgumentError, ModelFormatError, PolicyFormatError, PolicyMismatchError,
        WorldError,
    };
    #[pymodule_export]
    use super::files::{check_distinct, check_writable, read_file};
    #[pymodule_export]
    use super::optimize::optimize;
    #[pymodule_export]
    use super::outside::PyOutsideWorld;
    #[pymodule_export]
    use super::policy::PyPolicy;
    #[pymodule_export]
    use super::qlearn::{PyQLearner, evaluate_policy_windows};
    #[pymodule_export]
    use super::remote::PyRemoteWorld;
    #[pymodule_export]
    use super::run::run;
    #[pymodule_export]
    use super::shards::{controller_credit, controller_exact_values, controller_steps, controller_values};
    #[pymodule_export]
    use super::stepping::{PyAgent, PySession};
    #[pymodule_export]
    use super::world::PyWorld;

    use super::{Bound, PyModule, PyModuleMethods, PyResult};

    #[pymodule_init]
    fn init(m: &Bound<'_, PyModule>) -> PyResult<()> {
        // Import numpy's C API now: done lazily, the first array made after a Ctrl-C would find
        // the import interrupted and panic.
        let _ = numpy::PyArray1::<f64>::from_vec(m.py(), Vec::new());
        m.add("ENGINE_VERSION", ceworld::VERSION)?;
        m.add("GRAPH_PRUNE", ceworld::policy::graph::PRUNE)?;
        m.add("BACKEND_METHODS", super::remote::METHODS)?;
        m.add("PACKAGE_COMMANDS", ceworld::cli::PACKAGE_COMMANDS.to_vec())?;
        m.add("PENDING_METHODS", super::remote::PENDING)?;
        super::run::add(m)?;
        super::defaults::add(m)
    }
}
