//! The Markov chain a deterministic controller makes of a tabular world, and its value
//! (model §8).
//!
//! The chain's states are the (state, node) pairs the controller reaches from the start, in the
//! order they are met. A step from `(s, q)` goes through an after-state `(s', q)` (the world has
//! moved, the observation is not yet drawn) and then to `(s', q')`, `q'` the node after `q` on
//! the observation: `P = T · O`, kept as the two factors (`T(s'|s,a)` and `O(o|a,s')` apart), so
//! a step costs the successors of `T` plus those of `O`, not their product (hallway's random
//! 32-node controller: about 4 a pair and 12 an after-state against 46 a pair), where that is
//! fewer entries ([`Factored`]; elsewhere the world's outcomes are kept).
//!
//! In the infinite horizon the value solves `(I − γP) x = r`, held to the bounds of `MacQueen`
//! (1966): after a sweep `x' = r + γPx`, with `Δ = x' − x`, every value lies in `x' + γ/(1 −
//! γ)·[min Δ, max Δ]` (`P` is stochastic), so it stops once half that interval is within the
//! tolerance, and the value is its middle. Jacobi sweeps first, from zero: where the bounds close
//! fast they are the cheapest, and where the rewards make `Δ` even (a controller that listens
//! forever) the first gives the exact value. Where the bounds' ratio foretells many sweeps (a
//! chain slow to forget its start, or with several closed classes), stabilised bi-conjugate
//! gradients (van der Vorst 1992), each answer checked by a sweep; where they break down or
//! stall, sweeps again from their last answer. At a finite horizon, as many sweeps of backward
//! induction. The chain is numbered in the order it is met, so two controllers that act alike on
//! what they reach get the same value, bit for bit, however their nodes are numbered.

use crate::exact::MAX_STEPS;
use crate::policy::controller::Controller;
use crate::world::pomdp::Tables;

/// A tabular world's transitions and observations apart: `T(s'|s,a)` as the successors of each
/// `(s, a)`, `O(o|a,s')` as the observations of each `(a, s')`, those of positive probability.
#[derive(Debug)]
pub struct Factored {
    /// `t_row[s·A + a] .. t_row[s·A + a + 1]`: the next states of `(s, a)` and their chances.
    t_row: Vec<usize>,
    t_to: Vec<u32>,
    t_prob: Vec<f64>,
    /// `o_row[a·S + s'] .. o_row[a·S + s' + 1]`: the observations of `(a, s')`, their chances.
    o_row: Vec<usize>,
    o_of: Vec<u32>,
    o_prob: Vec<f64>,
    /// Whether the factors pay: whether the outcomes `(s', o)` of a pair are more, on average,
    /// than its next states and the observations of an after-state (where not, as in a world
    /// whose observations are nearly certain, the chain is kept as the world's outcomes).
    pays: bool,
}

impl Factored {
    /// The factors of `t`'s outcomes: a next state where an outcome of `(s, a)` reaches it.
    pub fn new(t: &Tables) -> Factored {
        let (n_s, n_a, n_o) = (t.n_states(), t.n_actions(), t.n_observations());
        let pomdp = &t.pomdp;
        let (mut t_row, mut t_to, mut t_prob) = (vec![0], Vec::new(), Vec::new());
        for s in 0..n_s {
            for a in 0..n_a {
                // The outcomes of `(s, a)` are grouped by next state.
                let mut last = u32::MAX;
                for k in t.outcomes(s, a) {
                    let s2 = t.next[k].0;
                    if s2 != last {
                        t_to.push(s2);
                        t_prob.push(pomdp.transition[(a * n_s + s) * n_s + s2 as usize]);
                        last = s2;
                    }
                }
                t_row.push(t_to.len());
            }
        }
        let (mut o_row, mut o_of, mut o_prob) = (vec![0], Vec::new(), Vec::new());
        for row in pomdp.observation.chunks(n_o.max(1)).take(n_a * n_s) {
            for (o, &p) in row.iter().enumerate() {
                if p > 0.0 {
                    o_of.push(o as u32);
                    o_prob.push(p);
                }
            }
            o_row.push(o_of.len());
        }
        let (joint, rows) = (t.next.len() as f64, (n_s * n_a).max(1) as f64);
        let pays = joint / rows > (t_to.len() + o_of.len()) as f64 / rows;
        Factored { t_row, t_to, t_prob, o_row, o_of, o_prob, pays }
    }
}

/// Scratch space of a controller's value: its chain and the solver's vectors, reused from one
/// controller to the next.
#[derive(Clone, Debug, Default)]
pub struct Scratch {
    /// `1 +` the number of pair `(s, q)` at `s·n + q`; 0 where not reached.
    index: Vec<u32>,
    /// `1 +` the number of after-state `(s', q)` at `s'·n + q`; 0 where not reached.
    after_index: Vec<u32>,
    /// The reached pairs `(s, q)`, in the order met.
    pairs: Vec<(u32, u32)>,
    /// Each pair's expected immediate reward.
    reward: Vec<f64>,
    /// Each pair's after-states `to[row[i]..row[i + 1]]`, with their chances `prob` (`T`).
    row: Vec<usize>,
    to: Vec<u32>,
    prob: Vec<f64>,
    /// Each after-state's pairs `after_to[after_row[j]..after_row[j + 1]]`, with their chances
    /// `after_prob` (`O`, summed over the observations that lead to one node).
    after_row: Vec<usize>,
    after_to: Vec<u32>,
    after_prob: Vec<f64>,
    /// Whether the pairs' rows lead to pairs, the world's outcomes (no after-states).
    direct: bool,
    /// The values of the after-states in a product by `P`.
    w: Vec<f64>,
    /// The solver's vectors, one entry a pair.
    vectors: [Vec<f64>; 7],
}

impl Scratch {
    /// The value of the Moore controller `c` on `t` from its start law: at `horizon`, or in the
    /// infinite horizon (`None`) to `tolerance` (see the module's documentation).
    pub fn value(&mut self, t: &Tables, f: &Factored, c: &Controller, horizon: Option<usize>, tolerance: f64) -> f64 {
        self.evaluate(t, f, c, horizon, tolerance, MAX_GRADIENTS)
    }

    /// [`Scratch::value`] with at most `gradients` steps of the gradients before the sweeps.
    fn evaluate(
        &mut self,
        t: &Tables,
        f: &Factored,
        c: &Controller,
        horizon: Option<usize>,
        tolerance: f64,
        gradients: usize,
    ) -> f64 {
        self.reach(t, f, c);
        let m = self.pairs.len();
        let gamma = t.gamma;
        let mut vectors = std::mem::take(&mut self.vectors);
        for v in &mut vectors {
            v.clear();
            v.resize(m, 0.0);
        }
        let [x, next, ..] = &mut vectors;
        let shift = match horizon {
            Some(h) => {
                for _ in 0..h {
                    self.sweep(gamma, x, next);
                    std::mem::swap(x, next);
                }
                0.0
            }
            None => self.solve(gamma, tolerance, &mut vectors, gradients),
        };
        let x = &vectors[0];
        let (n, first) = (c.nodes(), c.next[t.n_observations()] as usize);
        let value = t
            .start
            .iter()
            .enumerate()
            .filter(|&(_, &p)| p > 0.0)
            .map(|(s, &p)| p * x[self.index[s * n + first] as usize - 1])
            .sum::<f64>();
        self.vectors = vectors;
        value + shift
    }

    /// Numbers the pairs and after-states `c` reaches from the start and lays out their rows.
    fn reach(&mut self, t: &Tables, f: &Factored, c: &Controller) {
        let (n, y1, n_s, n_a) = (c.nodes(), t.n_observations() + 1, t.n_states(), t.n_actions());
        self.direct = !f.pays;
        let Scratch { index, after_index, pairs, reward, row, to, prob, after_row, after_to, after_prob, .. } = self;
        index.clear();
        index.resize(n_s * n, 0);
        after_index.clear();
        after_index.resize(if f.pays { n_s * n } else { 0 }, 0);
        pairs.clear();
        reward.clear();
        for v in [&mut *row, &mut *after_row] {
            v.clear();
            v.push(0);
        }
        for v in [&mut *to, &mut *after_to] {
            v.clear();
        }
        for v in [&mut *prob, &mut *after_prob] {
            v.clear();
        }
        let number = |s: u32, q: u32, index: &mut Vec<u32>, pairs: &mut Vec<(u32, u32)>| {
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
                number(s as u32, first, index, pairs);
            }
        }
        let mut i = 0;
        while i < pairs.len() {
            let (s, q) = (pairs[i].0 as usize, pairs[i].1 as usize);
            let a = c.act[q] as usize;
            reward.push(t.expected_reward(s, a));
            if f.pays {
                for e in f.t_row[s * n_a + a]..f.t_row[s * n_a + a + 1] {
                    let s2 = f.t_to[e];
                    let slot = &mut after_index[s2 as usize * n + q];
                    if *slot == 0 {
                        // A new after-state: its row now, the pairs it reaches numbered.
                        let start = after_to.len();
                        for k in f.o_row[a * n_s + s2 as usize]..f.o_row[a * n_s + s2 as usize + 1] {
                            let to_pair = number(s2, c.next[q * y1 + f.o_of[k] as usize], index, pairs);
                            merge(after_to, after_prob, start, to_pair, f.o_prob[k]);
                        }
                        after_row.push(after_to.len());
                        *slot = (after_row.len() - 1) as u32;
                    }
                    to.push(*slot - 1);
                    prob.push(f.t_prob[e]);
                }
            } else {
                // The world's outcomes, merged where they lead to one pair.
                let start = to.len();
                for k in t.outcomes(s, a) {
                    let (s2, o) = t.next[k];
                    let to_pair = number(s2, c.next[q * y1 + o as usize], index, pairs);
                    merge(to, prob, start, to_pair, t.prob[k]);
                }
            }
            row.push(to.len());
            i += 1;
        }
    }

    /// `y = P x`.
    fn step(&mut self, x: &[f64], y: &mut [f64]) {
        let Scratch { row, to, prob, after_row, after_to, after_prob, w, direct, .. } = self;
        let product = |r: &[usize], to: &[u32], prob: &[f64], x: &[f64]| {
            let (to, prob) = (to[r[0]..r[1]].chunks_exact(2), prob[r[0]..r[1]].chunks_exact(2));
            let tail: f64 = to.remainder().iter().zip(prob.remainder()).map(|(&k, &p)| p * x[k as usize]).sum();
            let (a, b) = to
                .zip(prob)
                .fold((0.0, 0.0), |(a, b), (k, p)| (a + p[0] * x[k[0] as usize], b + p[1] * x[k[1] as usize]));
            (a + b) + tail
        };
        let w = if *direct {
            x
        } else {
            w.clear();
            w.extend(after_row.windows(2).map(|r| product(r, after_to, after_prob, x)));
            w
        };
        for (y, r) in y.iter_mut().zip(row.windows(2)) {
            *y = product(r, to, prob, w);
        }
    }

    /// One sweep from `x` into `x` (its old values left in `next`) under the bounds of `MacQueen`:
    /// half the bounds' interval and their middle, the shift to add to each value.
    fn bounded_sweep(&mut self, gamma: f64, x: &mut Vec<f64>, next: &mut Vec<f64>) -> (f64, f64) {
        let factor = gamma / (1.0 - gamma);
        let (low, high) = self.sweep(gamma, x, next);
        std::mem::swap(x, next);
        (factor * (high - low) / 2.0, factor * (low + high) / 2.0)
    }

    /// One sweep `next = r + γPx`; returns the least and the greatest of `next − x`.
    fn sweep(&mut self, gamma: f64, x: &[f64], next: &mut [f64]) -> (f64, f64) {
        self.step(x, next);
        let (mut low, mut high) = (f64::INFINITY, f64::NEG_INFINITY);
        for ((y, &r), &x) in next.iter_mut().zip(&self.reward).zip(x) {
            *y = r + gamma * *y;
            low = low.min(*y - x);
            high = high.max(*y - x);
        }
        (low, high)
    }

    /// Solves `(I − γP) x = r` into `vectors[0]` to `tolerance` under the bounds of `MacQueen`;
    /// returns the shift to add to each value (the middle of the bounds). Sweeps first: where
    /// the bounds close fast (a chain that forgets its start quickly) they are the cheapest; where
    /// the bounds' last ratio foresees more than [`SWEEPS_BEFORE_GRADIENTS`] sweeps to go, at most
    /// `most` steps of the gradients, then sweeps again from their answer.
    fn solve(&mut self, gamma: f64, tolerance: f64, vectors: &mut [Vec<f64>; 7], most: usize) -> f64 {
        let (mut last, mut tried, mut shift) = (f64::INFINITY, most == 0, 0.0);
        for k in 0..MAX_STEPS {
            let [x, next, ..] = &mut *vectors;
            let half;
            (half, shift) = self.bounded_sweep(gamma, x, next);
            if half <= tolerance {
                break;
            }
            let ratio = half / last;
            last = half;
            if !tried && k >= 2 && (ratio >= 1.0 || (tolerance / half).ln() / ratio.ln() > SWEEPS_BEFORE_GRADIENTS) {
                tried = true;
                if let Some(shift) = self.gradients(gamma, tolerance, vectors, most) {
                    return shift;
                }
                if vectors[0].iter().any(|v| !v.is_finite()) {
                    vectors[0].fill(0.0);
                }
                last = f64::INFINITY;
            }
        }
        shift
    }

    /// At most `most` steps of the gradients from `vectors[0]`, restarted from each answer
    /// checked by a sweep and found short; the shift of the bounds once one holds.
    fn gradients(&mut self, gamma: f64, tolerance: f64, vectors: &mut [Vec<f64>; 7], most: usize) -> Option<f64> {
        let factor = gamma / (1.0 - gamma);
        let [x, next, res, rhat, p, v, s] = vectors;
        // The answer `x` holds where one sweep from it moves every value alike, to the tolerance.
        let check = |me: &mut Scratch, x: &mut Vec<f64>, next: &mut Vec<f64>| {
            let (half, shift) = me.bounded_sweep(gamma, x, next);
            (half <= tolerance).then_some(shift)
        };
        let apply = |me: &mut Scratch, from: &[f64], to: &mut [f64]| {
            me.step(from, to);
            for (y, &x) in to.iter_mut().zip(from) {
                *y = x - gamma * *y;
            }
        };
        let mut steps = 0;
        'restart: for _ in 0..8 {
            // The residual of the answer `x`.
            apply(self, x, res);
            for (r, &b) in res.iter_mut().zip(&self.reward) {
                *r = b - *r;
            }
            rhat.clone_from(res);
            p.fill(0.0);
            v.fill(0.0);
            let (mut rho, mut alpha, mut omega) = (1.0, 1.0, 1.0);
            loop {
                steps += 1;
                if steps > most {
                    return None;
                }
                let rho_next = dot(rhat, res);
                let beta = (rho_next / rho) * (alpha / omega);
                if !beta.is_finite() || rho_next == 0.0 {
                    continue 'restart;
                }
                rho = rho_next;
                for ((p, &r), &v) in p.iter_mut().zip(res.iter()).zip(v.iter()) {
                    *p = r + beta * (*p - omega * v);
                }
                apply(self, p, v);
                alpha = rho / dot(rhat, v);
                if !alpha.is_finite() {
                    continue 'restart;
                }
                for ((s, &r), &v) in s.iter_mut().zip(res.iter()).zip(v.iter()) {
                    *s = r - alpha * v;
                }
                // `res` holds `A s` (the residual is `s` until it is updated below).
                apply(self, s, res);
                let (ts, tt) = (dot(res, s), dot(res, res));
                omega = if tt > 0.0 { ts / tt } else { 0.0 };
                for ((x, &p), &s) in x.iter_mut().zip(p.iter()).zip(s.iter()) {
                    *x += alpha * p + omega * s;
                }
                for (r, &s) in res.iter_mut().zip(s.iter()) {
                    *r = s - omega * *r;
                }
                let (low, high) = range(res);
                if factor * (high - low) / 2.0 <= tolerance || omega == 0.0 || !omega.is_finite() {
                    if let Some(shift) = check(self, x, next) {
                        return Some(shift);
                    }
                    continue 'restart;
                }
            }
        }
        None
    }
}

/// Adds `p` to the chance of `k` in the row `to[start..]`, `prob[start..]` (a new entry where `k`
/// is not there yet).
fn merge(to: &mut Vec<u32>, prob: &mut Vec<f64>, start: usize, k: u32, p: f64) {
    if let Some(at) = to[start..].iter().position(|&x| x == k) {
        prob[start + at] += p;
    } else {
        to.push(k);
        prob.push(p);
    }
}

/// `a · b`, summed in four lanes (a sum in one is as slow as its chain of additions).
fn dot(a: &[f64], b: &[f64]) -> f64 {
    let mut lanes = [0.0; 4];
    let (a4, b4) = (a.chunks_exact(4), b.chunks_exact(4));
    let tail: f64 = a4.remainder().iter().zip(b4.remainder()).map(|(a, b)| a * b).sum();
    for (a, b) in a4.zip(b4) {
        for k in 0..4 {
            lanes[k] += a[k] * b[k];
        }
    }
    (lanes[0] + lanes[1]) + (lanes[2] + lanes[3]) + tail
}

/// The least and the greatest of `r`, in four lanes.
fn range(r: &[f64]) -> (f64, f64) {
    let (mut low, mut high) = ([f64::INFINITY; 4], [f64::NEG_INFINITY; 4]);
    let r4 = r.chunks_exact(4);
    let (mut l, mut h) =
        r4.remainder().iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &x| (l.min(x), h.max(x)));
    for x in r4 {
        for k in 0..4 {
            low[k] = low[k].min(x[k]);
            high[k] = high[k].max(x[k]);
        }
    }
    for k in 0..4 {
        (l, h) = (l.min(low[k]), h.max(high[k]));
    }
    (l, h)
}

/// The sweeps still to go, foreseen from the bounds' last ratio, beyond which the gradients
/// take over (a step of the gradients costs two products by `P`, a sweep one; the gradients
/// take a few dozen steps at `γ = 0.95`).
const SWEEPS_BEFORE_GRADIENTS: f64 = 40.0;

/// The most steps of the gradients before sweeps take over.
const MAX_GRADIENTS: usize = 2_000;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::{Purpose, stream};
    use crate::world::pomdp::PomdpWorld;
    use rand::RngExt;

    #[test]
    fn the_gradients_and_the_sweeps_agree_within_the_tolerance() {
        for (name, n) in [("hallway.POMDP", 16), ("network.POMDP", 4), ("4x3.95.POMDP", 8), ("tiger.95.POMDP", 3)] {
            let path = format!("{}/../../data/pomdp/{name}", env!("CARGO_MANIFEST_DIR"));
            let world = PomdpWorld::from_file(path, 100, None).unwrap();
            let t = world.tables();
            let f = Factored::new(t);
            // The factors pay where the observations are noisy.
            assert_eq!(f.pays, name == "hallway.POMDP", "{name}");
            let (y1, n_a) = (t.n_observations() + 1, t.n_actions());
            for k in 0..3 {
                let mut rng = stream(3, Purpose::Evaluate, k, n as u64);
                let c = Controller::moore(
                    (0..n).map(|_| rng.random_range(0..n_a as u32)).collect(),
                    (0..n * y1).map(|_| rng.random_range(0..n as u32)).collect(),
                );
                let mut scratch = Scratch::default();
                let tight = scratch.evaluate(t, &f, &c, None, 1e-10, 0);
                for tolerance in [1e-3, 1e-6] {
                    let gradients = scratch.value(t, &f, &c, None, tolerance);
                    let sweeps = scratch.evaluate(t, &f, &c, None, tolerance, 0);
                    for v in [gradients, sweeps] {
                        assert!((v - tight).abs() <= tolerance, "{name} {k} at {tolerance}: {v} vs {tight}");
                    }
                }
            }
        }
    }
}
