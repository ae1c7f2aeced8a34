//! The model of pairs (model §10): what each decision brings at once (its reward and the next
//! observation) given each (earlier decision, the observation that followed it) of the episode,
//! learnt from every kept step, and the machine that takes, after every history, the decision of
//! the highest reward it foresees.
//!
//! Where a decision's outcome depends on which decisions were taken and what they showed (a
//! clicking game: a cell clicked twice is wasted, a cell beside one that showed no mine is safe; a
//! bandit: the arm that just paid), no window of lags and no table of agent states learns it in few
//! steps, for the histories are too many to be met twice. A pair is met in every episode that takes
//! its decision, though: for decision `a` and pair `(b, o)` the model keeps the steps that decided `a`
//! after `b` was followed by `o`, and foresees `a`'s reward as its mean over all steps plus, for each
//! pair of the history, how much the steps after that pair differ from it (each such mean shrunk to
//! the overall one by [`PRIOR`] steps); the next observation alike. The episode's first observation
//! is a pair of a decision of its own (the start).
//!
//! Its machine is a tree of histories grown most likely first (the chance of a history: the product
//! of the foreseen chances of its observations) up to a budget of nodes; a history outside it is
//! *lost*, where the machine decides as at a start on the current observation. It decides for one
//! step ahead only: where a decision pays later, the other families plan.

use std::cmp::Ordering;
use std::collections::BinaryHeap;

use crate::episodes::trace::Traces;
use crate::policy::controller::Controller;

/// Steps by which a mean after a pair is shrunk to the decision's overall mean.
pub const PRIOR: f64 = 4.0;

/// The most entries of the model's table of next observations (decisions · pairs · observations).
pub const MOST_ENTRIES: usize = 1 << 22;

/// What the kept steps say of each decision after each pair.
#[derive(Clone, Debug, PartialEq)]
pub struct Pairs {
    /// Decisions `A` (a pair's decision is one of them or the start, `A`).
    decisions: usize,
    /// Observations `Y`.
    observations: usize,
    /// Steps of each decision, their summed reward and their next observations (`a·Y + o`).
    steps: Vec<f64>,
    reward: Vec<f64>,
    next: Vec<f64>,
    /// The same after pair `e = b·Y + o`, at `e·A + a` (observations at `(e·A + a)·Y + o'`).
    pair_steps: Vec<f64>,
    pair_reward: Vec<f64>,
    pair_next: Vec<f64>,
    /// Episodes that began with each observation.
    first: Vec<f64>,
    /// The most steps of a kept episode.
    longest: usize,
}

/// What the model foresees after a history: each decision's reward and law of its next
/// observation (unnormalised).
#[derive(Clone, Debug)]
struct Foresight {
    reward: Vec<f64>,
    next: Vec<f64>,
}

impl Pairs {
    /// The model of the kept steps of a world of `observations` and `decisions`; none where its
    /// table would pass [`MOST_ENTRIES`] or there is no step.
    pub fn fit(observations: usize, decisions: usize, traces: &Traces) -> Option<Pairs> {
        let (a, y) = (decisions, observations);
        let pairs = (a + 1) * y;
        if traces.steps() == 0 || pairs.checked_mul(a * y).is_none_or(|n| n > MOST_ENTRIES) {
            return None;
        }
        let mut m = Pairs {
            decisions: a,
            observations: y,
            steps: vec![0.0; a],
            reward: vec![0.0; a],
            next: vec![0.0; a * y],
            pair_steps: vec![0.0; pairs * a],
            pair_reward: vec![0.0; pairs * a],
            pair_next: vec![0.0; pairs * a * y],
            first: vec![0.0; y],
            longest: 0,
        };
        let mut history: Vec<usize> = Vec::new();
        for episode in traces.episodes().filter(|e| !e.is_empty()) {
            let first = traces.obs[episode.start] as usize;
            m.first[first] += 1.0;
            m.longest = m.longest.max(episode.len());
            history.clear();
            history.push(a * y + first);
            for t in episode.clone() {
                let (d, r) = (traces.dec[t] as usize, traces.rew[t]);
                let next = (t + 1 < episode.end).then(|| traces.obs[t + 1] as usize);
                m.steps[d] += 1.0;
                m.reward[d] += r;
                for &e in &history {
                    m.pair_steps[e * a + d] += 1.0;
                    m.pair_reward[e * a + d] += r;
                }
                if let Some(o) = next {
                    m.next[d * y + o] += 1.0;
                    for &e in &history {
                        m.pair_next[(e * a + d) * y + o] += 1.0;
                    }
                    history.push(d * y + o);
                }
            }
        }
        Some(m)
    }

    /// Each decision's mean reward and law of next observations over every step (0 where never
    /// taken).
    fn overall(&self) -> Foresight {
        let (a, y) = (self.decisions, self.observations);
        let reward = (0..a).map(|d| self.reward[d] / self.steps[d].max(1.0)).collect();
        let next = (0..a * y).map(|i| self.next[i] / self.steps[i / y].max(1.0)).collect();
        Foresight { reward, next }
    }

    /// `f` after one more pair `e` of the history (`base` the overall foresight), its laws of
    /// next observations too where `laws`.
    fn add(&self, f: &mut Foresight, base: &Foresight, e: usize, laws: bool) {
        let (a, y) = (self.decisions, self.observations);
        for d in 0..a {
            let (p, n) = (e * a + d, self.pair_steps[e * a + d]);
            f.reward[d] += (self.pair_reward[p] + PRIOR * base.reward[d]) / (n + PRIOR) - base.reward[d];
            for o in (0..y).filter(|_| laws) {
                let i = d * y + o;
                f.next[i] += (self.pair_next[p * y + o] + PRIOR * base.next[i]) / (n + PRIOR) - base.next[i];
            }
        }
    }

    /// The decision of the highest foreseen reward among those ever taken (the first of equals; 0
    /// where none was).
    fn best(&self, f: &Foresight) -> u32 {
        let taken = (0..self.decisions).filter(|&d| self.steps[d] > 0.0);
        let best = taken.fold(None, |b: Option<usize>, d| match b {
            Some(b) if f.reward[b] >= f.reward[d] => Some(b),
            _ => Some(d),
        });
        best.unwrap_or(0) as u32
    }

    /// The foreseen law of the observation after decision `d` (uniform where it says nothing).
    fn law(&self, f: &Foresight, d: usize) -> Vec<f64> {
        let y = self.observations;
        let row: Vec<f64> = f.next[d * y..(d + 1) * y].iter().map(|&p| p.max(0.0)).collect();
        let total: f64 = row.iter().sum();
        if total > 0.0 { row.into_iter().map(|p| p / total).collect() } else { vec![1.0 / y as f64; y] }
    }

    /// The Mealy machine of at most `nodes` nodes (at least 2; fewer where their foresights would
    /// pass [`MOST_ENTRIES`] numbers): node 0 the start, the last one lost, the others the
    /// histories most likely under its own decisions, of at most the longest kept episode's steps.
    pub fn machine(&self, nodes: usize) -> Controller {
        let (a, y) = (self.decisions, self.observations);
        let base = self.overall();
        // Each node's parent, pair (the newest of its history), decision (the start's is `a`),
        // steps decided and foresight, kept within the table's budget of entries.
        let budget = nodes.min(MOST_ENTRIES / (a * (1 + y))).max(2) - 1;
        let mut tree: Vec<(usize, usize, u32, usize)> = vec![(0, 0, a as u32, 0)];
        let mut foresight = vec![base.clone()];
        let total: f64 = self.first.iter().sum();
        let mut frontier: BinaryHeap<Grow> =
            (0..y).map(|o| Grow { chance: self.first[o] / total.max(1.0), order: o, parent: 0, observed: o }).collect();
        let mut order = y;
        while tree.len() < budget {
            let Some(g) = frontier.pop() else { break };
            let (_, _, pending, depth) = tree[g.parent];
            let e = pending as usize * y + g.observed;
            let mut f = foresight[g.parent].clone();
            self.add(&mut f, &base, e, true);
            let d = self.best(&f);
            tree.push((g.parent, e, d, depth + 1));
            let q = tree.len() - 1;
            // No episode kept decided more than `longest` times: deeper histories are not grown.
            if depth + 1 < self.longest {
                for (o, p) in self.law(&f, d as usize).into_iter().enumerate() {
                    frontier.push(Grow { chance: g.chance * p, order, parent: q, observed: o });
                    order += 1;
                }
            }
            foresight.push(f);
        }
        let lost = tree.len();
        let mut on = vec![0; (lost + 1) * y];
        let mut next = vec![lost as u32; (lost + 1) * y];
        for (q, &(parent, e, d, _)) in tree.iter().enumerate().skip(1) {
            on[parent * y + e % y] = d;
            next[parent * y + e % y] = q as u32;
        }
        // What is not grown decides on the history it has, one step, and is lost after.
        foresight.push(base.clone());
        for q in 0..=lost {
            let pending = if q == lost { a } else { tree[q].2 as usize };
            for o in (0..y).filter(|&o| next[q * y + o] as usize == lost) {
                let mut f = Foresight { reward: foresight[q].reward.clone(), next: Vec::new() };
                self.add(&mut f, &base, pending * y + o, false);
                on[q * y + o] = self.best(&f);
            }
        }
        Controller::mealy(on, next, y)
    }
}

/// A history the tree may grow: observation `observed` after node `parent`, of chance `chance`.
#[derive(Clone, Copy, Debug)]
struct Grow {
    chance: f64,
    order: usize,
    parent: usize,
    observed: usize,
}

impl PartialEq for Grow {
    fn eq(&self, other: &Self) -> bool {
        self.cmp(other) == Ordering::Equal
    }
}

impl Eq for Grow {}

impl PartialOrd for Grow {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}

impl Ord for Grow {
    /// The likelier first, then the one met first.
    fn cmp(&self, other: &Self) -> Ordering {
        self.chance.total_cmp(&other.chance).then(other.order.cmp(&self.order))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Episodes of (observation, decision, reward) steps.
    fn traces(episodes: &[Vec<(u32, u32, f64)>]) -> Traces {
        let mut traces = Traces::default();
        for steps in episodes {
            traces.obs.extend(steps.iter().map(|s| s.0));
            traces.dec.extend(steps.iter().map(|s| s.1));
            traces.rew.extend(steps.iter().map(|s| s.2));
            traces.prob.extend(steps.iter().map(|_| 1.0));
            traces.ends.push(traces.obs.len());
        }
        traces
    }

    /// A clicking game of three cells by hand: a cell clicked for the first time pays 1 and shows
    /// 1, one clicked again pays −1 and shows 0; every sequence of three clicks.
    fn clicks() -> Traces {
        let mut episodes = Vec::new();
        for k in 0..27u32 {
            let order = [k % 3, k / 3 % 3, k / 9];
            let mut seen = [false; 3];
            let mut obs = 0;
            let mut steps = Vec::new();
            for &d in &order {
                let fresh = !std::mem::replace(&mut seen[d as usize], true);
                steps.push((obs, d, if fresh { 1.0 } else { -1.0 }));
                obs = u32::from(fresh);
            }
            episodes.push(steps);
        }
        traces(&episodes)
    }

    #[test]
    fn it_counts_each_decision_after_each_pair() {
        // Two observations, two decisions: the first observation is the start's pair (2·2 + y).
        let t = traces(&[vec![(1, 0, 1.0), (0, 1, 2.0), (1, 1, -1.0)], vec![(0, 1, 3.0)]]);
        let m = Pairs::fit(2, 2, &t).unwrap();
        assert_eq!((m.steps.clone(), m.reward.clone()), (vec![1.0, 3.0], vec![1.0, 4.0]));
        // Next observations: decision 0 then 0; decision 1 then 1 (the last steps have none).
        assert_eq!(m.next, [1.0, 0.0, 0.0, 1.0]);
        assert_eq!(m.first, [1.0, 1.0]);
        let at = |b: usize, o: usize, d: usize| (b * 2 + o) * 2 + d;
        // After the start showing 1: decision 0 once (1), decision 1 twice (2 − 1).
        assert_eq!((m.pair_steps[at(2, 1, 0)], m.pair_steps[at(2, 1, 1)]), (1.0, 2.0));
        assert_eq!(m.pair_reward[at(2, 1, 1)], 1.0);
        // After (0, 0): decision 1 twice; after (1, 1): decision 1 once; after the start showing 0:
        // decision 1 once, paying 3.
        assert_eq!((m.pair_steps[at(0, 0, 1)], m.pair_steps[at(1, 1, 1)]), (2.0, 1.0));
        assert_eq!((m.pair_steps[at(2, 0, 1)], m.pair_reward[at(2, 0, 1)]), (1.0, 3.0));
        // Its next observation after (0, 0): decision 1 was followed by 1 once.
        assert_eq!(m.pair_next[at(0, 0, 1) * 2 + 1], 1.0);
        assert!(Pairs::fit(2, 2, &Traces::default()).is_none());
        assert!(Pairs::fit(1 << 11, 2, &t).is_none());
    }

    #[test]
    fn its_machine_clicks_every_cell_once() {
        let machine = Pairs::fit(2, 3, &clicks()).unwrap().machine(64);
        machine.check(2, 3).unwrap();
        // Played on the game itself: three fresh clicks.
        let (mut q, mut obs, mut seen) = (0usize, 0usize, [false; 3]);
        for _ in 0..3 {
            let d = machine.on[q * 2 + obs] as usize;
            q = machine.next[q * 2 + obs] as usize;
            assert!(!std::mem::replace(&mut seen[d], true), "cell {d} clicked twice");
            obs = 1;
        }
    }

    #[test]
    fn its_tree_grows_the_likeliest_histories_within_its_budget() {
        let m = Pairs::fit(2, 3, &clicks()).unwrap();
        for nodes in [2, 3, 5, 64] {
            let machine = m.machine(nodes);
            assert!(machine.next.len() / 2 <= nodes.max(2), "{nodes}");
        }
        // Every episode starts on observation 0: the start's child for it is grown first, then its
        // likelier observation (a fresh click shows 1); the rest is lost.
        let machine = m.machine(4);
        assert_eq!(machine.next[0], 1);
        let lost = machine.next.len() / 2 - 1;
        assert_eq!(machine.next[1] as usize, lost);
        assert_eq!((machine.next[2 + 1], machine.next[2 * 2 + 1]), (2, 3));
    }
}
