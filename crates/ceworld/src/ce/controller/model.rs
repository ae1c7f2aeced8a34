//! The empirical model of a candidate memory over every step kept (model §10, memory from every
//! step): the kept episodes replayed through the memory give its agent state at each step (what
//! the memory holds when the step decides); counted, each step weighted by the inverse of its
//! decision's probability ([`Traces::weight`]), they give for each (state, decision) its visits,
//! its mean reward and the law of the next agent state. Value iteration on that model
//! plans the memory's decisions and values it, so that every step taken serves every memory
//! considered, not only the controller that took it.
//!
//! The model is a guess where the agent state is not a sufficient statistic of the past, and it
//! flatters decisions seen rarely: each (state, decision) loses `pessimism · spread / √visits`
//! (`spread` the range of the steps' rewards), and a learner confirms a plan on episodes of the
//! world before it keeps it.

use crate::episodes::trace::Traces;

/// What the kept steps say of a memory's (state, decision) pairs.
#[derive(Clone, Debug, PartialEq)]
pub struct AgentModel {
    /// Agent states of the memory.
    pub states: usize,
    /// Decisions.
    pub actions: usize,
    /// Steps that decided `d` in state `s`, at `s·A + d`.
    pub visits: Vec<u32>,
    /// Their summed weight ([`Traces::weight`]: 1 a step but for an explorer's draws).
    pub weight: Vec<f64>,
    /// Their summed reward, each weighted.
    pub reward: Vec<f64>,
    /// The next states met after pair `p`: `next[from[p]..from[p + 1]]`, each `(state, weight)`,
    /// by state (an episode's last step has none).
    pub next: Vec<(u32, f64)>,
    /// Where each pair's next states begin in `next` (`states·A + 1` entries).
    pub from: Vec<u32>,
    /// Episodes whose first step decided in state `s`.
    pub starts: Vec<u32>,
    /// The largest reward of a step less the smallest.
    pub spread: f64,
    /// The most steps of one episode.
    pub longest: usize,
    /// The agent state of every step, by its index in its episode: those of index `t` at
    /// `timeline[at[t]..at[t + 1]]`.
    pub timeline: Vec<u32>,
    /// Where the states of each step index begin in `timeline` (`longest + 1` entries).
    pub at: Vec<u32>,
}

/// A memory's decisions planned on its model, and the model's value of them.
#[derive(Clone, Debug, PartialEq)]
pub struct Planned {
    /// The decision of each agent state.
    pub act: Vec<u32>,
    /// The model's mean value of the kept episodes' starts.
    pub value: f64,
}

/// The agent state of every kept step under a successor table (a controller's `next`,
/// `successor[q·Y + y]`, from node 0): the node each step decides in.
pub fn replay(successor: &[u32], observations: usize, traces: &Traces) -> Vec<u32> {
    let mut state = Vec::with_capacity(traces.steps());
    for episode in traces.episodes() {
        let mut q = 0usize;
        for t in episode {
            q = successor[q * observations + traces.obs[t] as usize] as usize;
            state.push(q as u32);
        }
    }
    state
}

impl AgentModel {
    /// The model of a memory whose agent state at kept step `t` is `state[t]` (one of `states`),
    /// over the episodes of `traces` (those of parity `half` only, where given).
    pub fn fit(state: &[u32], states: usize, actions: usize, traces: &Traces, half: Option<usize>) -> AgentModel {
        let pairs = states * actions;
        let mut m = AgentModel {
            states,
            actions,
            visits: vec![0; pairs],
            weight: vec![0.0; pairs],
            reward: vec![0.0; pairs],
            next: Vec::new(),
            from: vec![0; pairs + 1],
            starts: vec![0; states],
            spread: 0.0,
            longest: 0,
            timeline: Vec::new(),
            at: Vec::new(),
        };
        let pair = |t: usize| state[t] as usize * actions + traces.dec[t] as usize;
        let (mut low, mut high) = (f64::INFINITY, f64::NEG_INFINITY);
        let chosen = |e: usize| half.is_none_or(|h| e % 2 == h);
        let episodes = || traces.episodes().enumerate().filter(|&(e, _)| chosen(e)).map(|(_, range)| range);
        for episode in episodes() {
            if episode.is_empty() {
                continue;
            }
            m.longest = m.longest.max(episode.len());
            m.starts[state[episode.start] as usize] += 1;
            for t in episode.clone() {
                let (p, r, w) = (pair(t), traces.rew[t], traces.weight(t));
                m.visits[p] += 1;
                m.weight[p] += w;
                m.reward[p] += w * r;
                (low, high) = (low.min(r), high.max(r));
                if t + 1 < episode.end {
                    m.from[p + 1] += 1;
                }
            }
        }
        m.spread = if high > low { high - low } else { 0.0 };
        // The states by step index (a counting sort): `at[t + 1] - at[t]` episodes reach index `t`.
        let mut lengths = vec![0u32; m.longest + 1];
        for episode in episodes() {
            lengths[episode.len()] += 1;
        }
        let mut reaching: u32 = lengths.iter().sum();
        m.at = vec![0; m.longest + 1];
        for (t, &ended) in lengths[..m.longest].iter().enumerate() {
            reaching -= ended;
            m.at[t + 1] = m.at[t] + reaching;
        }
        let mut fill: Vec<u32> = m.at.clone();
        m.timeline = vec![0; m.at[m.longest] as usize];
        for episode in episodes() {
            for (i, t) in episode.enumerate() {
                m.timeline[fill[i] as usize] = state[t];
                fill[i] += 1;
            }
        }
        // The successors of each pair in place (a counting sort), then sorted and counted.
        for p in 0..pairs {
            m.from[p + 1] += m.from[p];
        }
        let mut fill: Vec<u32> = m.from[..pairs].to_vec();
        let mut to = vec![(0u32, 0.0); m.from[pairs] as usize];
        for episode in episodes() {
            for t in episode.start..episode.end.saturating_sub(1) {
                let p = pair(t);
                to[fill[p] as usize] = (state[t + 1], traces.weight(t));
                fill[p] += 1;
            }
        }
        let mut from = vec![0u32; pairs + 1];
        for p in 0..pairs {
            let run = &mut to[m.from[p] as usize..m.from[p + 1] as usize];
            run.sort_unstable_by_key(|&(s, _)| s);
            for &(s, w) in run.iter() {
                let ours = m.next.len() > from[p] as usize;
                match m.next.last_mut() {
                    Some((last, weight)) if ours && *last == s => *weight += w,
                    _ => m.next.push((s, w)),
                }
            }
            from[p + 1] = m.next.len() as u32;
        }
        m.from = from;
        m
    }

    /// The decisions that value iteration on the model chooses, and the model's value of the
    /// episodes' starts under the best decisions at each time.
    ///
    /// `horizon` backups discounted by `gamma`, each (state, decision) less `pessimism · spread /
    /// √visits`. Backup `k` values each decision with `k` steps to go, which is what a step of
    /// index `longest − k` has: a memory that does not hold the time decides, in each state, what
    /// is best summed over the steps that met that state ([`AgentModel::timeline`]), not what is
    /// best with the longest episode still ahead. A state never visited keeps `fallback`'s decision.
    pub fn plan(&self, gamma: f64, horizon: usize, pessimism: f64, fallback: &[u32]) -> Planned {
        let (n, a) = (self.states, self.actions);
        let penalty: Vec<f64> = self
            .visits
            .iter()
            .map(|&v| if v == 0 { 0.0 } else { pessimism * self.spread / f64::from(v).sqrt() })
            .collect();
        let (mut value, mut fresh) = (vec![0.0; n], vec![0.0; n]);
        let mut q = vec![0.0; n * a];
        let mut score = vec![0.0; n * a];
        for k in 1..=horizon.max(1) {
            for (s, fresh) in fresh.iter_mut().enumerate() {
                let mut best: Option<f64> = None;
                for p in (s * a..(s + 1) * a).filter(|&p| self.visits[p] > 0) {
                    q[p] = self.q(p, gamma, &value) - penalty[p];
                    if best.is_none_or(|b| q[p] > b) {
                        best = Some(q[p]);
                    }
                }
                *fresh = best.unwrap_or(0.0);
            }
            if let Some(t) = self.longest.checked_sub(k) {
                for &s in &self.timeline[self.at[t] as usize..self.at[t + 1] as usize] {
                    let s = s as usize;
                    for p in s * a..(s + 1) * a {
                        score[p] += q[p];
                    }
                }
            }
            std::mem::swap(&mut value, &mut fresh);
        }
        let mut act: Vec<u32> = fallback.to_vec();
        for (s, decision) in act.iter_mut().enumerate() {
            let seen = (0..a).filter(|&d| self.visits[s * a + d] > 0);
            if let Some(d) = seen.max_by(|&d, &e| score[s * a + d].total_cmp(&score[s * a + e]).then(e.cmp(&d))) {
                *decision = d as u32;
            }
        }
        Planned { act, value: self.start_value(&value) }
    }

    /// The model's value of the episodes' starts when state `s` decides `act[s]` (`horizon`
    /// backups discounted by `gamma`, no doubt); where that pair was never seen, what the steps
    /// did there: the state's pairs seen, weighted by their steps' weights.
    pub fn evaluate(&self, act: &[u32], gamma: f64, horizon: usize) -> f64 {
        let (n, a) = (self.states, self.actions);
        let (mut value, mut fresh) = (vec![0.0; n], vec![0.0; n]);
        for _ in 0..horizon.max(1) {
            for s in 0..n {
                let p = s * a + act[s] as usize;
                fresh[s] = if self.visits[p] > 0 {
                    self.q(p, gamma, &value)
                } else {
                    let seen = (s * a..(s + 1) * a).filter(|&p| self.visits[p] > 0);
                    let (sum, weight) = seen.fold((0.0, 0.0), |(sum, weight), p| {
                        (sum + self.q(p, gamma, &value) * self.weight[p], weight + self.weight[p])
                    });
                    if weight > 0.0 { sum / weight } else { 0.0 }
                };
            }
            std::mem::swap(&mut value, &mut fresh);
        }
        self.start_value(&value)
    }

    /// The mean reward of pair `p` and its next states' values by `value`, discounted by `gamma`.
    fn q(&self, p: usize, gamma: f64, value: &[f64]) -> f64 {
        let ahead: f64 = self.next[self.from[p] as usize..self.from[p + 1] as usize]
            .iter()
            .map(|&(to, weight)| weight * value[to as usize])
            .sum();
        (self.reward[p] + gamma * ahead) / self.weight[p]
    }

    /// The mean of `value` over the episodes' starts.
    fn start_value(&self, value: &[f64]) -> f64 {
        let episodes: u32 = self.starts.iter().sum();
        let start = self.starts.iter().zip(value).map(|(&s, &v)| f64::from(s) * v).sum::<f64>();
        start / f64::from(episodes.max(1))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::policy::controller::Controller;

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
                traces.add(&constant, 2, 0, (0..3).map(|t| (obs[t], reward(t))));
            }
        }
        traces
    }

    #[test]
    fn the_kept_steps_are_counted_per_node_and_decision() {
        let traces = echo_traces();
        // Memoryless: one node whatever it observes.
        let m = AgentModel::fit(&replay(&[0, 0], 2, &traces), 1, 2, &traces, None);
        assert_eq!(m.visits, vec![24, 24]);
        assert_eq!(m.starts, vec![16]);
        assert_eq!((m.spread, m.longest), (1.0, 3));
        // Steps 2 and 3 pay where the observation before is the decision: half the sequences each.
        assert_eq!(m.reward, vec![8.0, 8.0]);
        // Eight episodes of three steps per decision: two steps each lead on, to the one state.
        assert_eq!(m.next, vec![(0, 16.0), (0, 16.0)]);
        assert_eq!(m.weight, vec![24.0, 24.0]);
        assert_eq!(m.from, vec![0, 1, 2]);
        // A window of two: the next states of each pair by state, each counted once per step.
        let window = [0, 1, 2, 3, 0, 1, 2, 3];
        let w = AgentModel::fit(&replay(&window, 2, &traces), 4, 2, &traces, None);
        let of = |p: usize| w.next[w.from[p] as usize..w.from[p + 1] as usize].to_vec();
        // State 1 holds (0, 1) (or 1 first): after it, (1, 0) or (1, 1), each as often; decided 0
        // at the first step of four sequences and the second of two.
        assert_eq!(of(2), vec![(2, 3.0), (3, 3.0)]);
        assert_eq!(w.from[8] as usize, w.next.len());
        assert_eq!(w.next.iter().map(|&(_, c)| c).sum::<f64>(), 32.0);
    }

    #[test]
    fn each_step_counts_with_the_inverse_of_its_decision_s_probability() {
        // One state; decision 0 taken with probability 1/2 (reward 1) then 1 (reward 0) in the
        // first episode, decision 1 with probability 1/4 (reward 2) alone in the second.
        let traces = Traces {
            obs: vec![0, 0, 0],
            dec: vec![0, 0, 1],
            rew: vec![1.0, 0.0, 2.0],
            prob: vec![0.5, 1.0, 0.25],
            ends: vec![2, 3],
            gamma: 1.0,
        };
        let m = AgentModel::fit(&replay(&[0], 1, &traces), 1, 2, &traces, None);
        assert_eq!(
            (m.visits.clone(), m.weight.clone(), m.reward.clone()),
            (vec![2, 1], vec![3.0, 4.0], vec![2.0, 8.0])
        );
        // The first step led on with its weight; the last steps of episodes lead nowhere.
        assert_eq!(m.next, vec![(0, 2.0)]);
        // One step to go: decision 0 is worth 2/3, decision 1 is worth 8/4.
        assert_eq!(m.evaluate(&[0], 1.0, 1), 2.0 / 3.0);
        assert_eq!(m.evaluate(&[1], 1.0, 1), 2.0);
    }

    #[test]
    fn a_memory_of_the_last_two_observations_plans_to_repeat_the_previous_one() {
        let traces = echo_traces();
        // A window of two (model §8's "window" template): node (q·Y + y) mod 4 holds (y_{t-1}, y_t).
        let window = [0, 1, 2, 3, 0, 1, 2, 3];
        let m = AgentModel::fit(&replay(&window, 2, &traces), 4, 2, &traces, None);
        let plan = m.plan(1.0, m.longest, 0.0, &[0; 4]);
        // Node q holds y_{t-1} = q / 2: decide it.
        assert_eq!(plan.act, vec![0, 0, 1, 1]);
        let none = AgentModel::fit(&replay(&[0, 0], 2, &traces), 1, 2, &traces, None);
        let memoryless = none.plan(1.0, none.longest, 0.0, &[0]);
        // Valued as planned, without doubt, the plan is worth what planning said.
        assert_eq!(m.evaluate(&plan.act, 1.0, m.longest), plan.value);
        // The two halves of the episodes share the steps.
        let halves = [0, 1].map(|h| AgentModel::fit(&replay(&window, 2, &traces), 4, 2, &traces, Some(h)));
        let visits = |h: usize| halves[h].visits.iter().sum::<u32>();
        assert_eq!((visits(0), visits(1)), (24, 24));
        assert!(plan.value > memoryless.value, "{} vs {}", plan.value, memoryless.value);
    }

    #[test]
    fn a_state_decides_what_is_best_over_the_steps_that_met_it_not_with_the_longest_episode_ahead() {
        // Episodes of two steps, the agent state the observation. Investing (decision 1) in state
        // 0 pays nothing but leads to state 1, which pays 3; cashing (decision 0) pays 1. State 0
        // is met once at the first step (invested) and twice at the last (cashed once, invested once).
        let traces = Traces {
            obs: vec![0, 1, 1, 0, 1, 0],
            dec: vec![1, 0, 0, 0, 0, 1],
            rew: vec![0.0, 3.0, 3.0, 1.0, 3.0, 0.0],
            prob: vec![1.0; 6],
            ends: vec![2, 4, 6],
            gamma: 1.0,
        };
        let by_observation = [0, 1, 0, 1];
        let m = AgentModel::fit(&replay(&by_observation, 2, &traces), 2, 2, &traces, None);
        assert_eq!((m.longest, m.at.clone(), m.timeline.clone()), (2, vec![0, 3, 6], vec![0, 1, 1, 1, 0, 0]));
        // With two steps to go, investing is worth (0 + 3) / 2 (one of its two steps led on), more
        // than cashing's 1; with one step to go, 0 against 1. Summed over the steps that met state
        // 0 (one with two steps to go, two with one), cashing: 1 + 2·1 = 3 against 1.5 + 2·0.
        let plan = m.plan(1.0, m.longest, 0.0, &[1, 1]);
        assert_eq!(plan.act, vec![0, 0]);
        // Backups past the longest episode have no step to decide: the same plan.
        assert_eq!(m.plan(1.0, 4 * m.longest, 0.0, &[1, 1]).act, plan.act);
    }

    #[test]
    fn pessimism_lowers_what_few_steps_support_and_unvisited_nodes_keep_their_fallback() {
        let traces = echo_traces();
        let window = [0, 1, 2, 3, 0, 1, 2, 3];
        let m = AgentModel::fit(&replay(&window, 2, &traces), 4, 2, &traces, None);
        let bold = m.plan(1.0, 3, 0.0, &[0; 4]).value;
        let careful = m.plan(1.0, 3, 1.0, &[0; 4]).value;
        assert!(careful < bold);
        // A memory of three nodes whose third is never entered keeps its fallback decision there.
        let three = [0, 1, 0, 1, 2, 2];
        let m3 = AgentModel::fit(&replay(&three, 2, &traces), 3, 2, &traces, None);
        assert_eq!(m3.plan(1.0, 3, 0.0, &[0, 0, 1]).act[2], 1);
    }
}
