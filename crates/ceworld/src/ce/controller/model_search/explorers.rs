//! The explorers of model-search (model §10) and what their steps say without a model: the best
//! so far as an explorer, drawing its decisions at each step ([`Explore`]), and the best so far
//! with each decision row taking the decision its explorers' steps credit most (model §8's credit
//! within episodes).

use rand::RngExt;

use crate::episodes::credit::StepCredit;
use crate::episodes::trace::Traces;
use crate::policy::controller::{Controller, Explore};
use crate::rng::EngineRng;

/// `c` as an explorer: each decision drawn again, uniformly among `actions`, with probability
/// `rate` at each step ([`Explore`]), on top of `c`'s own draws where it has some.
pub(super) fn explorer(c: &Controller, rate: f64, actions: usize, rng: &mut EngineRng) -> Controller {
    let rate = c.explore.map_or(rate, |e| 1.0 - (1.0 - e.rate) * (1.0 - rate));
    let explore = Explore { rate, actions: actions as u32, key: rng.random() };
    Controller { explore: Some(explore), ..c.clone() }
}

/// `c` with each decision row taking the best decision of the steps of `episodes` of `traces`
/// there (episodes of `c` as an explorer, [`StepCredit::best_taken`]), where one was seen;
/// `None` where none was.
pub(super) fn credited_best(
    c: &Controller,
    traces: &Traces,
    episodes: impl Iterator<Item = std::ops::Range<usize>>,
    n_obs: usize,
    actions: usize,
) -> Option<Controller> {
    let best = StepCredit::best_taken(c, traces, episodes, n_obs, actions);
    if best.iter().all(Option::is_none) {
        return None;
    }
    let mut c = Controller { explore: None, ..c.clone() };
    let decisions = if c.is_mealy() { &mut c.on } else { &mut c.act };
    for (d, best) in decisions.iter_mut().zip(best) {
        *d = best.unwrap_or(*d);
    }
    Some(c)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::{Purpose, stream};

    #[test]
    fn each_row_of_the_best_takes_the_decision_of_highest_mean_credit_where_one_was_seen() {
        // A Mealy machine of one node and three observations (rows), three decisions; episodes
        // of one step each (the value still to come is the step's reward), decisions as drawn.
        let best = Controller::mealy(vec![0, 1, 2], vec![0, 0, 0], 3);
        // Row 0: decision 0 means 1.0, decision 2 means 1.5; row 1: decisions 0 and 1 tie at
        // 2.0 (the lower kept); row 2: never met.
        let traces = Traces {
            obs: vec![0, 0, 0, 1, 1],
            dec: vec![0, 0, 2, 0, 1],
            rew: vec![1.0, 1.0, 1.5, 2.0, 2.0],
            prob: vec![1.0; 5],
            ends: vec![1, 2, 3, 4, 5],
            gamma: 1.0,
        };
        assert_eq!(credited_best(&best, &traces, traces.episodes(), 3, 3).unwrap().on, vec![2, 0, 2]);
        // A Moore machine's rows are its nodes (node y after y): of the episodes given only.
        let moore = Controller::moore(vec![1, 1], vec![0, 1, 0, 1]);
        let traces = Traces {
            obs: vec![0, 1, 1],
            dec: vec![0, 0, 1],
            rew: vec![5.0, 1.0, 3.0],
            prob: vec![1.0; 3],
            ends: vec![1, 2, 3],
            gamma: 1.0,
        };
        let credited = credited_best(&moore, &traces, traces.episodes().skip(1), 2, 2).unwrap();
        assert_eq!((credited.act, credited.next), (vec![1, 1], moore.next.clone()));
        // Within an episode, a step is credited with what is still to come: node 1 then node 1,
        // deciding 0 (3 + 1 to come) then 1 (1 to come).
        let two = Traces { ends: vec![3], obs: vec![1, 1, 1], dec: vec![0, 0, 1], ..traces.clone() };
        assert_eq!(credited_best(&moore, &two, two.episodes(), 2, 2).unwrap().act, vec![1, 0]);
        assert_eq!(credited_best(&moore, &traces, traces.episodes().skip(3), 2, 2), None);
    }

    #[test]
    fn an_explorer_s_draws_are_a_function_of_its_episode_and_step_at_the_rate_asked() {
        let best = Controller::moore(vec![1], vec![0; 2]);
        let e = explorer(&best, 0.3, 4, &mut stream(0, Purpose::Init, 0, 0));
        let mut drawn = 0;
        for episode in 0..200 {
            let (mut walk, mut again) = (e.walk(2, episode), e.walk(2, episode));
            for t in 0..50 {
                let (d, p) = walk.step(t % 2);
                assert_eq!(again.step(t % 2), (d, p), "episode {episode} step {t}");
                drawn += usize::from(d != 1);
                // Drawn again with probability 0.3, uniformly among 4: 0.3 / 4 each.
                let expected = if d == 1 { 0.7 + 0.075 } else { 0.075 };
                assert!((p - expected).abs() < 1e-12, "{p} for decision {d}");
            }
        }
        // 10,000 steps, each off the plan with probability 0.3 · 3/4 = 0.225 (sd about 0.004).
        let off = drawn as f64 / 10_000.0;
        assert!((off - 0.225).abs() < 0.015, "{off}");
        // Another episode draws otherwise.
        let decisions = |k: u64| {
            let mut walk = e.walk(2, k);
            (0..50).map(|t| walk.step(t % 2).0).collect::<Vec<_>>()
        };
        assert_ne!(decisions(0), decisions(1));
        // A walk of the best so far itself takes its plan at every step, with probability 1.
        assert_eq!(best.walk(2, 3).step(0), (1, 1.0));
    }
}
