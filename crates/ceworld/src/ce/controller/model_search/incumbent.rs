//! The best so far of model-search (model §10), what replaces it, and the contenders that keep
//! their evidence: a plan replaces the best where its gain over it on the same selection
//! episodes, over every iteration both were valued in, is more than the noise of those gains.
//!
//! One iteration's ten episodes cannot tell a best that fails once in thirty episodes from a plan
//! that never fails (their gains are zero on most draws of ten); a plan not worse than the best
//! is valued again in the next iterations beside it, its gains accumulating, until they tell.

use serde::{Deserialize, Serialize};

use crate::evaluate::{Evaluation, mean};
use crate::policy::controller::Controller;

/// The best controller so far, with its mean value over every selection episode it was valued on.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Incumbent {
    /// The controller.
    pub controller: Controller,
    /// Its mean value on the selection episodes it was valued on.
    pub value: f64,
    /// How many.
    pub episodes: usize,
    /// Plans valued beside it, not worse on the episodes both were valued on, not yet better by
    /// the noise of their gains: valued again in the next iteration.
    #[serde(default)]
    pub contenders: Vec<Contender>,
}

/// A plan valued beside the best so far, on the same selection episodes.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Contender {
    /// The controller.
    pub controller: Controller,
    /// Its values on the selection episodes both were valued on, in order.
    pub values: Vec<f64>,
    /// The best so far's on the same ones.
    pub held: Vec<f64>,
}

impl Contender {
    /// Its mean gain over the best so far.
    fn gain(&self) -> f64 {
        mean(self.values.iter().copied()) - mean(self.held.iter().copied())
    }

    /// Whether it beats the best so far by more than `margin` standard errors of its gains
    /// episode by episode (0: by anything). The best of several plans on a few episodes is
    /// biased up; the gains of one plan over the best on the same episodes are not.
    fn beats(&self, margin: f64) -> bool {
        let gains: Vec<f64> = self.values.iter().zip(&self.held).map(|(c, h)| c - h).collect();
        let noise = Evaluation::from_rewards(&gains).std_error.max(0.0);
        self.gain() > margin * noise
    }
}

/// One iteration's verdict: `few` were valued on the same `m` selection episodes (`values`, `m`
/// a controller, in `few`'s order), the best so far last where there is one. The first best is
/// the plan of the highest mean; a best so far is replaced by the plan (or contender, its earlier
/// gains counted) of the highest mean gain among those that beat it by `margin`
/// ([`Contender::beats`]), else its value takes the episodes in. The `keep` of the others of the
/// highest mean gain not below 0 are the best's contenders after it (on a replacement, the old
/// best is one of them, with its record against its successor). True where the best changed.
pub(super) fn settle(
    best: &mut Option<Incumbent>,
    few: &[Controller],
    values: &[f64],
    m: usize,
    margin: f64,
    keep: usize,
) -> bool {
    let on = |k: usize| values[k * m..(k + 1) * m].to_vec();
    let plans = few.len() - usize::from(best.is_some());
    if plans == 0 {
        return false;
    }
    let Some(held) = best.as_mut() else {
        let score = |k: usize| mean(on(k).into_iter());
        let k = (0..plans).fold(0, |b, i| if score(i) > score(b) { i } else { b });
        *best = Some(crowned(k, &on(k), None, plans, few, &on, keep));
        return true;
    };
    // Each plan's record against the best so far, its earlier one first.
    let records: Vec<Contender> = (0..plans)
        .map(|j| {
            let earlier = held.contenders.iter().find(|c| c.controller == few[j]);
            let mut record =
                earlier.cloned().unwrap_or(Contender { controller: few[j].clone(), values: vec![], held: vec![] });
            record.values.extend(on(j));
            record.held.extend(on(plans));
            record
        })
        .collect();
    let winner = (0..plans).filter(|&j| records[j].beats(margin)).fold(None, |b: Option<usize>, j| match b {
        Some(b) if records[b].gain() >= records[j].gain() => Some(b),
        _ => Some(j),
    });
    if let Some(k) = winner {
        let won = &records[k];
        let old = Contender { controller: held.controller.clone(), values: won.held.clone(), held: won.values.clone() };
        *best = Some(crowned(k, &won.values, Some(old), plans, few, &on, keep));
        return true;
    }
    let n = held.episodes + m;
    held.value = (held.value * held.episodes as f64 + mean(on(plans).into_iter()) * m as f64) / n as f64;
    held.episodes = n;
    held.contenders = kept(records, keep);
    false
}

/// `few[k]` the best so far, of values `values`; the other plans of `few[..plans]` its contenders
/// on this iteration's episodes, after `first` (the best it replaces).
fn crowned(
    k: usize,
    values: &[f64],
    first: Option<Contender>,
    plans: usize,
    few: &[Controller],
    on: &dyn Fn(usize) -> Vec<f64>,
    keep: usize,
) -> Incumbent {
    let others = (0..plans).filter(|&j| j != k);
    let records = others.map(|j| Contender { controller: few[j].clone(), values: on(j), held: on(k) });
    let contenders = kept(first.into_iter().chain(records).collect(), keep);
    Incumbent { controller: few[k].clone(), value: mean(values.iter().copied()), episodes: values.len(), contenders }
}

/// The `keep` records of the highest mean gain not below 0; among equal gains, those of more
/// episodes (the surer), then the earlier.
fn kept(mut records: Vec<Contender>, keep: usize) -> Vec<Contender> {
    records.retain(|r| r.gain() >= 0.0);
    records.sort_by(|p, q| q.gain().total_cmp(&p.gain()).then(q.values.len().cmp(&p.values.len())));
    records.truncate(keep);
    records
}

#[cfg(test)]
mod tests {
    use super::*;

    fn record(values: &[f64], held: &[f64]) -> Contender {
        let controller = Controller::moore(vec![0], vec![0]);
        Contender { controller, values: values.to_vec(), held: held.to_vec() }
    }

    #[test]
    fn a_plan_beats_the_best_by_more_than_the_noise_of_its_gains() {
        let held = [0.0; 4];
        // Gains 1, 0, 1, 0: mean 0.5, standard error 0.289.
        let lucky = record(&[1.0, 0.0, 1.0, 0.0], &held);
        assert!(lucky.beats(0.0) && lucky.beats(1.0) && !lucky.beats(2.0));
        // The same gain on every episode has no noise: any margin.
        assert!(record(&[0.5; 4], &held).beats(100.0));
        // Equal values never beat it; nor does a loss.
        assert!(!record(&held, &held).beats(0.0) && !record(&[-1.0; 4], &held).beats(0.0));
        // Paired: the episodes' own spread does not count, the gains' does.
        let hard = [5.0, -5.0, 5.0, -5.0];
        assert!(record(&[5.1, -4.9, 5.1, -4.9], &hard).beats(3.0));
    }

    fn controllers(n: usize) -> Vec<Controller> {
        (0..n as u32).map(|k| Controller::moore(vec![k], vec![0])).collect()
    }

    #[test]
    fn the_first_best_is_the_highest_mean_and_the_others_not_worse_contend() {
        let few = controllers(3);
        let mut best = None;
        // Two episodes each: means 0.5, 1, 1 (the first of equals wins).
        assert!(settle(&mut best, &few, &[0.0, 1.0, 1.0, 1.0, 1.0, 1.0], 2, 1.0, 3));
        let best = best.unwrap();
        assert_eq!((best.controller.clone(), best.value, best.episodes), (few[1].clone(), 1.0, 2));
        assert_eq!(
            best.contenders,
            vec![Contender { controller: few[2].clone(), values: vec![1.0; 2], held: vec![1.0; 2] }]
        );
    }

    #[test]
    fn a_rare_failure_of_the_best_is_told_over_iterations() {
        // The best fails once in an iteration of four episodes; the plan never does: one
        // iteration's gains (0, 0, 0, 1) are within their noise (mean 0.25, standard error 0.25);
        // a second failure tells (mean 0.25 of eight, standard error 0.16).
        let few = controllers(2);
        let mut best = Some(Incumbent { controller: few[1].clone(), value: 1.0, episodes: 4, contenders: vec![] });
        assert!(!settle(&mut best, &few, &[1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 0.0], 4, 1.0, 3));
        let held = best.as_ref().unwrap();
        assert_eq!((held.controller.clone(), held.value, held.episodes), (few[1].clone(), 0.875, 8));
        assert_eq!(held.contenders.len(), 1);
        assert!(settle(&mut best, &few, &[1.0, 1.0, 1.0, 1.0, 1.0, 0.0, 1.0, 1.0], 4, 1.0, 3));
        let best = best.unwrap();
        // The plan, valued on eight episodes, is the best; the old best, worse, does not contend.
        assert_eq!((best.controller.clone(), best.value, best.episodes), (few[0].clone(), 1.0, 8));
        assert!(best.contenders.is_empty());
        // Without the first iteration's record, the second alone would not have told.
        let mut fresh = Some(Incumbent { controller: few[1].clone(), value: 1.0, episodes: 4, contenders: vec![] });
        assert!(!settle(&mut fresh, &few, &[1.0, 1.0, 1.0, 1.0, 1.0, 0.0, 1.0, 1.0], 4, 1.0, 3));
    }

    #[test]
    fn among_equal_gains_the_surer_contends() {
        // The contender, level with the best over eight episodes, is level again; a fresh plan
        // is level on these four: the one place goes to the contender.
        let few = controllers(3);
        let earlier = Contender { controller: few[1].clone(), values: vec![1.0; 8], held: vec![1.0; 8] };
        let mut best =
            Some(Incumbent { controller: few[2].clone(), value: 1.0, episodes: 8, contenders: vec![earlier] });
        assert!(!settle(&mut best, &few, &[1.0; 12], 4, 1.0, 1));
        let held = best.unwrap();
        assert_eq!(held.contenders.len(), 1);
        assert_eq!((held.contenders[0].controller.clone(), held.contenders[0].values.len()), (few[1].clone(), 12));
    }

    #[test]
    fn the_plan_of_the_highest_gain_wins_and_contenders_keep_the_best_and_not_worse() {
        let few = controllers(4);
        let mut best = Some(Incumbent { controller: few[3].clone(), value: 0.5, episodes: 2, contenders: vec![] });
        // Gains (-0.5, -0.5), (0, 0) and (0.25, 0.5) over the best's (0.5, 0.25).
        assert!(!settle(&mut best, &few, &[0.0, -0.25, 0.5, 0.25, 0.75, 0.75, 0.5, 0.25], 2, 5.0, 3));
        let held = best.as_ref().unwrap();
        let kept: Vec<_> = held.contenders.iter().map(|c| c.controller.clone()).collect();
        assert_eq!(kept, vec![few[2].clone(), few[1].clone()], "the highest gain first, the loser dropped");
        // With one kept, the highest gain alone; at margin 0, it wins, the old best then contending
        // with its record against it where not worse (here worse: dropped), the tie kept.
        let mut again = Some(Incumbent { controller: few[3].clone(), value: 0.5, episodes: 2, contenders: vec![] });
        assert!(settle(&mut again, &few, &[0.0, -0.25, 0.75, 0.75, 0.75, 0.75, 0.5, 0.25], 2, 0.0, 1));
        let won = again.unwrap();
        assert_eq!(won.controller, few[1]);
        assert_eq!(won.contenders.iter().map(|c| c.controller.clone()).collect::<Vec<_>>(), vec![few[2].clone()]);
    }
}
