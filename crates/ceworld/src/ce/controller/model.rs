//! The empirical model of a candidate memory over every step kept (model §10, memory from every
//! step): the kept episodes replayed through the memory give its agent states (the node after
//! each observation); counted, they give for each (node, decision) its visits, its mean reward
//! and the law of the next observation, hence of the next node. Value iteration on that model
//! plans the memory's decisions and values it, so that every step taken serves every memory
//! considered, not only the controller that took it.
//!
//! The model is a guess where the memory is not a sufficient statistic of the past, and it
//! flatters decisions seen rarely: each (node, decision) loses `pessimism · spread / √visits`
//! (`spread` the range of the steps' rewards), and a learner confirms a plan on episodes of the
//! world before it keeps it.

use crate::episodes::trace::Traces;
use crate::policy::controller::Controller;

/// What the kept steps say of a memory's (node, decision) pairs.
#[derive(Clone, Debug, PartialEq)]
pub struct AgentModel {
    /// Nodes of the memory.
    pub nodes: usize,
    /// Decisions.
    pub actions: usize,
    /// Observations (the successor table's stride).
    pub observations: usize,
    /// Steps that decided `d` in node `q`, at `q·A + d`.
    pub visits: Vec<u32>,
    /// Their summed reward.
    pub reward: Vec<f64>,
    /// Their next observations counted, at `(q·A + d)·Y + y` (an episode's last step has none).
    pub next: Vec<u32>,
    /// Episodes that started in node `q` (after their first observation).
    pub starts: Vec<u32>,
    /// The largest reward of a step less the smallest.
    pub spread: f64,
    /// The most steps of one episode.
    pub longest: usize,
}

impl AgentModel {
    /// The model of the memory `successor` (`successor[q·Y + y]`, a controller's `next`, of
    /// `successor.len() / observations` nodes) over `traces`.
    pub fn fit(successor: &[u32], observations: usize, actions: usize, traces: &Traces) -> AgentModel {
        let nodes = successor.len() / observations;
        let mut m = AgentModel {
            nodes,
            actions,
            observations,
            visits: vec![0; nodes * actions],
            reward: vec![0.0; nodes * actions],
            next: vec![0; nodes * actions * observations],
            starts: vec![0; nodes],
            spread: 0.0,
            longest: 0,
        };
        let (mut low, mut high) = (f64::INFINITY, f64::NEG_INFINITY);
        for episode in traces.episodes() {
            let Some(first) = traces.obs.get(episode.start) else { continue };
            m.longest = m.longest.max(episode.len());
            let mut q = successor[*first as usize] as usize;
            m.starts[q] += 1;
            for t in episode.clone() {
                let (d, r) = (traces.dec[t] as usize, traces.rew[t]);
                let at = q * actions + d;
                m.visits[at] += 1;
                m.reward[at] += r;
                (low, high) = (low.min(r), high.max(r));
                if t + 1 < episode.end {
                    let y = traces.obs[t + 1] as usize;
                    m.next[at * observations + y] += 1;
                    q = successor[q * observations + y] as usize;
                }
            }
        }
        m.spread = if high > low { high - low } else { 0.0 };
        m
    }

    /// The decisions that value iteration on the model chooses (`horizon` backups discounted by
    /// `gamma`, each (node, decision) less `pessimism · spread / √visits`; a node never visited
    /// keeps `fallback`'s decision), and the model's value of the episodes' starts under them.
    pub fn plan(&self, successor: &[u32], gamma: f64, horizon: usize, pessimism: f64, fallback: &[u32]) -> Plan {
        let (n, a, y1) = (self.nodes, self.actions, self.observations);
        let penalty: Vec<f64> = self
            .visits
            .iter()
            .map(|&v| if v == 0 { 0.0 } else { pessimism * self.spread / f64::from(v).sqrt() })
            .collect();
        let (mut value, mut fresh) = (vec![0.0; n], vec![0.0; n]);
        let mut act: Vec<u32> = fallback.to_vec();
        for _ in 0..horizon.max(1) {
            fresh.fill(0.0);
            for q in 0..n {
                let mut best: Option<(f64, u32)> = None;
                for d in 0..a {
                    let at = q * a + d;
                    if self.visits[at] == 0 {
                        continue;
                    }
                    let visits = f64::from(self.visits[at]);
                    let ahead: f64 = (0..y1)
                        .filter(|&y| self.next[at * y1 + y] > 0)
                        .map(|y| f64::from(self.next[at * y1 + y]) * value[successor[q * y1 + y] as usize])
                        .sum();
                    let q_value = (self.reward[at] + gamma * ahead) / visits - penalty[at];
                    if best.is_none_or(|(b, _)| q_value > b) {
                        best = Some((q_value, d as u32));
                    }
                }
                if let Some((v, d)) = best {
                    fresh[q] = v;
                    act[q] = d;
                }
            }
            std::mem::swap(&mut value, &mut fresh);
        }
        let episodes: u32 = self.starts.iter().sum();
        let start = self.starts.iter().zip(&value).map(|(&s, &v)| f64::from(s) * v).sum::<f64>();
        Plan { controller: Controller::moore(act, successor.to_vec()), value: start / f64::from(episodes.max(1)) }
    }
}

/// A memory with the decisions planned on its model, and the model's value of it.
#[derive(Clone, Debug, PartialEq)]
pub struct Plan {
    /// The memory with its planned decisions (a Moore machine).
    pub controller: Controller,
    /// The model's mean value of the kept episodes' starts.
    pub value: f64,
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `RepeatPrevious` by hand: two observations, reward 1 for deciding the observation before
    /// (the first step pays nothing either way); every sequence of three observations played by
    /// each constant decision (16 episodes of three steps).
    fn echo_traces() -> Traces {
        let mut traces = Traces::default();
        for d in 0..2u32 {
            let constant = Controller::moore(vec![d], vec![0, 0]);
            for sequence in 0..8usize {
                let obs = [sequence >> 2 & 1, sequence >> 1 & 1, sequence & 1];
                let reward = |t: usize| if t > 0 && obs[t - 1] == d as usize { 1.0 } else { 0.0 };
                traces.add(&constant, 2, (0..3).map(|t| (obs[t], reward(t))));
            }
        }
        traces
    }

    #[test]
    fn the_kept_steps_are_counted_per_node_and_decision() {
        let traces = echo_traces();
        // Memoryless: one node whatever it observes.
        let m = AgentModel::fit(&[0, 0], 2, 2, &traces);
        assert_eq!(m.visits, vec![24, 24]);
        assert_eq!(m.starts, vec![16]);
        assert_eq!((m.spread, m.longest), (1.0, 3));
        // Steps 2 and 3 pay where the observation before is the decision: half the sequences each.
        assert_eq!(m.reward, vec![8.0, 8.0]);
        // Sixteen episodes of three steps: two next observations each, half of them 1.
        assert_eq!(m.next, vec![8, 8, 8, 8]);
    }

    #[test]
    fn a_memory_of_the_last_two_observations_plans_to_repeat_the_previous_one() {
        let traces = echo_traces();
        // A window of two (model §8's "window" template): node (q·Y + y) mod 4 holds (y_{t-1}, y_t).
        let window = [0, 1, 2, 3, 0, 1, 2, 3];
        let m = AgentModel::fit(&window, 2, 2, &traces);
        let plan = m.plan(&window, 1.0, m.longest, 0.0, &[0; 4]);
        // Node q holds y_{t-1} = q / 2: decide it.
        assert_eq!(plan.controller.act, vec![0, 0, 1, 1]);
        let none = AgentModel::fit(&[0, 0], 2, 2, &traces);
        let memoryless = none.plan(&[0, 0], 1.0, none.longest, 0.0, &[0]);
        assert!(plan.value > memoryless.value, "{} vs {}", plan.value, memoryless.value);
    }

    #[test]
    fn pessimism_lowers_what_few_steps_support_and_unvisited_nodes_keep_their_fallback() {
        let traces = echo_traces();
        let window = [0, 1, 2, 3, 0, 1, 2, 3];
        let m = AgentModel::fit(&window, 2, 2, &traces);
        let bold = m.plan(&window, 1.0, 3, 0.0, &[0; 4]).value;
        let careful = m.plan(&window, 1.0, 3, 1.0, &[0; 4]).value;
        assert!(careful < bold);
        // A memory of three nodes whose third is never entered keeps its fallback decision there.
        let three = [0, 1, 0, 1, 2, 2];
        let m3 = AgentModel::fit(&three, 2, 2, &traces);
        assert_eq!(m3.plan(&three, 1.0, 3, 0.0, &[0, 0, 1]).controller.act[2], 1);
    }
}
