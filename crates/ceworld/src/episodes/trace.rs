//! The steps of episodes kept whole (model §10, memory from every step): each step's
//! observation, decision and reward, episode after episode, so that a learner may replay every
//! step it has taken through any candidate memory, not only through the controller that took it.

use serde::{Deserialize, Serialize};

use crate::policy::controller::Controller;

/// Episodes' steps: step `t` of the store is `(obs[t], dec[t], rew[t])`; episode `e` is the
/// steps `ends[e - 1]..ends[e]` (from 0 for the first).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Traces {
    /// The observation each step decided on.
    pub obs: Vec<u32>,
    /// The decision taken.
    pub dec: Vec<u32>,
    /// The reward that followed.
    pub rew: Vec<f64>,
    /// Where each episode ends (one past its last step).
    pub ends: Vec<usize>,
    /// The discount of the world the rewards are of (an episode's value is
    /// `r_1 + γ r_2 + γ² r_3 + ...`).
    pub gamma: f64,
}

impl Default for Traces {
    fn default() -> Self {
        Traces { obs: Vec::new(), dec: Vec::new(), rew: Vec::new(), ends: Vec::new(), gamma: 1.0 }
    }
}

impl Traces {
    /// Adds one episode of controller `c`: its steps' (observation, reward); the decisions are
    /// the controller's own (it draws none), taken again here.
    pub fn add(&mut self, c: &Controller, n_obs: usize, steps: impl Iterator<Item = (usize, f64)>) {
        let mut node = 0u32;
        for (y, r) in steps {
            let d = c.step(&mut node, y, n_obs);
            self.obs.push(y as u32);
            self.dec.push(d);
            self.rew.push(r);
        }
        self.ends.push(self.obs.len());
    }

    /// Keeps the latest whole episodes of at most `steps` steps (the last one whatever its
    /// length).
    pub fn keep_last(&mut self, steps: usize) {
        let n = self.obs.len();
        if n <= steps || self.ends.is_empty() {
            return;
        }
        let start = |k: usize| if k == 0 { 0 } else { self.ends[k - 1] };
        let last = self.ends.len() - 1;
        let k = (0..last).find(|&k| n - start(k) <= steps).unwrap_or(last);
        let drop = start(k);
        self.obs.drain(..drop);
        self.dec.drain(..drop);
        self.rew.drain(..drop);
        self.ends = self.ends[k..].iter().map(|e| e - drop).collect();
    }

    /// `other`'s episodes after these.
    pub fn append(&mut self, other: Traces) {
        self.gamma = other.gamma;
        let base = self.obs.len();
        self.obs.extend(other.obs);
        self.dec.extend(other.dec);
        self.rew.extend(other.rew);
        self.ends.extend(other.ends.into_iter().map(|e| e + base));
    }

    /// The steps kept.
    pub fn steps(&self) -> usize {
        self.obs.len()
    }

    /// The episodes kept, each as its range of steps.
    pub fn episodes(&self) -> impl Iterator<Item = std::ops::Range<usize>> + '_ {
        std::iter::once(0).chain(self.ends.iter().copied()).zip(self.ends.iter().copied()).map(|(a, b)| a..b)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_controller_s_episodes_are_kept_with_its_decisions_and_appended_in_order() {
        // Two observations; node y after y, deciding its node (Moore): decisions echo y.
        let echo = Controller::moore(vec![0, 1], vec![0, 1, 0, 1]);
        let mut traces = Traces::default();
        traces.add(&echo, 2, [(1, 0.5), (0, -1.0)].into_iter());
        let mut more = Traces::default();
        more.add(&echo, 2, [(1, 2.0)].into_iter());
        traces.append(more);
        assert_eq!(traces.obs, vec![1, 0, 1]);
        assert_eq!(traces.dec, vec![1, 0, 1]);
        assert_eq!(traces.rew, vec![0.5, -1.0, 2.0]);
        assert_eq!(traces.episodes().collect::<Vec<_>>(), vec![0..2, 2..3]);
        // The latest whole episodes of at most 1 step, then of 2: the last one alone, then both.
        let mut kept = traces.clone();
        kept.keep_last(2);
        assert_eq!(kept.episodes().count(), 1);
        kept.keep_last(1);
        assert_eq!((kept.obs.clone(), kept.ends.clone()), (vec![1], vec![1]));
        let mut all = traces.clone();
        all.keep_last(3);
        assert_eq!(all, traces);
    }
}
