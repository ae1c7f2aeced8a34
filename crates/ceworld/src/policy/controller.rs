//! A deterministic finite-state controller (model §8): the policies the controller search draws.
//!
//! A controller is a machine over a world's observations. Node `q` on observation `y` moves to
//! `next[q·Y + y]` (`Y` the world's observation count); it starts in node 0, before the first
//! observation, so that its first node is `next[y_1]`. (A tabular world's first observation is
//! its start symbol, model §7, so there the first node is `next[|O|]`.) Its decision is either
//! the new node's (a Moore machine: `act[q']`, with `on` empty), or the old node's on what it
//! observes (a Mealy machine: `on[q·Y + y]`, with `act` all 0): a Mealy machine of one node is a
//! memoryless policy, and of `n` nodes it holds every Moore machine of `n` nodes.
//!
//! As an HHMM (model §2) a Moore machine is the two-level policy `[n, n]` with one-hot tables
//! `h0[q] = act[q]`, `h1[y][u] = next[u·Y + y]`, `start = 0`, `step[p] = p`, so that
//! evaluation, exact values, graphs and policy files take it as it is. A Mealy machine is the
//! policy `[m, n]` whose upper memory is the node before the step (`n` nodes reached) and whose
//! lower memory is the pair (decision, next node) the step takes (`m` pairs met):
//! `h0[(d, q')] = d`, `h1[y][q] = (on[q·Y + y], next[q·Y + y])`, `start = 0`, `step[(d, q')] = q'`,
//! tables that grow with the pairs, where the Moore machine of its (node, observation) pairs
//! ([`Controller::to_moore`], which the exact values use) would square nodes × observations.
//! A controller draws no randomness of its own, except an explorer's ([`Explore`], model §10):
//! its decisions drawn again at some steps, by a pure function of the episode and the step, so
//! that whoever reads an episode's observations takes its decisions again.

use crate::error::Result;
use crate::policy::{Hhmm, Layout};
use crate::rng::mix64;

/// A deterministic controller: `act[q]` (Moore) or `on[q·Y + y]` (Mealy), and `next[q·Y + y]`.
#[derive(Clone, Debug, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
pub struct Controller {
    /// The decision of each node (a Moore machine; all 0 in a Mealy machine).
    pub act: Vec<u32>,
    /// The successor of node `q` after observation `y`, at `q·Y + y`.
    pub next: Vec<u32>,
    /// A Mealy machine's decisions: node `q`'s on observation `y`, at `q·Y + y`, taken before it
    /// moves; empty in a Moore machine.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub on: Vec<u32>,
    /// An explorer's draws ([`Explore`]); `None` for a deterministic controller. Its policy
    /// ([`Controller::to_hhmm`]) draws its decisions as they do, from the policy's own stream.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub explore: Option<Explore>,
}

/// The draws of an explorer (model §10): at step `t` of its episode `k` the decision is drawn
/// again, uniformly among `actions`, with probability `rate`, by a pure function of (`key`, `k`,
/// `t`), so that the decisions and their probabilities are known wherever the episode's
/// observations are.
#[derive(Clone, Copy, Debug, serde::Serialize, serde::Deserialize)]
pub struct Explore {
    /// The probability that a step's decision is drawn again.
    pub rate: f64,
    /// The decisions it is drawn among.
    pub actions: u32,
    /// The explorer's key.
    pub key: u64,
}

impl PartialEq for Explore {
    fn eq(&self, other: &Explore) -> bool {
        (self.rate.to_bits(), self.actions, self.key) == (other.rate.to_bits(), other.actions, other.key)
    }
}

impl Eq for Explore {}

impl std::hash::Hash for Explore {
    fn hash<H: std::hash::Hasher>(&self, state: &mut H) {
        (self.rate.to_bits(), self.actions, self.key).hash(state);
    }
}

impl Explore {
    /// The decision of step `t` of episode `episode` whose machine decides `planned`.
    #[inline]
    pub fn decide(&self, planned: u32, episode: u64, t: u64) -> u32 {
        let h = mix64(self.key ^ mix64(episode.wrapping_mul(0x9e37_79b9_7f4a_7c15) ^ t));
        let u = (h >> 11) as f64 / (1u64 << 53) as f64;
        if u < self.rate { (mix64(h) % u64::from(self.actions.max(1))) as u32 } else { planned }
    }

    /// The probability of decision `d` where the machine decides `planned`.
    #[inline]
    pub fn probability(&self, planned: u32, d: u32) -> f64 {
        let drawn = self.rate / f64::from(self.actions.max(1));
        if d == planned { 1.0 - self.rate + drawn } else { drawn }
    }
}

/// A controller run through one episode ([`Controller::walk`]): its node, and its draws where
/// it is an explorer.
#[derive(Clone, Debug)]
pub struct Walk<'c> {
    controller: &'c Controller,
    n_obs: usize,
    node: u32,
    episode: u64,
    t: u64,
}

impl Walk<'_> {
    /// One step on observation `y`: the decision and its probability (1 but for an explorer).
    #[inline]
    pub fn step(&mut self, y: usize) -> (u32, f64) {
        let planned = self.controller.step(&mut self.node, y, self.n_obs);
        let t = self.t;
        self.t += 1;
        match &self.controller.explore {
            None => (planned, 1.0),
            Some(e) => {
                let d = e.decide(planned, self.episode, t);
                (d, e.probability(planned, d))
            }
        }
    }

    /// The node the controller is in.
    pub fn node(&self) -> u32 {
        self.node
    }
}

impl Controller {
    /// A Moore machine.
    pub fn moore(act: Vec<u32>, next: Vec<u32>) -> Controller {
        Controller { act, next, on: Vec::new(), explore: None }
    }

    /// A Mealy machine of `next.len() / Y` nodes.
    pub fn mealy(on: Vec<u32>, next: Vec<u32>, n_obs: usize) -> Controller {
        Controller { act: vec![0; next.len() / n_obs.max(1)], next, on, explore: None }
    }

    /// Episode `episode` of this controller on a world of `n_obs` observations, from node 0.
    pub fn walk(&self, n_obs: usize, episode: u64) -> Walk<'_> {
        Walk { controller: self, n_obs, node: 0, episode, t: 0 }
    }

    /// Number of nodes.
    pub fn nodes(&self) -> usize {
        self.act.len()
    }

    /// Whether the decisions are a Mealy machine's.
    pub fn is_mealy(&self) -> bool {
        !self.on.is_empty()
    }

    /// Its decision rows: `on` (one per node and observation) for a Mealy machine, `act` (one
    /// per node) for a Moore machine.
    pub fn decisions(&self) -> &[u32] {
        if self.is_mealy() { &self.on } else { &self.act }
    }

    /// One step on observation `y` (of `n_obs`): moves `node` on and returns the machine's
    /// decision (an explorer's draws are [`Walk::step`]'s).
    #[inline]
    pub fn step(&self, node: &mut u32, y: usize, n_obs: usize) -> u32 {
        let i = *node as usize * n_obs + y;
        *node = self.next[i];
        if self.on.is_empty() { self.act[*node as usize] } else { self.on[i] }
    }

    /// Checks that this is a controller of a world of `n_obs` observations and `n_actions`
    /// decisions: at least one node, a decision below `n_actions` per node (or per node and
    /// observation), a successor below the node count per node and observation.
    pub fn check(&self, n_obs: usize, n_actions: usize) -> Result<()> {
        let n = self.act.len();
        let invalid = |why: String| Err(crate::error::Error::invalid("controller", why));
        if n == 0 || self.next.len() != n * n_obs {
            return invalid(format!(
                "{n} nodes and {} successors (expected at least 1 node and nodes · {n_obs} successors)",
                self.next.len()
            ));
        }
        if !self.on.is_empty() && (self.on.len() != self.next.len() || self.act.iter().any(|&a| a != 0)) {
            return invalid(format!(
                "{} Mealy decisions for {n} nodes (expected nodes · {n_obs}, and every Moore decision 0)",
                self.on.len()
            ));
        }
        if let Some(a) = self.act.iter().chain(&self.on).find(|&&a| a as usize >= n_actions) {
            return invalid(format!("decision {a} (expected below {n_actions})"));
        }
        if let Some(q) = self.next.iter().find(|&&q| q as usize >= n) {
            return invalid(format!("successor {q} (expected below {n} nodes)"));
        }
        Ok(())
    }

    /// The Moore machine that decides as this one does (itself, for a Moore machine): node 0
    /// the start, then one node per (node reached from the start, observation), numbered
    /// `1 + k·Y + y` with `k` the node's rank in the order it is first reached. It takes the
    /// decision this machine takes in node `q` on `y`, and moves on `y'` to `(next[q·Y + y], y')`.
    pub fn to_moore(&self, n_obs: usize) -> Controller {
        if self.on.is_empty() {
            return self.clone();
        }
        let mut rank = vec![u32::MAX; self.nodes()];
        let mut order = vec![0u32];
        rank[0] = 0;
        let mut i = 0;
        while i < order.len() {
            let q = order[i] as usize;
            for &to in &self.next[q * n_obs..(q + 1) * n_obs] {
                if rank[to as usize] == u32::MAX {
                    rank[to as usize] = order.len() as u32;
                    order.push(to);
                }
            }
            i += 1;
        }
        let node = |k: u32, y: usize| 1 + k * n_obs as u32 + y as u32;
        let m = 1 + order.len() * n_obs;
        let mut act = vec![0; m];
        let mut next = vec![0; m * n_obs];
        for (y2, to) in next[..n_obs].iter_mut().enumerate() {
            *to = node(0, y2);
        }
        for (k, &q) in order.iter().enumerate() {
            for y in 0..n_obs {
                let i = q as usize * n_obs + y;
                let from = node(k as u32, y) as usize;
                act[from] = self.on[i];
                let after = rank[self.next[i] as usize];
                for y2 in 0..n_obs {
                    next[from * n_obs + y2] = node(after, y2);
                }
            }
        }
        Controller { explore: self.explore, ..Controller::moore(act, next) }
    }

    /// The two-level one-hot HHMM of this controller (module docs).
    pub fn to_hhmm(&self, n_obs: usize, n_actions: usize) -> Result<Hhmm> {
        if self.is_mealy() {
            return self.mealy_hhmm(n_obs, n_actions);
        }
        let n = self.nodes();
        let layout = Layout::new(n_obs, n_actions, &[n, n])?.fits_in_memory()?;
        let mut probs = vec![0.0; layout.len];
        let t = &layout.tables;
        for (q, &a) in self.act.iter().enumerate() {
            self.decision_law(a, &mut probs[t[0].offset + q * n_actions..][..n_actions]);
        }
        for y in 0..n_obs {
            for u in 0..n {
                probs[t[1].offset + (y * n + u) * n + self.next[u * n_obs + y] as usize] = 1.0;
            }
        }
        probs[t[2].offset] = 1.0;
        for p in 0..n {
            probs[t[3].offset + p * n + p] = 1.0;
        }
        Hhmm::from_flat(layout, probs)
    }

    /// The law of the decision where the machine decides `planned`: certain, or an explorer's
    /// ([`Explore::probability`]).
    fn decision_law(&self, planned: u32, row: &mut [f64]) {
        for (d, p) in row.iter_mut().enumerate() {
            *p = match &self.explore {
                None => f64::from(u8::from(d as u32 == planned)),
                Some(e) => e.probability(planned, d as u32),
            };
        }
    }

    /// A Mealy machine's HHMM (module docs): the upper memory the node before the step (its
    /// nodes reached from node 0, by rank), the lower one the pair (decision, next node) the
    /// step takes (the pairs met, in order), so that the tables grow with the pairs, not with
    /// nodes × observations.
    fn mealy_hhmm(&self, n_obs: usize, n_actions: usize) -> Result<Hhmm> {
        let mut rank = vec![u32::MAX; self.nodes()];
        let mut order = vec![0u32];
        rank[0] = 0;
        let mut pairs: Vec<(u32, u32)> = Vec::new();
        let mut pair_of = std::collections::HashMap::new();
        // The pair of each reached node and observation, at rank·Y + y.
        let mut taken = Vec::new();
        let mut i = 0;
        while i < order.len() {
            let q = order[i] as usize;
            for k in q * n_obs..(q + 1) * n_obs {
                let to = self.next[k];
                if rank[to as usize] == u32::MAX {
                    rank[to as usize] = order.len() as u32;
                    order.push(to);
                }
                let pair = (self.on[k], to);
                let next_index = pairs.len();
                let index = *pair_of.entry(pair).or_insert(next_index);
                if index == next_index {
                    pairs.push(pair);
                }
                taken.push(index);
            }
            i += 1;
        }
        let (m, n) = (pairs.len(), order.len());
        let layout = Layout::new(n_obs, n_actions, &[m, n])?.fits_in_memory()?;
        let mut probs = vec![0.0; layout.len];
        let t = &layout.tables;
        for (p, &(a, to)) in pairs.iter().enumerate() {
            self.decision_law(a, &mut probs[t[0].offset + p * n_actions..][..n_actions]);
            probs[t[3].offset + p * n + rank[to as usize] as usize] = 1.0;
        }
        for u in 0..n {
            for y in 0..n_obs {
                probs[t[1].offset + (y * n + u) * m + taken[u * n_obs + y]] = 1.0;
            }
        }
        probs[t[2].offset] = 1.0;
        Hhmm::from_flat(layout, probs)
    }
}

impl Hhmm {
    /// The most likely policy: every law at its likeliest outcome (the first of equals), a
    /// deterministic controller with the same memory.
    #[must_use]
    pub fn most_likely(&self) -> Hhmm {
        let mut probs = vec![0.0; self.probs.len()];
        for t in &self.layout.tables {
            for r in 0..t.rows {
                let start = t.offset + r * t.cols;
                let row = &self.probs[start..start + t.cols];
                let best = (0..t.cols).fold(0, |b, k| if row[k] > row[b] { k } else { b });
                probs[start + best] = 1.0;
            }
        }
        Self::from_parts(self.layout.clone(), probs)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_explorer_s_policy_draws_its_decisions_as_its_walks_do() {
        // Two nodes deciding 0 then 1, each decision drawn again among three with probability 0.6.
        let explore = Some(Explore { rate: 0.6, actions: 3, key: 1 });
        let c = Controller { explore, ..Controller::moore(vec![0, 1], vec![1, 1, 0, 0]) };
        let close = |policy: &Hhmm, expected: &[f64]| {
            let h0 = &policy.probs[policy.layout().tables[0].offset..][..expected.len()];
            assert!(h0.iter().zip(expected).all(|(p, e)| (p - e).abs() < 1e-12), "{h0:?}");
        };
        close(&c.to_hhmm(2, 3).unwrap(), &[0.6, 0.2, 0.2, 0.2, 0.6, 0.2]);
        // A Mealy machine's pairs decide the same way; its Moore machine keeps the draws.
        let mealy = Controller { explore, ..Controller::mealy(vec![0, 2], vec![0, 0], 2) };
        close(&mealy.to_hhmm(2, 3).unwrap(), &[0.6, 0.2, 0.2, 0.2, 0.2, 0.6]);
        assert_eq!(mealy.to_moore(2).explore, explore);
    }

    #[test]
    fn a_mealy_machine_on_many_observations_has_tables_of_its_pairs() {
        // One node over 5000 observations, deciding y mod 3: three pairs, one node (as the
        // Moore machine of its pairs it would be [5001, 5001], 125 billion entries).
        let n_obs = 5000;
        let on: Vec<u32> = (0..n_obs as u32).map(|y| y % 3).collect();
        let policy = Controller::mealy(on, vec![0; n_obs], n_obs).to_hhmm(n_obs, 3).unwrap();
        assert_eq!(policy.levels(), [3, 1]);
        // Two nodes that swap on every observation and decide the node: pairs (0, 1), (1, 0).
        let swap = Controller::mealy(vec![0, 0, 1, 1], vec![1, 1, 0, 0], 2).to_hhmm(2, 2).unwrap();
        assert_eq!(swap.levels(), [2, 2]);
    }
}
