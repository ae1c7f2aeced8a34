//! `WorldArg`: the world argument of the engine's functions, whichever kind it is (a registered
//! world, one written in Python, one sampled elsewhere), and the one place that runs engine code
//! on its episodes.

use pyo3::prelude::*;

use ceworld::episodes::Interruptible;
use ceworld::{Episodes, with_world};

use crate::errors::{detached, raise};
use crate::outside::{PyOutsideWorld, detached_or_watched, run_outside, surface};
use crate::remote::PyRemoteWorld;
use crate::signals::Signals;
use crate::world::PyWorld;

/// The world argument of the engine's functions: a registered world or one written in Python.
pub enum WorldArg<'py> {
    /// A registered world.
    Engine(PyRef<'py, PyWorld>),
    /// A world written in Python.
    Outside(PyRef<'py, PyOutsideWorld>),
    /// A world whose episodes a backend samples elsewhere.
    Remote(PyRef<'py, PyRemoteWorld>),
}

impl<'py> WorldArg<'py> {
    /// `world` as either kind, or a `TypeError`.
    pub fn of(world: &Bound<'py, PyAny>) -> PyResult<Self> {
        if let Ok(w) = world.extract::<PyRef<'py, PyWorld>>() {
            return Ok(WorldArg::Engine(w));
        }
        if let Ok(w) = world.extract::<PyRef<'py, PyRemoteWorld>>() {
            return Ok(WorldArg::Remote(w));
        }
        world.extract::<PyRef<'py, PyOutsideWorld>>().map(WorldArg::Outside).map_err(|_| {
            pyo3::exceptions::PyTypeError::new_err(format!(
                "invalid world: {} (expected a cehmm world or a world written in Python)",
                crate::convert::shown(world)
            ))
        })
    }

    /// The tabular world (a `.pomdp` file) it is, if it is one.
    pub fn tabular(&self) -> Option<&ceworld::world::pomdp::PomdpWorld> {
        match self {
            WorldArg::Engine(w) => w.world.tabular(),
            WorldArg::Outside(_) | WorldArg::Remote(_) => None,
        }
    }

    /// Runs `f` on the world's episodes, detached from the interpreter. An exception raised by a
    /// world's Python code comes back as itself, with a note naming the episode and the step.
    pub fn run<T: Send>(
        &self,
        py: Python<'_>,
        f: impl FnOnce(&dyn Episodes) -> ceworld::Result<T> + Send,
    ) -> PyResult<T> {
        self.run_with(py, None, f)
    }

    /// [`WorldArg::run`], the signal handlers run meanwhile: Ctrl-C stops the episodes (between
    /// two steps of a world written in Python, between two calls of one run by the engine).
    pub fn run_watched<T: Send>(
        &self,
        py: Python<'_>,
        signals: &mut Signals,
        f: impl FnOnce(&dyn Episodes) -> ceworld::Result<T> + Send,
    ) -> PyResult<T> {
        self.run_with(py, Some(signals), f)
    }

    fn run_with<T: Send>(
        &self,
        py: Python<'_>,
        signals: Option<&mut Signals>,
        f: impl FnOnce(&dyn Episodes) -> ceworld::Result<T> + Send,
    ) -> PyResult<T> {
        match self {
            WorldArg::Engine(w) => {
                let world = &w.world;
                match signals {
                    None => detached(py, || with_world!(world, w => f(w))),
                    Some(signals) => {
                        let interrupt = signals.interrupt().clone();
                        let run =
                            || ceworld::catch_panics(|| with_world!(world, w => f(&Interruptible::new(w, interrupt))));
                        signals.watch(py, run)?.map_err(raise)
                    }
                }
            }
            WorldArg::Outside(w) => run_outside(py, w, signals, |lockstep| f(lockstep)),
            WorldArg::Remote(w) => {
                let interrupt = signals.as_ref().map(|s| s.interrupt().clone()).unwrap_or_default();
                let remote = w.episodes(py, interrupt);
                let result = detached_or_watched(py, signals, || f(&remote))?;
                surface(py, result, remote.into_raised())
            }
        }
    }
}
