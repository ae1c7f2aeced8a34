//! The steps of episodes kept whole (model §10, memory from every step): each step's
//! observation, decision and reward, episode after episode, so that a learner may replay every
//! step it has taken through any candidate memory, not only through the controller that took it.

use serde::{Deserialize, Serialize};

use crate::policy::controller::Controller;

/// Episodes' steps: step `t` of the store is `(obs[t], dec[t], rew[t], prob[t])`; episode `e`
/// is the steps `ends[e - 1]..ends[e]` (from 0 for the first).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Traces {
    /// The observation each step decided on.
    pub obs: Vec<u32>,
    /// The decision taken.
    pub dec: Vec<u32>,
    /// The reward that followed.
    pub rew: Vec<f64>,
    /// The probability the controller that took the step had of its decision (1 but for an
    /// explorer's, [`crate::policy::controller::Explore`]); a checkpoint written before these
    /// were kept reads as 1 for every step.
    #[serde(default)]
    pub prob: Vec<f64>,
    /// Where each episode ends (one past its last step).
    pub ends: Vec<usize>,
    /// The discount of the world the rewards are of (an episode's value is
    /// `r_1 + γ r_2 + γ² r_3 + ...`).
    pub gamma: f64,
}

impl Default for Traces {
    fn default() -> Self {
        Traces { obs: Vec::new(), dec: Vec::new(), rew: Vec::new(), prob: Vec::new(), ends: Vec::new(), gamma: 1.0 }
    }
}

impl Traces {
    /// Adds episode `episode` of controller `c`: its steps' (observation, reward); the decisions
    /// are the controller's own ([`Controller::walk`]'s), taken again here.
    pub fn add(&mut self, c: &Controller, n_obs: usize, episode: u64, steps: impl Iterator<Item = (usize, f64)>) {
        self.fill_probabilities();
        let mut walk = c.walk(n_obs, episode);
        for (y, r) in steps {
            let (d, p) = walk.step(y);
            self.obs.push(y as u32);
            self.dec.push(d);
            self.rew.push(r);
            self.prob.push(p);
        }
        self.ends.push(self.obs.len());
    }

    /// A probability of 1 for every step kept without one (read from an older checkpoint).
    fn fill_probabilities(&mut self) {
        self.prob.resize(self.obs.len(), 1.0);
    }

    /// The weight of step `t` in a model of the steps: the inverse of its decision's probability,
    /// so that the decisions an explorer drew at random count as those of every history, not as
    /// those of the histories its plan met (model §10).
    #[inline]
    pub fn weight(&self, t: usize) -> f64 {
        self.prob.get(t).map_or(1.0, |&p| 1.0 / p)
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
        self.fill_probabilities();
        self.obs.drain(..drop);
        self.dec.drain(..drop);
        self.rew.drain(..drop);
        self.prob.drain(..drop);
        self.ends = self.ends[k..].iter().map(|e| e - drop).collect();
    }

    /// `other`'s episodes after these.
    pub fn append(&mut self, other: Traces) {
        self.gamma = other.gamma;
        let base = self.obs.len();
        self.fill_probabilities();
        let more = other.obs.len();
        self.obs.extend(other.obs);
        self.dec.extend(other.dec);
        self.rew.extend(other.rew);
        self.prob.extend(other.prob);
        self.prob.resize(base + more, 1.0);
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
        traces.add(&echo, 2, 0, [(1, 0.5), (0, -1.0)].into_iter());
        let mut more = Traces::default();
        more.add(&echo, 2, 0, [(1, 2.0)].into_iter());
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

    #[test]
    fn an_explorer_s_steps_are_kept_with_their_probabilities_and_weighted_by_their_inverse() {
        use crate::policy::controller::Explore;
        // Steps kept without probabilities (an older checkpoint's) weigh 1.
        let echo = Controller::moore(vec![0, 1], vec![0, 1, 0, 1]);
        let mut traces = Traces::default();
        traces.add(&echo, 2, 0, [(1, 0.0), (0, 0.0)].into_iter());
        traces.prob.clear();
        assert_eq!(traces.weight(1), 1.0);
        // Echo as an explorer that draws nearly every decision again among two.
        let explorer = Controller { explore: Some(Explore { rate: 0.9, actions: 2, key: 3 }), ..echo.clone() };
        let obs = [0, 1, 1, 0, 1, 0, 0, 1];
        traces.add(&explorer, 2, 5, obs.iter().map(|&y| (y, 1.0)));
        assert_eq!(traces.prob.len(), 2 + obs.len());
        let mut walk = explorer.walk(2, 5);
        for (t, &y) in obs.iter().enumerate() {
            let (d, p) = walk.step(y);
            assert_eq!((traces.dec[2 + t], traces.prob[2 + t]), (d, p));
            // Its plan (echo) with 0.1 + 0.45, the other decision with 0.45.
            let expected = if d as usize == y { 0.55 } else { 0.45 };
            assert!((p - expected).abs() < 1e-12 && traces.weight(2 + t) == 1.0 / p, "{p}");
        }
        // The probabilities stay with their steps when older episodes are dropped.
        let mut kept = traces.clone();
        kept.keep_last(obs.len());
        assert_eq!((kept.prob.as_slice(), kept.dec.as_slice()), (&traces.prob[2..], &traces.dec[2..]));
    }
}
