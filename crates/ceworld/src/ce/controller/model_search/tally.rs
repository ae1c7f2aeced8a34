//! Tallies (model §10): memories that count, for each value of a part of the observation (or of
//! the whole observation), how many times so far it was observed, and whose agent state is the
//! count of the value another part (or the same one) holds now, the current step counted, and, or
//! not, the current observation. Where the order of past observations does not matter but their
//! numbers do ("how many of the cards dealt were of the colour asked for now", "was this seen
//! before"), no window of lags holds the memory, and a tally does in few agent states: as many as
//! the counts it tells apart. Its machine holds the whole count of every value, each capped at
//! `cap` (counts above it are told as `cap`), so that a tally of `r` values has `(cap + 1)^r`
//! nodes; the cap is the largest that keeps them within the lenses' budget of nodes.

use crate::episodes::trace::Traces;
use crate::policy::controller::Controller;

use crate::ce::controller::lens::Sizes;

/// What a tally counts and what a decision looks at.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Tally {
    /// The view ([`Sizes::project`]) whose values are counted.
    pub of: u32,
    /// The view whose current value names the count looked at (as many values as `of`).
    pub by: u32,
    /// Counts are told apart up to `cap`.
    pub cap: usize,
    /// Whether a decision also looks at the current observation.
    pub current: bool,
}

impl Tally {
    /// Every tally of a view (each part where the observation has several, and the whole one)
    /// looked up by a view of as many values, with the largest cap (at most the horizon, where
    /// known) that keeps its machine within `max_nodes` nodes and at least 1, with and without the
    /// current observation.
    pub fn all(sizes: Sizes, max_nodes: usize, horizon: usize) -> Vec<Tally> {
        let views: Vec<u32> = sizes.views().collect();
        let mut out = Vec::new();
        for &of in &views {
            let r = sizes.seen(of);
            let Some(cap) = largest_cap(r, max_nodes, horizon) else { continue };
            for &by in views.iter().filter(|&&by| sizes.seen(by) == r) {
                out.extend([false, true].map(|current| Tally { of, by, cap, current }));
            }
        }
        out
    }

    /// Nodes of the machine: every capped count of each of the values counted.
    pub fn nodes(self, sizes: Sizes) -> u128 {
        (self.cap as u128 + 1).saturating_pow(sizes.seen(self.of) as u32)
    }

    /// Agent states: the count looked at (0 to `cap`), with the current observation where looked at.
    pub fn states(self, sizes: Sizes) -> usize {
        (self.cap + 1) * if self.current { sizes.y } else { 1 }
    }

    /// The agent state of a step that observes `y`, after `counts` counted it.
    fn state(self, sizes: Sizes, counts: &[usize], y: usize) -> usize {
        let count = counts[sizes.project(self.by, y)];
        if self.current { count * sizes.y + y } else { count }
    }

    /// The counts after observing `y`.
    fn count(self, sizes: Sizes, counts: &mut [usize], y: usize) {
        let v = sizes.project(self.of, y);
        counts[v] = (counts[v] + 1).min(self.cap);
    }

    /// The agent state of every kept step.
    pub fn replay(self, sizes: Sizes, traces: &Traces) -> Vec<u32> {
        let mut states = Vec::with_capacity(traces.steps());
        let mut counts = vec![0; sizes.seen(self.of)];
        for episode in traces.episodes() {
            counts.fill(0);
            for &y in &traces.obs[episode] {
                self.count(sizes, &mut counts, y as usize);
                states.push(self.state(sizes, &counts, y as usize) as u32);
            }
        }
        states
    }

    /// The Mealy machine that decides `act[s]` in agent state `s`. Its node is the counts, the
    /// count of value `v` the digit `v` (the lowest first) in base `cap + 1`, so that node 0 (no
    /// value seen) is the start. `nodes(sizes)` must fit a `usize`.
    pub fn controller(self, act: &[u32], sizes: Sizes) -> Controller {
        let (base, r, y) = (self.cap + 1, sizes.seen(self.of), sizes.y);
        let nodes = self.nodes(sizes) as usize;
        let (mut on, mut next) = (Vec::with_capacity(nodes * y), Vec::with_capacity(nodes * y));
        let mut counts = vec![0; r];
        for q in 0..nodes {
            for o in 0..y {
                let mut rest = q;
                for c in &mut counts {
                    *c = rest % base;
                    rest /= base;
                }
                self.count(sizes, &mut counts, o);
                on.push(act[self.state(sizes, &counts, o)]);
                next.push(counts.iter().rev().fold(0, |n, &c| n * base + c) as u32);
            }
        }
        Controller::mealy(on, next, y)
    }
}

/// The largest cap of at least 1 and at most `horizon` (where it is not 0) whose `(cap + 1)^r`
/// nodes are at most `max_nodes`.
fn largest_cap(r: usize, max_nodes: usize, horizon: usize) -> Option<usize> {
    let fits = |cap: usize| (cap as u128 + 1).checked_pow(r as u32).is_some_and(|n| n <= max_nodes as u128);
    let most = if horizon > 0 { horizon } else { max_nodes };
    if !fits(1) {
        return None;
    }
    let mut cap = 1;
    while cap < most && fits(cap + 1) {
        cap += 1;
    }
    Some(cap)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Observations of two parts of 2 values each (a card's colour, the colour asked for).
    fn sizes() -> Sizes {
        Sizes::parts(4, 5, &[2, 2])
    }

    fn episodes(sequences: &[&[usize]]) -> Traces {
        let mut traces = Traces::default();
        let any = Controller::moore(vec![0], vec![0; 4]);
        for s in sequences {
            traces.add(&any, 4, 0, s.iter().map(|&y| (y, 0.0)));
        }
        traces
    }

    #[test]
    fn tallies_are_every_view_by_one_of_as_many_values() {
        let all = Tally::all(sizes(), 1024, 0);
        // Part 0 by part 0 or 1, part 1 by part 0 or 1 (caps of 31: 32² nodes), the whole by
        // itself (4 values: cap 4, 625 nodes); each with and without the current observation.
        assert_eq!(all.len(), 10);
        assert!(all.iter().all(|t| t.nodes(sizes()) <= 1024));
        assert_eq!(all.iter().map(|t| t.cap).collect::<Vec<_>>(), [31, 31, 31, 31, 31, 31, 31, 31, 4, 4]);
        // The horizon caps the counts; none fits where even a cap of 1 does not.
        assert!(Tally::all(sizes(), 1024, 6).iter().all(|t| t.cap <= 6));
        assert_eq!(Tally::all(Sizes::new(11, 2), 1024, 0).len(), 0);
        assert_eq!(Tally::all(Sizes::new(10, 2), 1024, 0)[0].cap, 1);
    }

    #[test]
    fn a_tally_counts_the_value_asked_for_the_current_step_included() {
        // y = 2 · colour + asked: the colour dealt, then the colour asked for.
        let t = Tally { of: 0b01, by: 0b10, cap: 2, current: false };
        let traces = episodes(&[&[0, 2, 3, 2, 1], &[3, 3]]);
        // Colours dealt 0, 1, 1, 1, 0 (asked 0, 0, 1, 0, 1): counts of the colour asked,
        // capped at 2; a new episode starts from none.
        assert_eq!(t.replay(sizes(), &traces), [1, 1, 2, 1, 2, 1, 2]);
        let with = Tally { current: true, ..t };
        assert_eq!(with.replay(sizes(), &traces), [4, 6, 11, 6, 9, 7, 11]);
        assert_eq!((t.states(sizes()), with.states(sizes()), t.nodes(sizes())), (3, 12, 9));
    }

    #[test]
    fn its_machine_decides_as_the_tally_sees_on_every_step() {
        let sequences: Vec<Vec<usize>> =
            (0..40usize).map(|k| (0..7).map(|t| (k * 7 + t * t * 3 + k / 3) % 4).collect()).collect();
        for t in Tally::all(sizes(), 30, 0) {
            let act: Vec<u32> = (0..t.states(sizes()) as u32).map(|s| s * 7 % 5).collect();
            let machine = t.controller(&act, sizes());
            machine.check(4, 5).unwrap();
            let mut own = Traces::default();
            for s in &sequences {
                own.add(&machine, 4, 0, s.iter().map(|&y| (y, 0.0)));
            }
            let states = t.replay(sizes(), &own);
            for step in 0..own.steps() {
                assert_eq!(own.dec[step], act[states[step] as usize], "{t:?} at step {step}");
            }
        }
    }
}
