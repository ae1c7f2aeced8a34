//! Lenses (model §10): memories that hold the last observations of an episode and its first, and
//! whose agent state is the part of them a decision looks at: some lags of a window (lag 0 the
//! current observation) and, or not, the first observation. A lens's agent states are few (a
//! task that repeats the card four steps back needs one lag: as many states as cards), so its
//! model is learnt from few steps, while the machine that carries it holds every observation up
//! to its oldest lag. Every lens of a few features is ranked on the model of the same steps.

use serde::{Deserialize, Serialize};

use crate::episodes::trace::Traces;
use crate::policy::controller::Controller;

/// What a decision looks at.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct Lens {
    /// Bit `j`: the observation `j` steps before the current one (bit 0 the current one).
    pub lags: u32,
    /// The episode's first observation.
    pub first: bool,
    /// The decision of the step before.
    pub decision: bool,
}

/// A world's sizes as a lens sees them.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Sizes {
    /// Observations.
    pub y: usize,
    /// Decisions.
    pub a: usize,
}

impl Lens {
    /// Every lens of at most `most` features (lags below `window`, the first observation, the
    /// decision before) whose machine has at most `max_nodes` nodes, fewest features first.
    pub fn all(window: usize, most: usize, sizes: Sizes, max_nodes: usize) -> Vec<Lens> {
        let window = window.min(31);
        let mut lenses: Vec<Lens> = (0u32..1 << window)
            .flat_map(|lags| {
                [(false, false), (true, false), (false, true), (true, true)].map(|(first, decision)| Lens {
                    lags,
                    first,
                    decision,
                })
            })
            .filter(|l| l.features() <= most && l.nodes(sizes) <= max_nodes as u128)
            .collect();
        lenses.sort_by_key(|l| l.features());
        lenses
    }

    /// The features looked at.
    pub fn features(self) -> usize {
        self.lags.count_ones() as usize + usize::from(self.first) + usize::from(self.decision)
    }

    /// Past observations the machine holds: the oldest lag looked at.
    pub fn depth(self) -> usize {
        if self.lags == 0 { 0 } else { 31 - self.lags.leading_zeros() as usize }
    }

    /// Nodes of the machine ([`Lens::controller`]): each past observation held, or none yet, and
    /// the first observation and the decision before, or none yet, where they are looked at.
    pub fn nodes(self, sizes: Sizes) -> u128 {
        let symbols = sizes.y as u128 + 1;
        symbols
            .saturating_pow(self.depth() as u32)
            .saturating_mul(if self.first { symbols } else { 1 })
            .saturating_mul(if self.decision { sizes.a as u128 + 1 } else { 1 })
    }

    /// Agent states: the values of the features looked at (a past observation or decision may be
    /// none yet).
    pub fn states(self, sizes: Sizes) -> usize {
        let Sizes { y, a } = sizes;
        (0..32).filter(|j| self.lags >> j & 1 == 1).map(|j| if j == 0 { y } else { y + 1 }).product::<usize>()
            * if self.first { y } else { 1 }
            * if self.decision { a + 1 } else { 1 }
    }

    /// The agent state of a step that observes `current`, with `past(j)` the observation `j`
    /// steps before plus one (0: none, before the episode's start), the episode's `first` and
    /// `before` the decision of the step before plus one (0 at the first step).
    fn state(self, sizes: Sizes, current: usize, past: impl Fn(usize) -> usize, first: usize, before: usize) -> usize {
        let Sizes { y, a } = sizes;
        let mut s = 0;
        for j in (0..32).filter(|j| self.lags >> j & 1 == 1) {
            s = if j == 0 { s * y + current } else { s * (y + 1) + past(j) };
        }
        if self.first {
            s = s * y + first;
        }
        if self.decision { s * (a + 1) + before } else { s }
    }

    /// The agent state of every kept step.
    pub fn replay(self, sizes: Sizes, traces: &Traces) -> Vec<u32> {
        let mut states = Vec::with_capacity(traces.steps());
        for episode in traces.episodes() {
            let first = traces.obs[episode.start] as usize;
            for t in episode.clone() {
                let past = |j: usize| if t >= episode.start + j { traces.obs[t - j] as usize + 1 } else { 0 };
                let before = if t > episode.start { traces.dec[t - 1] as usize + 1 } else { 0 };
                states.push(self.state(sizes, traces.obs[t] as usize, past, first, before) as u32);
            }
        }
        states
    }

    /// The Mealy machine that decides `act[s]` in agent state `s`. Its node holds, plus one each
    /// (0: none yet), the decision before where looked at (the lowest digit), the last `depth`
    /// observations (the latest lowest) and the first where looked at (the highest), so that
    /// node 0 is the start. `nodes(sizes)` must fit a `usize`.
    pub fn controller(self, act: &[u32], sizes: Sizes) -> Controller {
        let (depth, symbols, y) = (self.depth(), sizes.y + 1, sizes.y);
        let held = symbols.pow(depth as u32);
        let decisions = if self.decision { sizes.a + 1 } else { 1 };
        let nodes = self.nodes(sizes) as usize;
        let (mut on, mut next) = (Vec::with_capacity(nodes * y), Vec::with_capacity(nodes * y));
        for q in 0..nodes {
            let (before, rest) = (q % decisions, q / decisions);
            let (first, window) = (rest / held, rest % held);
            let digit = |j: usize| window / symbols.pow(j as u32 - 1) % symbols;
            for o in 0..y {
                let first_now = if first == 0 { o + 1 } else { first };
                let d = act[self.state(sizes, o, digit, first_now - 1, before)];
                on.push(d);
                let shifted = if depth == 0 { 0 } else { (window * symbols + o + 1) % held };
                let rest = if self.first { first_now * held } else { 0 } + shifted;
                let before = if self.decision { d as usize + 1 } else { 0 };
                next.push((rest * decisions + before) as u32);
            }
        }
        Controller::mealy(on, next, y)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Episodes of three observations of two kinds, every sequence once, decisions all 0.
    fn traces() -> Traces {
        let mut traces = Traces::default();
        // Node y + 1 after y, deciding y there (Moore; node 0, deciding 2, is left at once).
        let echo = Controller::moore(vec![2, 0, 1], vec![1, 2, 1, 2, 1, 2]);
        for sequence in 0..8usize {
            let obs = [sequence >> 2 & 1, sequence >> 1 & 1, sequence & 1];
            traces.add(&echo, 2, obs.into_iter().map(|y| (y, 0.0)));
        }
        traces
    }

    const SIZES: Sizes = Sizes { y: 2, a: 3 };

    #[test]
    fn lenses_are_counted_by_their_features_and_machines() {
        let all = Lens::all(3, 2, SIZES, usize::MAX);
        // Lags 0, 1, 2, the first and the decision before: 1 + 5 + 10 lenses of at most two.
        assert_eq!(all.len(), 16);
        assert_eq!(all[0], Lens { lags: 0, first: false, decision: false });
        let l = Lens { lags: 0b101, first: true, decision: true };
        assert_eq!((l.features(), l.depth(), l.nodes(SIZES), l.states(SIZES)), (4, 2, 108, 48));
        // A lag of 2 holds two past observations: 9 nodes, more than 8.
        assert!(Lens::all(3, 3, SIZES, 8).iter().all(|l| l.depth() < 2));
    }

    #[test]
    fn a_lens_sees_the_lag_and_the_first_observation_it_names() {
        let traces = traces();
        // The observation one step back (0 none, else y + 1), beside the first one.
        let l = Lens { lags: 0b10, first: true, decision: false };
        let states = l.replay(SIZES, &traces);
        let expected: Vec<u32> = (0..8usize)
            .flat_map(|s| {
                let obs = [s >> 2 & 1, s >> 1 & 1, s & 1];
                [0, obs[0] + 1, obs[1] + 1].map(|past| (past * 2 + obs[0]) as u32)
            })
            .collect();
        assert_eq!(states, expected);
        // The decision before (0 none, else d + 1): the echo decides what it observes.
        let l = Lens { lags: 0, first: false, decision: true };
        let expected: Vec<u32> = (0..8usize)
            .flat_map(|s| {
                let obs = [s >> 2 & 1, s >> 1 & 1, s & 1];
                [0, obs[0] as u32 + 1, obs[1] as u32 + 1]
            })
            .collect();
        assert_eq!(l.replay(SIZES, &traces), expected);
    }

    #[test]
    fn its_machine_decides_as_the_lens_sees_on_every_step() {
        for l in Lens::all(3, 4, SIZES, usize::MAX) {
            // A decision for every agent state, varied.
            let act: Vec<u32> = (0..l.states(SIZES) as u32).map(|s| s * 7 % 3).collect();
            let machine = l.controller(&act, SIZES);
            machine.check(2, 3).unwrap();
            // Its own episodes: the decision before is the machine's.
            let mut own = Traces::default();
            for sequence in 0..8usize {
                let obs = [sequence >> 2 & 1, sequence >> 1 & 1, sequence & 1];
                own.add(&machine, 2, obs.into_iter().map(|y| (y, 0.0)));
            }
            let states = l.replay(SIZES, &own);
            for t in 0..own.steps() {
                assert_eq!(own.dec[t], act[states[t] as usize], "{l:?} at step {t}");
            }
        }
    }
}
