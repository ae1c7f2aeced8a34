//! A deterministic finite-state controller (model §8): the policies the controller search draws.
//!
//! A controller is a Moore machine over a world's observations: node `q` takes decision
//! `act[q]`; on observation `y` it moves to `next[q·Y + y]` (`Y` the world's observation count).
//! It starts in node 0, before the first observation, so that its first node is `next[y_1]`
//! and its first decision `act[next[y_1]]`. (A tabular world's first observation is its start
//! symbol, model §7, so there the first node is `next[|O|]`.) As an HHMM (model §2) it is the
//! two-level policy `[n, n]` with one-hot tables `h0[q] = act[q]`, `h1[y][u] = next[u·Y + y]`,
//! `start = 0`, `step[p] = p`, so that evaluation, exact values, graphs and policy files take it
//! as it is; a controller draws no randomness of its own.

use crate::error::Result;
use crate::policy::{Hhmm, Layout};

/// A deterministic controller: `act[q]` and `next[q·Y + y]`.
#[derive(Clone, Debug, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
pub struct Controller {
    /// The decision of each node.
    pub act: Vec<u32>,
    /// The successor of node `q` after observation `y`, at `q·Y + y`.
    pub next: Vec<u32>,
}

impl Controller {
    /// Number of nodes.
    pub fn nodes(&self) -> usize {
        self.act.len()
    }

    /// The node after observation `y` in node `q`, for a world of `n_obs` observations.
    #[inline]
    pub fn next_node(&self, q: u32, y: usize, n_obs: usize) -> u32 {
        self.next[q as usize * n_obs + y]
    }

    /// Checks that this is a controller of a world of `n_obs` observations and `n_actions`
    /// decisions: at least one node, a decision below `n_actions` per node, a successor below
    /// the node count per node and observation.
    pub fn check(&self, n_obs: usize, n_actions: usize) -> Result<()> {
        let n = self.act.len();
        let invalid = |why: String| Err(crate::error::Error::invalid("controller", why));
        if n == 0 || self.next.len() != n * n_obs {
            return invalid(format!(
                "{n} nodes and {} successors (expected at least 1 node and nodes · {n_obs} successors)",
                self.next.len()
            ));
        }
        if let Some(a) = self.act.iter().find(|&&a| a as usize >= n_actions) {
            return invalid(format!("decision {a} (expected below {n_actions})"));
        }
        if let Some(q) = self.next.iter().find(|&&q| q as usize >= n) {
            return invalid(format!("successor {q} (expected below {n} nodes)"));
        }
        Ok(())
    }

    /// The two-level one-hot HHMM of this controller (module docs).
    pub fn to_hhmm(&self, n_obs: usize, n_actions: usize) -> Result<Hhmm> {
        let n = self.act.len();
        let layout = Layout::new(n_obs, n_actions, &[n, n])?.fits_in_memory()?;
        let mut probs = vec![0.0; layout.len];
        let t = &layout.tables;
        for (q, &a) in self.act.iter().enumerate() {
            probs[t[0].offset + q * n_actions + a as usize] = 1.0;
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
