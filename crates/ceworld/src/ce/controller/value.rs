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

/// Exact values of controllers on one world.
///
/// A controller's value is the value of the Markov chain it makes of the world, over the
/// (state, node) pairs it can reach from the start ([`Scratch`] numbers them in the order they
/// are met, and merges the outcomes that lead to the same pair): at a finite horizon by as many
/// sweeps of backward induction; in the infinite horizon by Jacobi sweeps with the bounds of
/// `MacQueen` (1966). After a sweep `x' = r + γPx`, with `Δ = x' − x`, every value lies in
/// `x' + γ/(1 − γ)·[min Δ, max Δ]` (`P` is stochastic), so the sweeps stop once half that
/// interval is within the tolerance, and the value is its middle. Where the rewards make `Δ`
/// even (a controller that listens forever) one sweep gives the exact value; two controllers
/// that act alike on what they reach get the same value, bit for bit, however their nodes are
/// numbered.
pub struct ControllerValue<'a> {
    world: &'a PomdpWorld,
    /// `None`: infinite horizon, to `tolerance`.
    horizon: Option<usize>,
    tolerance: f64,
}

/// Scratch space of [`ControllerValue::value`], reused from one controller to the next.
#[derive(Clone, Debug, Default)]
pub struct Scratch {
    /// `1 +` the number of pair `(s, q)` at `s·n + q`; 0 where not reached.
    index: Vec<u32>,
    /// The reached pairs `(s, q)`, in the order met.
    pairs: Vec<(u32, u32)>,
    /// Each pair's expected immediate reward.
    reward: Vec<f64>,
    /// Each pair's successors `to[row[i]..row[i + 1]]`, with their probabilities `prob`.
    row: Vec<usize>,
    to: Vec<u32>,
    prob: Vec<f64>,
    v: Vec<f64>,
    w: Vec<f64>,
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
        let gamma = t.gamma;
        let first = c.next[t.n_observations()];
        self.reach(c, scratch);
        let Scratch { index, pairs, reward, row, to, prob, v, w } = scratch;
        let m = pairs.len();
        v.clear();
        v.resize(m, 0.0);
        w.clear();
        w.resize(m, 0.0);
        let (sweeps, factor) = match self.horizon {
            Some(h) => (h, 0.0),
            None => (MAX_STEPS, gamma / (1.0 - gamma)),
        };
        let mut shift = 0.0;
        for _ in 0..sweeps {
            let (mut low, mut high) = (f64::INFINITY, f64::NEG_INFINITY);
            for i in 0..m {
                let future: f64 = (row[i]..row[i + 1]).map(|e| prob[e] * v[to[e] as usize]).sum();
                let x = reward[i] + gamma * future;
                let change = x - v[i];
                low = low.min(change);
                high = high.max(change);
                w[i] = x;
            }
            std::mem::swap(v, w);
            if self.horizon.is_none() {
                shift = factor * (low + high) / 2.0;
                if factor * (high - low) / 2.0 <= self.tolerance {
                    break;
                }
            }
        }
        let n = c.nodes();
        let value = t
            .start
            .iter()
            .enumerate()
            .filter(|&(_, &p)| p > 0.0)
            .map(|(s, &p)| p * v[index[s * n + first as usize] as usize - 1])
            .sum::<f64>();
        value + shift
    }

    /// Numbers the pairs `c` reaches from the start and lays out their rows (see [`Scratch`]).
    fn reach(&self, c: &Controller, scratch: &mut Scratch) {
        let t = self.world.tables();
        let (n, y1) = (c.nodes(), t.n_observations() + 1);
        let Scratch { index, pairs, reward, row, to, prob, .. } = scratch;
        index.clear();
        index.resize(t.n_states() * n, 0);
        pairs.clear();
        reward.clear();
        row.clear();
        row.push(0);
        to.clear();
        prob.clear();
        let mut number = |s: u32, q: u32, pairs: &mut Vec<(u32, u32)>| {
            let slot = &mut index[s as usize * n + q as usize];
            if *slot == 0 {
                pairs.push((s, q));
                *slot = pairs.len() as u32;
            }
            *slot - 1
        };
        let first = c.next[y1 - 1];
        for (s, &p) in t.start.iter().enumerate() {
            if p > 0.0 {
                number(s as u32, first, pairs);
            }
        }
        let mut i = 0;
        while i < pairs.len() {
            let (s, q) = (pairs[i].0 as usize, pairs[i].1 as usize);
            let a = c.act[q] as usize;
            reward.push(t.expected_reward(s, a));
            let start = to.len();
            for j in t.outcomes(s, a) {
                let (s2, o) = t.next[j];
                let k = number(s2, c.next[q * y1 + o as usize], pairs);
                if let Some(at) = to[start..].iter().position(|&x| x == k) {
                    prob[start + at] += t.prob[j];
                } else {
                    to.push(k);
                    prob.push(t.prob[j]);
                }
            }
            row.push(to.len());
            i += 1;
        }
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
