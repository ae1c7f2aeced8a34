//! Lenses (model §10): memories that hold the last steps of an episode (their observations and
//! decisions) and its first observation, and whose agent state is the part of them a decision
//! looks at: some lags of a window (observation lag 0 the current one) and, or not, the first
//! observation. A lens's agent states are few (a task that repeats the card four steps back needs
//! one lag: as many states as cards), so its model is learnt from few steps, while the machine
//! that carries it holds every observation (what its view sees of it) and decision up to its
//! oldest lag. Where an observation is made of parts (the dimensions of a `Box` cut into bins:
//! [`Sizes::radices`]), a lens may look at some of them only (its `view`), so that a lag of the
//! one part that matters does not multiply the states by the others. Every lens of a few features is ranked on the model of the same steps.

use serde::{Deserialize, Serialize};
use serde_json::Value;

use crate::episodes::Shape;
use crate::episodes::trace::Traces;
use crate::policy::controller::Controller;

/// What a decision looks at.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct Lens {
    /// Bit `j`: the observation `j` steps before the current one (bit 0 the current one).
    pub lags: u32,
    /// Bit `j` (from 1): the decision `j` steps before.
    pub decisions: u32,
    /// The episode's first observation.
    pub first: bool,
    /// Bit `f`: part `f` of the observations looked at ([`Sizes::radices`]; all of them where
    /// the observation is one part).
    #[serde(default)]
    pub view: u32,
}

/// The most parts an observation is seen as made of ([`Sizes::radices`]).
pub const MOST_PARTS: usize = 8;

/// A world's sizes as a lens sees them.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Sizes {
    /// Observations.
    pub y: usize,
    /// Decisions.
    pub a: usize,
    /// The observation's parts (its row-major digits: `y` is `radices[0] · radices[1] · …`, the
    /// first the most significant), `parts` of them.
    pub radices: [usize; MOST_PARTS],
    /// How many.
    pub parts: usize,
}

impl Sizes {
    /// `y` observations of one part, `a` decisions.
    pub fn new(y: usize, a: usize) -> Sizes {
        let mut radices = [1; MOST_PARTS];
        radices[0] = y;
        Sizes { y, a, radices, parts: 1 }
    }

    /// `y` observations made of parts of `radices` values each (one part where they are more
    /// than [`MOST_PARTS`], fewer than two, one of them has a single value, or their product is
    /// not `y`).
    pub fn parts(y: usize, a: usize, radices: &[usize]) -> Sizes {
        let product = radices.iter().try_fold(1usize, |p, &r| p.checked_mul(r));
        if radices.len() < 2 || radices.len() > MOST_PARTS || product != Some(y) || radices.contains(&1) {
            return Sizes::new(y, a);
        }
        let mut sizes = Sizes::new(y, a);
        sizes.radices[..radices.len()].copy_from_slice(radices);
        sizes.parts = radices.len();
        sizes
    }

    /// A world's sizes, its observation's parts read from its description (its
    /// `spaces.observation.radices`, where its encoding gives them: `cehmm.spaces`).
    pub fn of(shape: Shape, description: &Value) -> Sizes {
        let radices = description.pointer("/spaces/observation/radices").and_then(Value::as_array);
        let radices: Option<Vec<usize>> =
            radices.and_then(|r| r.iter().map(|v| v.as_u64().and_then(|v| usize::try_from(v).ok())).collect());
        Sizes::parts(shape.observations, shape.decisions, radices.as_deref().unwrap_or(&[]))
    }

    /// The view of every part.
    pub fn whole(self) -> u32 {
        (1 << self.parts) - 1
    }

    /// The views of one part each (where the observation has several), then of the whole.
    pub fn views(self) -> impl Iterator<Item = u32> {
        (0..if self.parts > 1 { self.parts } else { 0 }).map(|f| 1 << f).chain([self.whole()])
    }

    /// Values of the parts of `view`.
    pub fn seen(self, view: u32) -> usize {
        set(view & self.whole()).map(|f| self.radices[f]).product()
    }

    /// The parts of `view` of observation `y`, as one number (row-major).
    pub fn project(self, view: u32, y: usize) -> usize {
        if view & self.whole() == self.whole() {
            return y;
        }
        let mut digits = [0; MOST_PARTS];
        let mut rest = y;
        for f in (0..self.parts).rev() {
            digits[f] = rest % self.radices[f];
            rest /= self.radices[f];
        }
        set(view & self.whole()).fold(0, |s, f| s * self.radices[f] + digits[f])
    }
}

/// The highest bit set (0 where none).
fn oldest(bits: u32) -> usize {
    if bits == 0 { 0 } else { 31 - bits.leading_zeros() as usize }
}

/// Every subset of `0..n` of at most `most` members, each in increasing order.
fn subsets(n: usize, most: usize) -> Vec<Vec<usize>> {
    let mut out = vec![Vec::new()];
    let mut from = 0;
    for _ in 0..most {
        let grown: Vec<Vec<usize>> = out[from..]
            .iter()
            .flat_map(|s| {
                let start = s.last().map_or(0, |&k| k + 1);
                (start..n).map(move |k| [s.as_slice(), &[k]].concat())
            })
            .collect();
        from = out.len();
        out.extend(grown);
    }
    out
}

/// The bits set, lowest first.
fn set(bits: u32) -> impl Iterator<Item = usize> {
    (0..32).filter(move |j| bits >> j & 1 == 1)
}

impl Lens {
    /// Every lens of at most `most` features (observations of lags below `window`, decisions of
    /// lags 1 to `window - 1`, the first observation), each that looks at an observation once per
    /// view (each part alone, the whole observation), whose machine has at most `max_nodes` nodes,
    /// fewest features first.
    pub fn all(window: usize, most: usize, sizes: Sizes, max_nodes: usize) -> Vec<Lens> {
        let window = window.min(31);
        // Feature k: observation lag k (k < window), decision lag k - window + 1, the first.
        let features = 2 * window;
        let lens_of = |chosen: &[usize]| {
            let mut l = Lens { lags: 0, decisions: 0, first: false, view: sizes.whole() };
            for &k in chosen {
                match k {
                    k if k < window => l.lags |= 1 << k,
                    k if k + 1 < features => l.decisions |= 1 << (k - window + 1),
                    _ => l.first = true,
                }
            }
            l
        };
        // One part or the whole observation (views of several parts among many would multiply
        // the lenses by their subsets); a lens that looks at no observation, the whole.
        let views = move |l: Lens| {
            let looks = l.lags != 0 || l.first;
            sizes.views().filter(move |&view| looks || view == sizes.whole()).map(move |view| Lens { view, ..l })
        };
        let mut lenses: Vec<Lens> = subsets(features, most)
            .iter()
            .map(|s| lens_of(s))
            .flat_map(views)
            .filter(|l| l.nodes(sizes) <= max_nodes as u128)
            .collect();
        lenses.sort_by_key(|l| l.features());
        lenses
    }

    /// The features looked at.
    pub fn features(self) -> usize {
        (self.lags.count_ones() + self.decisions.count_ones()) as usize + usize::from(self.first)
    }

    /// Nodes of the machine ([`Lens::controller`]): the parts of the view of each past
    /// observation held, or none yet, each past decision held, or none yet, and the parts of the
    /// view of the first observation, or none yet, where it is looked at.
    pub fn nodes(self, sizes: Sizes) -> u128 {
        let (y, a) = (sizes.seen(self.view) as u128 + 1, sizes.a as u128 + 1);
        y.saturating_pow(oldest(self.lags) as u32)
            .saturating_mul(a.saturating_pow(oldest(self.decisions) as u32))
            .saturating_mul(if self.first { y } else { 1 })
    }

    /// Agent states: the values of the features looked at (a past observation or decision may be
    /// none yet).
    pub fn states(self, sizes: Sizes) -> usize {
        let (y, a) = (sizes.seen(self.view), sizes.a);
        set(self.lags).map(|j| if j == 0 { y } else { y + 1 }).product::<usize>()
            * (a + 1).pow(self.decisions.count_ones())
            * if self.first { y } else { 1 }
    }

    /// The agent state of a step whose observation's view is `current`, with `past(j)` the
    /// view of the observation `j` steps before plus one and `before(j)` the decision `j` steps
    /// before plus one (0: none, before the episode's start), and the view of the episode's
    /// `first` observation.
    fn state(
        self,
        sizes: Sizes,
        current: usize,
        past: impl Fn(usize) -> usize,
        before: impl Fn(usize) -> usize,
        first: usize,
    ) -> usize {
        let (y, a) = (sizes.seen(self.view), sizes.a);
        let mut s = 0;
        for j in set(self.lags) {
            s = if j == 0 { s * y + current } else { s * (y + 1) + past(j) };
        }
        for j in set(self.decisions) {
            s = s * (a + 1) + before(j);
        }
        if self.first { s * y + first } else { s }
    }

    /// The agent state of every kept step.
    pub fn replay(self, sizes: Sizes, traces: &Traces) -> Vec<u32> {
        let mut states = Vec::with_capacity(traces.steps());
        // The view of each observation, projected once.
        let views: Vec<usize> = (0..sizes.y).map(|o| sizes.project(self.view, o)).collect();
        let seen = |o: u32| views[o as usize];
        for episode in traces.episodes() {
            let first = seen(traces.obs[episode.start]);
            for t in episode.clone() {
                let inside = |j: usize| t >= episode.start + j;
                let past = |j: usize| if inside(j) { seen(traces.obs[t - j]) + 1 } else { 0 };
                let before = |j: usize| if inside(j) { traces.dec[t - j] as usize + 1 } else { 0 };
                states.push(self.state(sizes, seen(traces.obs[t]), past, before, first) as u32);
            }
        }
        states
    }

    /// The Mealy machine that decides `act[s]` in agent state `s`. Its node holds, plus one each
    /// (0: none yet), the last decisions up to the oldest lag looked at (the latest in the lowest
    /// digit), then the views of the last observations the same way, then the view of the first
    /// where looked at (the highest digit), so that node 0 is the start. `nodes(sizes)` must fit
    /// a `usize`.
    pub fn controller(self, act: &[u32], sizes: Sizes) -> Controller {
        let (y, ys, a1) = (sizes.y, sizes.seen(self.view) + 1, sizes.a + 1);
        let (obs_held, dec_held) = (ys.pow(oldest(self.lags) as u32), a1.pow(oldest(self.decisions) as u32));
        let nodes = self.nodes(sizes) as usize;
        let (mut on, mut next) = (Vec::with_capacity(nodes * y), Vec::with_capacity(nodes * y));
        let views: Vec<usize> = (0..y).map(|o| sizes.project(self.view, o)).collect();
        for q in 0..nodes {
            let (decisions, rest) = (q % dec_held, q / dec_held);
            let (first, window) = (rest / obs_held, rest % obs_held);
            let past = |j: usize| window / ys.pow(j as u32 - 1) % ys;
            let before = |j: usize| decisions / a1.pow(j as u32 - 1) % a1;
            for &seen in &views {
                let first_now = if first == 0 { seen + 1 } else { first };
                let d = act[self.state(sizes, seen, past, before, first_now - 1)];
                on.push(d);
                let window = (window * ys + seen + 1) % obs_held;
                let decisions = (decisions * a1 + d as usize + 1) % dec_held;
                let first_held = if self.first { first_now * obs_held } else { 0 };
                next.push(((first_held + window) * dec_held + decisions) as u32);
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
            traces.add(&echo, 2, 0, obs.into_iter().map(|y| (y, 0.0)));
        }
        traces
    }

    const SIZES: Sizes = Sizes { y: 2, a: 3, radices: [2, 1, 1, 1, 1, 1, 1, 1], parts: 1 };

    #[test]
    fn lenses_are_counted_by_their_features_and_machines() {
        let all = Lens::all(3, 2, SIZES, usize::MAX);
        // Observations of lags 0, 1, 2, decisions of lags 1, 2, the first: 1 + 6 + 15 lenses
        // of at most two features.
        assert_eq!(all.len(), 22);
        assert_eq!(all[0], Lens { lags: 0, decisions: 0, first: false, view: 1 });
        let l = Lens { lags: 0b101, decisions: 0b10, first: true, view: 1 };
        // Nodes: two past observations, one decision, the first (3·3 · 4 · 3); states 2·3 · 4 · 2.
        assert_eq!((l.features(), l.nodes(SIZES), l.states(SIZES)), (4, 108, 48));
        // A lag of 2 holds two past observations: 9 nodes, more than 8.
        assert!(Lens::all(3, 3, SIZES, 8).iter().all(|l| oldest(l.lags) < 2 && oldest(l.decisions) < 2));
    }

    #[test]
    fn a_lens_sees_the_lag_and_the_first_observation_it_names() {
        let traces = traces();
        // The observation one step back (0 none, else y + 1), beside the first one.
        let l = Lens { lags: 0b10, decisions: 0, first: true, view: 1 };
        let states = l.replay(SIZES, &traces);
        let expected: Vec<u32> = (0..8usize)
            .flat_map(|s| {
                let obs = [s >> 2 & 1, s >> 1 & 1, s & 1];
                [0, obs[0] + 1, obs[1] + 1].map(|past| (past * 2 + obs[0]) as u32)
            })
            .collect();
        assert_eq!(states, expected);
        // The decision before (0 none, else d + 1): the echo decides what it observes.
        let l = Lens { lags: 0, decisions: 0b10, first: false, view: 1 };
        let expected: Vec<u32> = (0..8usize)
            .flat_map(|s| {
                let obs = [s >> 2 & 1, s >> 1 & 1, s & 1];
                [0, obs[0] as u32 + 1, obs[1] as u32 + 1]
            })
            .collect();
        assert_eq!(l.replay(SIZES, &traces), expected);
    }

    #[test]
    fn a_lens_may_look_at_some_parts_of_an_observation() {
        // Observations of two parts, of 2 and 3 values (row-major: y = 3·u + v).
        let sizes = Sizes::parts(6, 2, &[2, 3]);
        assert_eq!((sizes.parts, sizes.whole(), sizes.seen(0b01), sizes.seen(0b10), sizes.seen(0b11)), (2, 3, 2, 3, 6));
        assert_eq!([0b01, 0b10, 0b11].map(|view| sizes.project(view, 5)), [1, 2, 5]);
        // Parts that do not make the observations are one part.
        for radices in [&[6][..], &[2, 2], &[1, 6], &[]] {
            assert_eq!(Sizes::parts(6, 2, radices), Sizes::new(6, 2), "{radices:?}");
        }
        let described = serde_json::json!({"spaces": {"observation": {"radices": [2, 3]}}});
        let shape = Shape { observations: 6, decisions: 2, horizon: 3 };
        assert_eq!(Sizes::of(shape, &described), sizes);
        assert_eq!(Sizes::of(shape, &serde_json::json!({})), Sizes::new(6, 2));
        // The current observation's second part: 3 states; every view of each observation lens.
        let l = Lens { lags: 1, decisions: 0, first: false, view: 0b10 };
        assert_eq!((l.states(sizes), l.nodes(sizes)), (3, 1));
        // Its second part two steps back: the machine holds that part of the last two
        // observations (4 · 4 nodes, where whole ones would make 7 · 7).
        let l = Lens { lags: 0b100, decisions: 0, first: false, view: 0b10 };
        assert_eq!((l.states(sizes), l.nodes(sizes)), (4, 16));
        let all = Lens::all(2, 1, sizes, usize::MAX);
        // None; the current, the previous and the first observation, three views each; the
        // decision before.
        assert_eq!(all.len(), 1 + 3 * 3 + 1);
        // Of three parts, each alone or the whole: four views of the current and of the first
        // observation.
        let three = Sizes::parts(12, 2, &[2, 3, 2]);
        let views: Vec<u32> = Lens::all(1, 1, three, usize::MAX).iter().map(|l| l.view).collect();
        assert_eq!(views, [0b111, 0b001, 0b010, 0b100, 0b111, 0b001, 0b010, 0b100, 0b111]);
    }

    /// Episodes of three observations of six values, decided by `machine`.
    fn six(machine: &Controller) -> Traces {
        let mut own = Traces::default();
        for sequence in 0..36usize {
            let obs = [sequence % 6, sequence / 6, (sequence * 5 + 1) % 6];
            own.add(machine, 6, 0, obs.into_iter().map(|y| (y, 0.0)));
        }
        own
    }

    #[test]
    fn its_machine_decides_as_the_lens_sees_on_every_step() {
        let sizes = Sizes::parts(6, 2, &[2, 3]);
        for l in Lens::all(3, 3, sizes, usize::MAX) {
            let act: Vec<u32> = (0..l.states(sizes) as u32).map(|s| s * 7 % 2).collect();
            let machine = l.controller(&act, sizes);
            machine.check(6, 2).unwrap();
            let own = six(&machine);
            let states = l.replay(sizes, &own);
            for t in 0..own.steps() {
                assert_eq!(own.dec[t], act[states[t] as usize], "{l:?} at step {t}");
            }
        }
        for l in Lens::all(3, 4, SIZES, usize::MAX) {
            // A decision for every agent state, varied.
            let act: Vec<u32> = (0..l.states(SIZES) as u32).map(|s| s * 7 % 3).collect();
            let machine = l.controller(&act, SIZES);
            machine.check(2, 3).unwrap();
            // Its own episodes: the decision before is the machine's.
            let mut own = Traces::default();
            for sequence in 0..8usize {
                let obs = [sequence >> 2 & 1, sequence >> 1 & 1, sequence & 1];
                own.add(&machine, 2, 0, obs.into_iter().map(|y| (y, 0.0)));
            }
            let states = l.replay(SIZES, &own);
            for t in 0..own.steps() {
                assert_eq!(own.dec[t], act[states[t] as usize], "{l:?} at step {t}");
            }
        }
    }
}
