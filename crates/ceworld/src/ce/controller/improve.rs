//! Node by node improvement of a Moore controller on a discounted tabular world (model §8): each
//! node's decision and successors replaced by the best ones for the states the controller brings
//! it, against the controller's own values, and kept only where the exact value rises.
//!
//! With `V(q, s)` the controller's value from node `q` in state `s` and `w(q, s)` its discounted
//! occupancy from the start (how much of the value is earned in `(s, q)`), node `q`'s row is
//! scored `Σ_s w(q, s) [r(s, a) + γ Σ_{s', y} T(s'|s, a) O(y|a, s') V(σ(y), s')]` for each
//! decision `a`, with its successor `σ(y)` after each observation `y` the best for the mix of
//! states the node stands for, and with the node's own successors kept, as in Hansen's policy
//! iteration for controllers, without adding nodes. A row's score over the present row's is the
//! first-order gain of the start's value (the performance difference); the rows are tried
//! largest gain first. The score is a guide, not a guarantee (the other nodes' values were
//! computed with the old row), so a new row is kept only where the controller's exact value from
//! the start rises by more than the tolerance, one a pass.

use super::{ControllerValue, Scratch};
use crate::policy::controller::Controller;
use crate::world::pomdp::{PomdpWorld, Tables};

/// Sweeps of the node values and the occupancies at most (each at least contracts by `γ`).
const SWEEPS: usize = 2000;

/// The node values and occupancies only guide the choice of a row (each new row is held to the
/// exact value), so they stop at this fraction of the spread of the values, `(max r − min r) /
/// (1 − γ)`, rather than at the tolerance.
const GUIDE: f64 = 1e-6;

/// `V(q, s)` at `q·S + s`: Gauss–Seidel sweeps of the controller's Bellman equation from `v` (the
/// values before a change: a warm start) until the largest change is below `guide·(1 − γ)`; the
/// sweeps done.
fn node_values(t: &Tables, c: &Controller, guide: f64, v: &mut Vec<f64>) -> usize {
    let (n, n_s, y1) = (c.nodes(), t.n_states(), t.n_observations() + 1);
    v.resize(n * n_s, 0.0);
    for sweep in 1..=SWEEPS {
        let mut change: f64 = 0.0;
        for q in 0..n {
            let a = c.act[q] as usize;
            for s in 0..n_s {
                let mut x = t.expected_reward(s, a);
                for j in t.outcomes(s, a) {
                    let (s2, o) = t.next[j];
                    let q2 = c.next[q * y1 + o as usize] as usize;
                    x += t.gamma * t.prob[j] * v[q2 * n_s + s2 as usize];
                }
                change = change.max((x - v[q * n_s + s]).abs());
                v[q * n_s + s] = x;
            }
        }
        if change <= guide * (1.0 - t.gamma) {
            return sweep;
        }
    }
    SWEEPS
}

/// `w(q, s)` at `q·S + s`: `Σ_t γ^t P(s_t = s, q_t = q)` from the start law and the controller's
/// first node, the fixed point of `w = start + γ Pᵀ w` by sweeps from `w` (a warm start).
fn occupancy(t: &Tables, c: &Controller, guide: f64, w: &mut Vec<f64>) -> usize {
    let (n, n_s, y1) = (c.nodes(), t.n_states(), t.n_observations() + 1);
    let first = c.next[y1 - 1] as usize;
    w.resize(n * n_s, 0.0);
    let mut next = vec![0.0; n * n_s];
    for sweep in 1..=SWEEPS {
        next.fill(0.0);
        next[first * n_s..(first + 1) * n_s].copy_from_slice(&t.start);
        for q in 0..n {
            let a = c.act[q] as usize;
            for s in 0..n_s {
                let m = w[q * n_s + s];
                if m > 0.0 {
                    for j in t.outcomes(s, a) {
                        let (s2, o) = t.next[j];
                        let q2 = c.next[q * y1 + o as usize] as usize;
                        next[q2 * n_s + s2 as usize] += t.gamma * m * t.prob[j];
                    }
                }
            }
        }
        let change = next.iter().zip(w.iter()).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max);
        std::mem::swap(w, &mut next);
        if change <= guide * (1.0 - t.gamma) {
            return sweep;
        }
    }
    SWEEPS
}

/// What decision `a` leads to from a node whose states weigh `w`: the weighted expected reward,
/// the weight of each next state that can follow, by observation, and the work of it in
/// multiply-adds.
struct Successors {
    reward: f64,
    after: Vec<Vec<(usize, f64)>>,
    work: f64,
}

impl Successors {
    fn of(t: &Tables, w: &[f64], a: usize) -> Successors {
        let mut after: Vec<Vec<(usize, f64)>> = vec![Vec::new(); t.n_observations()];
        let (mut reward, mut work) = (0.0, 0.0);
        for (s, &ws) in w.iter().enumerate() {
            if ws > 0.0 {
                reward += ws * t.expected_reward(s, a);
                for j in t.outcomes(s, a) {
                    let (s2, o) = t.next[j];
                    after[o as usize].push((s2 as usize, ws * t.prob[j]));
                }
                work += t.outcomes(s, a).len() as f64;
            }
        }
        Successors { reward, after, work }
    }

    /// The score of the row that takes this decision: its reward and discounted value after
    /// each observation, with the node's successors `kept` or (with `choose`) the best for each
    /// observation that can follow (the others keep theirs); `(score, σ, work)`, the work counted
    /// with the successors' own, as for a row scored alone.
    fn score(&self, t: &Tables, v: &[f64], kept: &[u32], choose: bool) -> (f64, Vec<u32>, f64) {
        let (n_s, n) = (t.n_states(), v.len() / t.n_states());
        let value_at =
            |row: &[(usize, f64)], q2: usize| -> f64 { row.iter().map(|&(s2, p)| p * v[q2 * n_s + s2]).sum() };
        let (mut score, mut work) = (self.reward, self.work);
        let mut to = kept.to_vec();
        for (y, row) in self.after.iter().enumerate() {
            if row.is_empty() {
                continue;
            }
            let (best, at) = if choose {
                work += (row.len() * n) as f64;
                (0..n)
                    .map(|q2| (value_at(row, q2), q2))
                    .fold((f64::NEG_INFINITY, 0), |top, x| if x.0 > top.0 { x } else { top })
            } else {
                (value_at(row, kept[y] as usize), kept[y] as usize)
            };
            score += t.gamma * best;
            to[y] = at as u32;
        }
        (score, to, work)
    }
}

/// `c` improved node by node until no node's new row raises its exact value by more than
/// `tolerance`, or `work` multiply-adds are spent (counted, not timed, so the result is the same
/// on every machine; checked before each row tried and each pass): the controller and its exact
/// value.
pub fn improve(world: &PomdpWorld, c: &Controller, tolerance: f64, work: f64) -> (Controller, f64) {
    let t = world.tables();
    let values = ControllerValue::new(world, tolerance);
    let mut scratch = Scratch::default();
    let mut c = if c.is_mealy() { c.to_moore(t.n_observations() + 1) } else { c.clone() };
    let mut value = values.value(&c, &mut scratch);
    let (n, n_s, n_y, y1) = (c.nodes(), t.n_states(), t.n_observations(), t.n_observations() + 1);
    let (lo, hi) = (0..n_s)
        .flat_map(|s| (0..t.n_actions()).map(move |a| (s, a)))
        .map(|(s, a)| t.expected_reward(s, a))
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), r| (lo.min(r), hi.max(r)));
    let guide = GUIDE * (hi - lo).max(tolerance) / (1.0 - t.gamma);
    // A sweep, a row's choice, an exact value (taken as a few sweeps), in multiply-adds.
    let outcomes = t.next.len() as f64 / t.n_actions() as f64;
    let sweep = n as f64 * outcomes;
    let mut spent = 0.0;
    let (mut v, mut w) = (Vec::new(), Vec::new());
    let measure = |c: &Controller, v: &mut Vec<f64>, w: &mut Vec<f64>| {
        (node_values(t, c, guide, v) + occupancy(t, c, guide, w)) as f64 * sweep
    };
    spent += measure(&c, &mut v, &mut w);
    while spent < work {
        // Each node's best row and its first-order gain (the performance difference at the
        // current occupancies), the largest tried first.
        let mut rows: Vec<(f64, usize, usize, Vec<u32>)> = Vec::new();
        for q in 0..n {
            let wq = &w[q * n_s..(q + 1) * n_s];
            if wq.iter().all(|&x| x <= 0.0) {
                continue;
            }
            let kept = &c.next[q * y1..q * y1 + n_y];
            // Each decision's successors once, for every row that takes it.
            let by_action: Vec<Successors> = (0..t.n_actions()).map(|a| Successors::of(t, wq, a)).collect();
            let (now, _, cost) = by_action[c.act[q] as usize].score(t, &v, kept, false);
            spent += cost;
            // For each decision, its best successors, and the node's own kept: a row best by
            // the first order may fail where the next one would have held.
            for (a, successors) in by_action.iter().enumerate() {
                for choose in [true, false] {
                    let (score, to, cost) = successors.score(t, &v, kept, choose);
                    spent += cost;
                    if score > now {
                        rows.push((score - now, q, a, to));
                    }
                }
            }
        }
        rows.sort_by(|x, y| y.0.total_cmp(&x.0).then(x.1.cmp(&y.1)));
        // Tried in that order, the first that raises the exact value kept (the others were
        // scored against values it makes stale).
        let mut raised = false;
        for (_, q, a, to) in rows {
            if spent >= work {
                break;
            }
            let mut tried = c.clone();
            tried.act[q] = a as u32;
            tried.next[q * y1..q * y1 + n_y].copy_from_slice(&to);
            let x = values.value(&tried, &mut scratch);
            spent += 40.0 * sweep;
            if x > value + tolerance {
                (c, value, raised) = (tried, x, true);
                break;
            }
        }
        if !raised {
            break;
        }
        spent += measure(&c, &mut v, &mut w);
    }
    (c, value)
}

#[cfg(test)]
mod tests {
    // The slower tests of `improve` (random controllers, tiger-grid's start) are in
    // tests/controller_search.rs, out of the unit tests that mutation testing runs.
    use super::*;

    fn world(name: &str) -> PomdpWorld {
        PomdpWorld::from_file(format!("{}/../../data/pomdp/{name}", env!("CARGO_MANIFEST_DIR")), 100, None).unwrap()
    }

    fn exact(w: &PomdpWorld, c: &Controller) -> f64 {
        ControllerValue::new(w, 1e-6).value(c, &mut Scratch::default())
    }

    #[test]
    fn tigers_counting_controller_is_mended_by_hand() {
        // Listen (0) until two more growls came from one side (observation 0: left) than from
        // the other, then open the other door (2: right, 1: left): nodes 0 (even), 1 and 2 (one
        // more left or right), 3 and 4 (two more); 19.3714 (SARSOP [19.3711, 19.3721]).
        let w = world("tiger.95.POMDP");
        let next = vec![1, 2, 0, 3, 0, 0, 0, 4, 0, 0, 0, 0, 0, 0, 0];
        let optimum = Controller::moore(vec![0, 0, 0, 2, 1], next.clone());
        assert!((exact(&w, &optimum) - 19.3714).abs() < 1e-3, "{}", exact(&w, &optimum));
        // Opening the wrong doors (and listening once too often) is undone.
        let wrong = Controller::moore(vec![0, 0, 0, 1, 0], next);
        let (mended, value) = improve(&w, &wrong, 1e-6, 1e9);
        assert!(exact(&w, &wrong) < 0.0);
        assert!((value - exact(&w, &optimum)).abs() < 1e-6, "{value} {mended:?}");
        assert_eq!(mended.act, optimum.act);
        // The optimum is left as it is.
        assert_eq!(improve(&w, &optimum, 1e-6, 1e9).0, optimum);
    }
}
