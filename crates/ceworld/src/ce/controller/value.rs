//! How a controller search values its controllers (model §8): exactly on a tabular world, or
//! from sampled episodes of any world.

use crate::episodes::{Episodes, Remote};
use crate::error::{Error, Result};
use crate::exact::MAX_STEPS;
use crate::policy::controller::Controller;
use crate::world::World;
use crate::world::pomdp::PomdpWorld;

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
        let elsewhere = world.remote().filter(|r| r.tabular());
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

/// Exact values of controllers on one world.
pub struct ControllerValue<'a> {
    world: &'a PomdpWorld,
    /// `None`: infinite horizon, iterated to `tolerance`.
    horizon: Option<usize>,
    tolerance: f64,
}

impl<'a> ControllerValue<'a> {
    /// Values on `world`: infinite-horizon to `tolerance` when its discount is below 1, else at
    /// its horizon.
    pub fn new(world: &'a PomdpWorld, tolerance: f64) -> ControllerValue<'a> {
        let horizon = (world.tables().gamma >= 1.0).then(|| world.horizon());
        ControllerValue { world, horizon, tolerance }
    }

    /// The values of `controllers`, in parallel (on the current thread pool).
    pub fn values(&self, controllers: &[Controller]) -> Vec<f64> {
        use rayon::prelude::*;
        controllers.par_iter().map_init(|| (Vec::new(), Vec::new()), |(v, w), c| self.value(c, v, w)).collect()
    }

    /// The value of `c` from the start law; `v` and `w` are scratch space.
    pub fn value(&self, c: &Controller, v: &mut Vec<f64>, w: &mut Vec<f64>) -> f64 {
        let t = self.world.tables();
        let (n_s, n) = (t.n_states(), c.act.len());
        let y1 = t.n_observations() + 1;
        let gamma = t.gamma;
        v.clear();
        v.resize(n_s * n, 0.0);
        w.clear();
        w.resize(n_s * n, 0.0);
        let sweeps = self.horizon.unwrap_or(MAX_STEPS);
        // ||w − V*|| ≤ γ/(1 − γ)·||w − v|| for a γ-contraction.
        let factor = if gamma < 1.0 { gamma / (1.0 - gamma) } else { f64::INFINITY };
        for _ in 0..sweeps {
            let mut change: f64 = 0.0;
            for s in 0..n_s {
                for q in 0..n {
                    let a = c.act[q] as usize;
                    let mut x = t.expected_reward(s, a);
                    let mut future = 0.0;
                    for j in t.outcomes(s, a) {
                        let (s2, o) = t.next[j];
                        future += t.prob[j] * v[s2 as usize * n + c.next[q * y1 + o as usize] as usize];
                    }
                    x += gamma * future;
                    change = change.max((x - v[s * n + q]).abs());
                    w[s * n + q] = x;
                }
            }
            std::mem::swap(v, w);
            if self.horizon.is_none() && change * factor <= self.tolerance {
                break;
            }
        }
        let first = c.next[y1 - 1] as usize;
        t.start.iter().enumerate().map(|(s, &p)| p * v[s * n + first]).sum()
    }
}
