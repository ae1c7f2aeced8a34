//! A controller built from a tabular world's model (model §8, the model start): point-based
//! value iteration over beliefs met on the way (Perseus: Spaan & Vlassis, JAIR 2005), its
//! α-vectors made into a finite-state controller.
//!
//! Beliefs are collected on walks from the start belief (Bayes filter, model §7), each step the
//! QMDP decision or, as often, a random one. The first vectors are the blind policies' values.
//! Each stage backs up the value at beliefs drawn in turn, keeping a backup only where it raises
//! its own belief's value, until every belief's value has improved or stayed; an α-vector is the
//! value of "take its decision, then continue as the vector chosen for each observation". The
//! work is counted, not timed ([`Budget`]), so the result is the same on every machine.
//!
//! The controller keeps the (at most `most`) vectors best at the most beliefs met on walks of
//! their greedy policy: a node per vector, its decision the vector's, and after observation `y`
//! the node of the kept vector best at the belief that follows the mean of the beliefs the node
//! stands for. Its first node is the kept vector best at the start belief.

use rand::RngExt;

use crate::policy::controller::Controller;
use crate::rng::{EngineRng, Purpose, stream};
use crate::world::pomdp::{PomdpWorld, Tables};

/// How much work the model start does.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Budget {
    /// Beliefs collected.
    pub beliefs: usize,
    /// Steps of a random walk before it starts again from the start belief.
    pub walk: usize,
    /// At most this many stages of backups.
    pub stages: usize,
    /// At most this much work (checked between stages), counted in multiply-adds: a backup
    /// costs `|A|·|O|·|V|·|S|` (the best vector for each decision and observation), a new vector
    /// `|B|·|S|`. Counted rather than timed, so that the start is the same on every machine.
    pub work: f64,
}

impl Default for Budget {
    fn default() -> Self {
        Budget { beliefs: 500, walk: 40, stages: 300, work: 2e10 }
    }
}

impl Budget {
    /// The default budget, cut to about a tenth of `seconds` where given (at `1e9` of work a
    /// second, about what one core does).
    pub fn within(seconds: Option<f64>) -> Budget {
        let work = seconds.map_or(Budget::default().work, |s| (s * 1e8).min(Budget::default().work));
        Budget { work, ..Budget::default() }
    }
}

/// A value function over beliefs, as vectors (the value at a belief is the best dot product).
#[derive(Clone, Debug)]
pub struct PointBased {
    /// The beliefs the backups were made at.
    pub beliefs: Vec<Vec<f64>>,
    /// The α-vectors.
    pub alphas: Vec<Alpha>,
    /// Stages of backups done.
    pub stages: usize,
    /// Work done (see [`Budget::work`]).
    pub work: f64,
}

/// One α-vector: its values per state, its decision, and the belief it was backed up at.
#[derive(Clone, Debug)]
pub struct Alpha {
    /// The value of each state.
    pub values: Vec<f64>,
    /// The decision taken first.
    pub action: usize,
    /// Index into [`PointBased::beliefs`] (the start belief is index 0).
    pub witness: usize,
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// The index of the best of `alphas` at `belief` (the first of equals).
fn best(alphas: &[&Alpha], belief: &[f64]) -> (usize, f64) {
    let mut top = (0, f64::NEG_INFINITY);
    for (k, alpha) in alphas.iter().enumerate() {
        let v = dot(&alpha.values, belief);
        if v > top.1 {
            top = (k, v);
        }
    }
    top
}

/// The unnormalised beliefs after `a` and each observation from `belief`: `[o][s']`.
fn successors(t: &Tables, belief: &[f64], a: usize, out: &mut [Vec<f64>]) {
    for row in out.iter_mut() {
        row.fill(0.0);
    }
    for (s, &b) in belief.iter().enumerate() {
        if b > 0.0 {
            for j in t.outcomes(s, a) {
                let (s2, o) = t.next[j];
                out[o as usize][s2 as usize] += b * t.prob[j];
            }
        }
    }
}

impl PointBased {
    /// Point-based value iteration on `world` within `budget`, its randomness drawn from `seed`.
    pub fn solve(world: &PomdpWorld, budget: Budget, seed: u64) -> PointBased {
        let t = world.tables();
        let beliefs = collect(t, budget, seed);
        let n_s = t.n_states();
        // The blind policies ("always a") as the first vectors: a lower bound far above the
        // floor `min r / (1 − γ)` where γ is near 1.
        let alphas = (0..t.n_actions()).map(|a| Alpha { values: blind(t, a), action: a, witness: 0 }).collect();
        let mut solved = PointBased { beliefs, alphas, stages: 0, work: 0.0 };
        let mut rng = stream(seed, Purpose::Init, 2, 0);
        let mut scratch = vec![vec![0.0; n_s]; t.n_observations()];
        while solved.stages < budget.stages && solved.work < budget.work {
            let gain = solved.stage(t, &mut rng, &mut scratch);
            solved.stages += 1;
            if gain <= 1e-9 {
                break;
            }
        }
        solved
    }

    /// One Perseus stage; the largest gain of value at a belief. A backup that does not raise
    /// the value at its own belief is left out (rather than the old best vector put in, which
    /// would end the stage while other beliefs could still gain); the beliefs no new vector
    /// covers keep their old best one. So a stage without gain has backed up at every belief:
    /// the value has converged on them.
    fn stage(&mut self, t: &Tables, rng: &mut EngineRng, scratch: &mut [Vec<f64>]) -> f64 {
        let old: Vec<&Alpha> = self.alphas.iter().collect();
        let before: Vec<f64> = self.beliefs.iter().map(|b| best(&old, b).1).collect();
        let mut after = vec![f64::NEG_INFINITY; self.beliefs.len()];
        let mut new: Vec<Alpha> = Vec::new();
        let mut todo: Vec<usize> = (0..self.beliefs.len()).collect();
        let (n_s, n_b) = (t.n_states() as f64, self.beliefs.len() as f64);
        let backup_work = (t.n_actions() * t.n_observations() * old.len()) as f64 * n_s;
        let keep = |alpha: Alpha, new: &mut Vec<Alpha>, after: &mut [f64]| {
            for (k, b) in self.beliefs.iter().enumerate() {
                after[k] = after[k].max(dot(&alpha.values, b));
            }
            new.push(alpha);
        };
        while !todo.is_empty() {
            let i = todo.swap_remove(rng.random_range(0..todo.len()));
            self.work += backup_work;
            let mut alpha = backup(t, &old, &self.beliefs[i], scratch);
            alpha.witness = i;
            if dot(&alpha.values, &self.beliefs[i]) > before[i] + 1e-12 * before[i].abs().max(1.0) {
                keep(alpha, &mut new, &mut after);
                todo.retain(|&k| after[k] < before[k]);
            }
        }
        let gain = after.iter().zip(&before).map(|(a, b)| a - b).fold(0.0, f64::max);
        for k in 0..self.beliefs.len() {
            if after[k] < before[k] {
                keep(old[best(&old, &self.beliefs[k]).0].clone(), &mut new, &mut after);
            }
        }
        self.work += new.len() as f64 * n_b * n_s;
        self.alphas = new;
        gain
    }

    /// The controller the vectors make (module docs), of at most `most` nodes: walks of the
    /// greedy policy give the beliefs each kept vector stands for.
    pub fn controller(&self, world: &PomdpWorld, most: usize, seed: u64) -> Controller {
        let t = world.tables();
        let (n_o, y1, n_s) = (t.n_observations(), t.n_observations() + 1, t.n_states());
        let all: Vec<&Alpha> = self.alphas.iter().collect();
        let visited = walk(t, &all, 64, 40, seed);
        let mut wins = vec![0usize; all.len()];
        for b in &visited {
            wins[best(&all, b).0] += 1;
        }
        let first = best(&all, &t.start).0;
        let mut order: Vec<usize> = (0..all.len()).filter(|&k| k != first && wins[k] > 0).collect();
        order.sort_by(|&i, &j| wins[j].cmp(&wins[i]).then(i.cmp(&j)));
        order.insert(0, first);
        order.truncate(most.max(1));
        let kept: Vec<&Alpha> = order.iter().map(|&k| all[k]).collect();
        // Each node's belief: the mean of the beliefs met where its vector is the best kept one
        // (its witness where none is).
        let mut centre = vec![vec![0.0; n_s]; kept.len()];
        let mut count = vec![0usize; kept.len()];
        for b in &visited {
            let q = best(&kept, b).0;
            count[q] += 1;
            centre[q].iter_mut().zip(b).for_each(|(c, p)| *c += p);
        }
        for (q, c) in centre.iter_mut().enumerate() {
            if count[q] == 0 {
                c.clone_from(&self.beliefs[kept[q].witness]);
            }
        }
        let mut act = Vec::with_capacity(kept.len());
        let mut next = Vec::with_capacity(kept.len() * y1);
        let mut scratch = vec![vec![0.0; n_s]; n_o];
        for k in 0..kept.len() {
            act.push(kept[k].action as u32);
            successors(t, &centre[k], kept[k].action, &mut scratch);
            for belief in &scratch {
                let to = if belief.iter().any(|&p| p > 0.0) { best(&kept, belief).0 } else { k };
                next.push(to as u32);
            }
            next.push(0);
        }
        Controller::moore(act, next)
    }
}

/// The value of always taking `a` (Jacobi sweeps, stopped by the bounds of `MacQueen` as in
/// [`crate::ce::controller::ControllerValue`], the lower bound returned).
fn blind(t: &Tables, a: usize) -> Vec<f64> {
    let n_s = t.n_states();
    let (mut v, mut w) = (vec![0.0; n_s], vec![0.0; n_s]);
    let factor = if t.gamma < 1.0 { t.gamma / (1.0 - t.gamma) } else { 0.0 };
    let scale = (0..n_s).map(|s| t.expected_reward(s, a).abs()).fold(1e-9, f64::max);
    for _ in 0..crate::exact::MAX_STEPS {
        let (mut low, mut high) = (f64::INFINITY, f64::NEG_INFINITY);
        for s in 0..n_s {
            let future: f64 = t.outcomes(s, a).map(|j| t.prob[j] * v[t.next[j].0 as usize]).sum();
            w[s] = t.expected_reward(s, a) + t.gamma * future;
            low = low.min(w[s] - v[s]);
            high = high.max(w[s] - v[s]);
        }
        std::mem::swap(&mut v, &mut w);
        if factor * (high - low) <= 1e-9 * scale {
            for x in &mut v {
                *x += factor * low;
            }
            break;
        }
    }
    v
}

/// Beliefs met on `episodes` walks of `steps` steps of the greedy policy of `alphas`.
fn walk(t: &Tables, alphas: &[&Alpha], episodes: usize, steps: usize, seed: u64) -> Vec<Vec<f64>> {
    let mut rng = stream(seed, Purpose::Init, 3, 0);
    let mut met = Vec::new();
    for _ in 0..episodes {
        met.push(t.start.clone());
        let mut decide = |_: &mut EngineRng, belief: &[f64]| alphas[best(alphas, belief).0].action;
        walk_once(t, &mut rng, steps, &mut decide, &mut |belief| {
            met.push(belief.to_vec());
            true
        });
    }
    met
}

/// One walk of at most `steps` steps from the start belief (the state drawn as the belief
/// says), each decision chosen by `decide`: `visit` sees each belief that follows a step and
/// ends the walk by returning false.
fn walk_once(
    t: &Tables,
    rng: &mut EngineRng,
    steps: usize,
    decide: &mut impl FnMut(&mut EngineRng, &[f64]) -> usize,
    visit: &mut impl FnMut(&[f64]) -> bool,
) {
    let mut belief = t.start.clone();
    let mut next = vec![0.0; t.n_states()];
    let mut s = draw(rng, &t.start);
    for _ in 0..steps {
        let a = decide(rng, &belief);
        let range = t.outcomes(s, a);
        let j = range.start + draw(rng, &t.prob[range.clone()]);
        let (s2, o) = t.next[j];
        if t.filter(&belief, a, o as usize, &mut next) <= 0.0 {
            break;
        }
        std::mem::swap(&mut belief, &mut next);
        s = s2 as usize;
        if !visit(&belief) {
            break;
        }
    }
}

/// An index drawn from the weights `p` (the last one if rounding leaves `u` past the total).
fn draw(rng: &mut EngineRng, p: &[f64]) -> usize {
    let u: f64 = rng.random();
    let mut acc = 0.0;
    for (k, &x) in p.iter().enumerate() {
        acc += x;
        if u < acc {
            return k;
        }
    }
    p.len() - 1
}

/// The backup at `belief` of the value `alphas` (model §7's Bellman operator on beliefs).
fn backup(t: &Tables, alphas: &[&Alpha], belief: &[f64], scratch: &mut [Vec<f64>]) -> Alpha {
    let n_s = t.n_states();
    let mut top: Option<(f64, Alpha)> = None;
    for a in 0..t.n_actions() {
        successors(t, belief, a, scratch);
        let chosen: Vec<usize> = scratch.iter().map(|b| best(alphas, b).0).collect();
        let values: Vec<f64> = (0..n_s)
            .map(|s| {
                let future: f64 = t
                    .outcomes(s, a)
                    .map(|j| {
                        let (s2, o) = t.next[j];
                        t.prob[j] * alphas[chosen[o as usize]].values[s2 as usize]
                    })
                    .sum();
                t.expected_reward(s, a) + t.gamma * future
            })
            .collect();
        let v = dot(&values, belief);
        if top.as_ref().is_none_or(|(b, _)| v > *b) {
            top = Some((v, Alpha { values, action: a, witness: 0 }));
        }
    }
    top.expect("at least one action").1
}

/// `Q(s, a)` of the fully observable problem at `s·A + a` (value iteration, stopped by the
/// bounds of `MacQueen`): the QMDP decision `argmax_a Σ_s b(s) Q(s, a)` steers the walks.
fn qmdp(t: &Tables) -> Vec<f64> {
    let (n_s, n_a) = (t.n_states(), t.n_actions());
    let (mut v, mut q) = (vec![0.0; n_s], vec![0.0; n_s * n_a]);
    let factor = if t.gamma < 1.0 { t.gamma / (1.0 - t.gamma) } else { 0.0 };
    for _ in 0..crate::exact::MAX_STEPS {
        let (mut low, mut high) = (f64::INFINITY, f64::NEG_INFINITY);
        for s in 0..n_s {
            for a in 0..n_a {
                let future: f64 = t.outcomes(s, a).map(|j| t.prob[j] * v[t.next[j].0 as usize]).sum();
                q[s * n_a + a] = t.expected_reward(s, a) + t.gamma * future;
            }
            let best = q[s * n_a..(s + 1) * n_a].iter().copied().fold(f64::NEG_INFINITY, f64::max);
            low = low.min(best - v[s]);
            high = high.max(best - v[s]);
            v[s] = best;
        }
        if factor * (high - low) <= 1e-6 * v.iter().fold(1e-9_f64, |m, x| m.max(x.abs())) || t.gamma >= 1.0 {
            break;
        }
    }
    q
}

/// Beliefs met on walks from the start belief, the start belief first: each step takes the
/// QMDP decision or, as often, a random one.
fn collect(t: &Tables, budget: Budget, seed: u64) -> Vec<Vec<f64>> {
    let mut rng = stream(seed, Purpose::Init, 1, 0);
    let (q, n_a) = (qmdp(t), t.n_actions());
    let steer = |belief: &[f64]| {
        let value = |a: usize| belief.iter().enumerate().map(|(s, &b)| b * q[s * n_a + a]).sum::<f64>();
        (0..n_a).fold(0, |best, a| if value(a) > value(best) { a } else { best })
    };
    let mut beliefs = vec![t.start.clone()];
    let most = budget.beliefs.max(1);
    while beliefs.len() < most {
        let mut decide = |rng: &mut EngineRng, belief: &[f64]| {
            if rng.random::<bool>() { steer(belief) } else { rng.random_range(0..n_a) }
        };
        walk_once(t, &mut rng, budget.walk.max(1), &mut decide, &mut |belief| {
            beliefs.push(belief.to_vec());
            beliefs.len() < most
        });
    }
    beliefs
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ce::controller::{ControllerValue, Scratch};

    fn world(name: &str) -> PomdpWorld {
        PomdpWorld::from_file(format!("{}/../../data/pomdp/{name}", env!("CARGO_MANIFEST_DIR")), 100, None).unwrap()
    }

    #[test]
    fn a_blind_policy_is_valued_by_hand() {
        // Tiger, always listen: -1 a step, -1 / (1 - 0.95).
        let tiger = world("tiger.95.POMDP");
        assert!(blind(tiger.tables(), 0).iter().all(|v| (v - -20.0).abs() < 1e-6));
    }

    #[test]
    fn tiger_is_solved_and_its_controller_is_the_optimum() {
        let tiger = world("tiger.95.POMDP");
        let solved = PointBased::solve(&tiger, Budget::default(), 0);
        let at_start =
            |p: &PointBased| p.alphas.iter().map(|a| dot(&a.values, &tiger.tables().start)).fold(f64::MIN, f64::max);
        // SARSOP's bounds: [19.3711, 19.3721] (data/pomdp/SOURCES.md).
        assert!((at_start(&solved) - 19.3716).abs() < 0.01, "{}", at_start(&solved));
        let c = solved.controller(&tiger, 64, 0);
        assert!(c.nodes() <= 8, "{} nodes", c.nodes());
        let value = ControllerValue::new(&tiger, 1e-9).value(&c, &mut Scratch::default());
        assert!((value - 19.3716).abs() < 0.001, "{value}");
        // The same seed, the same vectors and controller, bit for bit.
        let again = PointBased::solve(&tiger, Budget::default(), 0);
        assert_eq!(at_start(&again).to_bits(), at_start(&solved).to_bits());
        assert_eq!(again.controller(&tiger, 64, 0), c);
    }

    #[test]
    fn the_controller_keeps_at_most_the_nodes_asked() {
        let w = world("4x3.95.POMDP");
        let solved = PointBased::solve(&w, Budget { work: 1e8, ..Budget::default() }, 1);
        for most in [1, 3, 16] {
            let c = solved.controller(&w, most, 1);
            assert!(c.nodes() <= most);
            c.check(w.tables().n_observations() + 1, w.tables().n_actions()).unwrap();
        }
    }

    #[test]
    fn the_work_follows_the_time_limit() {
        assert_eq!(Budget::within(None), Budget::default());
        assert_eq!(Budget::within(Some(10.0)).work, 1e9);
        assert_eq!(Budget::within(Some(1e6)).work, Budget::default().work);
    }
}
