//! How a controller search values its controllers (model §8): exactly on a tabular world, or
//! from sampled episodes of any world.

use crate::episodes::{Episodes, Remote};
use crate::error::{Error, Result};
use crate::policy::controller::Controller;
use crate::world::World;
use crate::world::pomdp::PomdpWorld;

use super::chain::{Factored, Scratch};
use super::config::ValueKind;

/// The world of a controller search and how its controllers are valued.
#[derive(Clone, Copy)]
pub enum Valued<'a> {
    /// Exact values of a tabular world (model §8).
    Exact(&'a PomdpWorld),
    /// Values estimated from episodes of any world.
    Sampled(&'a dyn Episodes),
    /// Exact values of a tabular world sampled elsewhere, computed there
    /// ([`crate::episodes::Remote::exact_values`]; model §9).
    ExactElsewhere(&'a dyn Episodes, &'a dyn Remote),
}

impl Valued<'_> {
    /// How a search on `world` values its controllers: `kind`, or by default exactly where the
    /// world is tabular (here, or sampled elsewhere) and from sampled episodes everywhere else.
    /// The one place that decides the kind of value, and so the defaults that depend on it
    /// ([`super::ControllerConfig::defaults_for`]).
    pub fn of(world: &dyn Episodes, kind: Option<ValueKind>) -> Result<Valued<'_>> {
        let elsewhere = world.remote().filter(|r| r.model().is_some());
        match (world.tabular(), elsewhere, kind) {
            (_, _, Some(ValueKind::Sampled)) | (None, None, None) => Ok(Valued::Sampled(world)),
            (Some(tabular), _, None | Some(ValueKind::Exact)) => Ok(Valued::Exact(tabular)),
            (None, Some(remote), None | Some(ValueKind::Exact)) => Ok(Valued::ExactElsewhere(world, remote)),
            (None, None, Some(ValueKind::Exact)) => Err(Error::invalid(
                "value",
                format!(
                    "\"exact\" for the world {} (exact values need a tabular world: a .pomdp file, a \
                     cehmm.PomdpWorld; use \"sampled\")",
                    world.description()
                ),
            )),
        }
    }

    /// Which kind.
    pub fn kind(&self) -> ValueKind {
        match self {
            Valued::Exact(_) | Valued::ExactElsewhere(..) => ValueKind::Exact,
            Valued::Sampled(_) => ValueKind::Sampled,
        }
    }

    /// The world as a source of episodes.
    pub fn episodes(&self) -> &dyn Episodes {
        match *self {
            Valued::Exact(world) => world,
            Valued::Sampled(world) | Valued::ExactElsewhere(world, _) => world,
        }
    }
}

/// Exact values of controllers on one world: the value of the Markov chain each makes of the
/// world ([`super::chain`]).
pub struct ControllerValue<'a> {
    world: &'a PomdpWorld,
    factored: Factored,
    /// `None`: infinite horizon, to `tolerance`.
    horizon: Option<usize>,
    tolerance: f64,
}

impl<'a> ControllerValue<'a> {
    /// Values on `world`: infinite-horizon to `tolerance` when its discount is below 1, else at
    /// its horizon.
    pub fn new(world: &'a PomdpWorld, tolerance: f64) -> ControllerValue<'a> {
        let horizon = (world.tables().gamma >= 1.0).then(|| world.horizon());
        ControllerValue { world, factored: Factored::new(world.tables()), horizon, tolerance }
    }

    /// The values of `controllers`, in parallel (on the current thread pool).
    pub fn values(&self, controllers: &[Controller]) -> Vec<f64> {
        use rayon::prelude::*;
        controllers.par_iter().map_init(Scratch::default, |scratch, c| self.value(c, scratch)).collect()
    }

    /// The value of `c` from the start law.
    pub fn value(&self, c: &Controller, scratch: &mut Scratch) -> f64 {
        let t = self.world.tables();
        let moore;
        let c = if c.is_mealy() {
            moore = c.to_moore(t.n_observations() + 1);
            &moore
        } else {
            c
        };
        scratch.value(t, &self.factored, c, self.horizon, self.tolerance)
    }
}

/// The values of the controllers a search has met (exact values, or scores on the fixed
/// selection episodes), so that a controller drawn again (as the laws concentrate, most are) is
/// valued once. Such a value depends on the controller alone, so the search's results do not
/// depend on what is kept; at most [`Seen::BYTES`] of controllers
/// are, the whole store cleared when full.
pub struct Seen {
    values: std::sync::Mutex<std::collections::HashMap<Controller, f64>>,
    most: usize,
}

impl Seen {
    /// The most memory the controllers kept may take.
    pub const BYTES: usize = 64 << 20;

    /// A store for controllers of at most `nodes` nodes on `observations` observations.
    pub fn new(nodes: usize, observations: usize) -> Seen {
        // Successors, and a Mealy machine's decisions.
        let bytes = (nodes * (2 * observations + 1) * 4 + 64).max(1);
        Seen { values: std::sync::Mutex::default(), most: (Self::BYTES / bytes).max(1) }
    }

    /// The value of `c`: the one kept, or `value()` (then kept).
    pub fn value(&self, c: &Controller, value: impl FnOnce() -> f64) -> f64 {
        if let Some(v) = self.get(c) {
            return v;
        }
        let v = value();
        self.keep(c, v);
        v
    }

    /// The value kept for `c`, if any.
    pub fn get(&self, c: &Controller) -> Option<f64> {
        self.lock().get(c).copied()
    }

    /// Keeps `v` as the value of `c`.
    pub fn keep(&self, c: &Controller, v: f64) {
        let mut values = self.lock();
        if values.len() >= self.most {
            values.clear();
        }
        values.insert(c.clone(), v);
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, std::collections::HashMap<Controller, f64>> {
        self.values.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
    }
}
