//! How a search on sampled values values, chooses and reports (model §8): each iteration's
//! controllers valued in groups ([`Groups`]), its candidates scored on the fixed selection episodes
//! (kept by their digest, [`Scores`], and by checkpoints), and the returned controller's evaluation
//! on fresh episodes, inside the time limit.

use super::checkpoint::{ControllerCheckpoint, Known};
use super::laws::Laws;
use super::outcome::ControllerOutcome;
use super::{Credit, Scored, Search, Values};
use crate::ce::budget::{GROUP_EPISODES, Groups};
use crate::ce::stopping::StopReason;
use crate::episodes::credit::StepCredit;
use crate::episodes::{Episodes, Streams};
use crate::error::Result;
use crate::evaluate::{final_evaluation, mean};
use crate::policy::controller::Controller;
use crate::rng::Purpose;

impl Search<'_> {
    /// The mean value of each of `controllers` on the first `m` selection episodes (shared by
    /// every iteration and run: streams `(seed, Select, 0, k)`). A controller scored before is
    /// not run again: its score depends on it alone (kept where `m` is all of them).
    pub(super) fn select_scores(&self, controllers: &[Controller], m: usize) -> Result<Vec<f64>> {
        let Values::Sampled(world) = &self.values else { unreachable!("exact values need no selection") };
        let whole = m == self.config.select_episodes;
        let keys: Vec<[u8; 16]> = controllers.iter().map(digest).collect();
        let scores: Vec<Option<f64>> = keys.iter().map(|k| self.scores.get(k)).collect();
        let (new, new_keys): (Vec<Controller>, Vec<[u8; 16]>) = controllers
            .iter()
            .zip(&keys)
            .zip(&scores)
            .filter(|(_, s)| s.is_none())
            .map(|((c, k), _)| (c.clone(), *k))
            .unzip();
        let mut values = vec![0.0; new.len() * m];
        let streams = Streams { seed: self.config.seed, purpose: Purpose::Select, iteration: 0 };
        self.pool.install(|| world.run_controllers(&new, streams, m, &mut values))?;
        self.ran(values.len());
        let mut fresh = new_keys.iter().zip(values.chunks(m)).map(|(k, v)| {
            let score = mean(v.iter().copied());
            if whole {
                self.scores.keep(*k, score);
            }
            score
        });
        Ok(scores.into_iter().map(|s| s.or_else(|| fresh.next()).expect("one score per new controller")).collect())
    }

    /// The mean value of `K` episodes of each of `controllers` on iteration `iteration`'s
    /// common streams, in groups of whole batches of the world, so that the time limit and the
    /// budget in steps can cut the iteration between two (the first always counts; those left
    /// out are `None`) and the values are the same as in one. Under a budget in steps the steps
    /// of the selection that follows (and of the stage's bar, where the iteration of `laws`
    /// computes it) are kept for them.
    pub(super) fn sampled_values(
        &self,
        world: &dyn Episodes,
        controllers: &[Controller],
        laws: &Laws,
        seed: u64,
        iteration: usize,
        over_time: &(dyn Fn() -> bool + Sync),
    ) -> Result<Valuation> {
        let samples = controllers.len();
        let k = self.config.episodes;
        let streams = Streams { seed, purpose: Purpose::Controllers, iteration: iteration as u64 };
        let (batch, horizon) = (world.batch(), world.shape().horizon);
        let full = if world.remote().is_some() { samples * k } else { GROUP_EPISODES };
        let mut groups = Groups::new(samples, k, batch, full, horizon);
        let selection = self.config.candidates * self.config.select_episodes + self.bar_episodes(laws);
        let mut valued = Vec::with_capacity(samples);
        let rows = StepCredit::rows_of(&controllers[0]);
        let mut credit = (self.config.credit == Credit::Steps).then(|| StepCredit::new(0, rows));
        let cut = loop {
            let left = self.left().map(|l| l.saturating_sub(groups.foreseen(selection)));
            let Some(group) = groups.next(left) else {
                break (valued.len() < samples).then_some(StopReason::MaxEnvSteps);
            };
            if group.start > 0 && over_time() {
                break Some(StopReason::TimeLimit);
            }
            let chunk = &controllers[group];
            let mut values = vec![0.0; chunk.len() * k];
            let steps = if let Some(all) = credit.as_mut() {
                let mut part = StepCredit::new(chunk.len(), rows);
                let (steps, credited) = world.run_controllers_credited(chunk, streams, k, &mut values, &mut part)?;
                if credited {
                    all.append(part);
                } else {
                    credit = None;
                }
                steps
            } else {
                world.run_controllers(chunk, streams, k, &mut values)?
            };
            groups.took(steps);
            self.ran(values.len());
            let means = values.chunks(k).map(|v| mean(v.iter().copied()));
            valued.extend(means.zip(chunk.iter().cloned()).map(Some));
        };
        valued.resize(samples, None);
        Ok(Valuation { drawn: valued, credit, groups: Some(groups), cut })
    }

    /// The steps the budget in steps leaves to learn (`None` without one).
    pub(super) fn left(&self) -> Option<u64> {
        self.config.budget.left(self.meter.steps())
    }

    /// The iteration's candidate for the best so far, as (value, index in `drawn`): its best
    /// controller on exact values; on sampled ones the best on the selection episodes of its best
    /// `candidates` distinct controllers (`order`: best first). Under a budget in steps, where
    /// the steps left do not cover the selection episodes of the candidates not yet scored, as
    /// `groups` foresee them: none once a best so far exists (`has_best`; fewer episodes would
    /// let a candidate replace it on a lucky few), before one the episodes they cover.
    pub(super) fn candidate(
        &self,
        drawn: &[(f64, Controller)],
        order: &[usize],
        groups: Option<&Groups>,
        has_best: bool,
    ) -> Result<Option<(f64, usize)>> {
        if let Values::Exact(_) | Values::ExactElsewhere(..) = self.values {
            return Ok(Some((drawn[order[0]].0, order[0])));
        }
        let mut few: Vec<usize> = Vec::new();
        for &i in order {
            if few.len() == self.config.candidates {
                break;
            }
            if few.iter().all(|&j| drawn[j].1 != drawn[i].1) {
                few.push(i);
            }
        }
        let controllers: Vec<Controller> = few.iter().map(|&i| drawn[i].1.clone()).collect();
        let mut m = self.config.select_episodes;
        if let (Some(left), Some(groups)) = (self.left(), groups) {
            let new = controllers.iter().filter(|c| self.scores.get(&digest(c)).is_none()).count();
            if groups.foreseen(new * m) > left {
                if has_best {
                    return Ok(None);
                }
                m = groups.covered(Some(left), new, m);
            }
        }
        let scores = self.select_scores(&controllers, m)?;
        let b = (0..few.len()).fold(0, |b, i| if scores[i] > scores[b] { i } else { b });
        Ok(Some((scores[b], few[b])))
    }

    /// Evaluates the outcome of a search on sampled values on fresh episodes (its value is
    /// theirs: the controller was not chosen on them), within the `left` seconds of the time
    /// limit ([`final_evaluation`]).
    pub(super) fn evaluate(&self, w: &dyn Episodes, outcome: &mut ControllerOutcome, left: Option<f64>) -> Result<()> {
        let interrupted = outcome.stop == StopReason::Interrupted;
        let (policy, episodes, seed) = (&outcome.policy, self.config.eval_episodes, self.config.seed);
        let (evaluation, cut) = self.pool.install(|| final_evaluation(w, policy, episodes, seed, interrupted, left))?;
        if cut {
            outcome.stop = StopReason::Interrupted;
        }
        outcome.value = evaluation.mean;
        outcome.evaluation = Some(evaluation);
        Ok(())
    }

    /// What the search has computed so far, as its checkpoints keep it.
    pub(super) fn known(&self) -> Known {
        Known { scores: self.scores.saved(), bar: self.bar.get().copied() }
    }

    /// The seconds kept for the final evaluation at the end of the time limit.
    pub(super) fn reserve(&self) -> f64 {
        f64::from_bits(self.reserve.load(std::sync::atomic::Ordering::Relaxed))
    }
}

/// The selection scores and the memoryless stage's bar a checkpoint kept: those of its run in
/// progress, or of the last run over (none in a fresh search).
pub(super) fn kept_values(state: &ControllerCheckpoint) -> Result<(Scores, std::sync::OnceLock<(f64, f64)>)> {
    let (scores, bar) = (Scores::default(), std::sync::OnceLock::new());
    if let Some(known) = state.run.as_ref().map(|r| &r.known).or(state.finished.last().map(|r| &r.known)) {
        scores.restore(&known.scores)?;
        if let Some(known) = known.bar {
            let _ = bar.set(known);
        }
    }
    Ok((scores, bar))
}

/// The scores of the controllers a sampled search has met on its fixed selection episodes, by
/// their digest, so that a controller drawn again is not run again, and a resumed search (its
/// checkpoint holds them) runs the episodes the uninterrupted search runs, and records the same
/// history: at most [`Scores::MOST`] are kept, the whole store cleared when full.
#[derive(Default)]
pub struct Scores {
    values: std::sync::Mutex<std::collections::HashMap<[u8; 16], f64>>,
}

impl Scores {
    /// The most scores kept (about 40 MB in memory, and in a checkpoint).
    pub const MOST: usize = 1 << 20;

    /// The score kept for the controller of digest `key` ([`digest`]), if any.
    pub fn get(&self, key: &[u8; 16]) -> Option<f64> {
        self.lock().get(key).copied()
    }

    /// Keeps `score` as the score of the controller of digest `key`.
    pub fn keep(&self, key: [u8; 16], score: f64) {
        let mut values = self.lock();
        if values.len() >= Self::MOST {
            values.clear();
        }
        values.insert(key, score);
    }

    /// Every score kept, by the digest in hex, in the digests' order (as a checkpoint holds them).
    pub fn saved(&self) -> Vec<(String, f64)> {
        let mut all: Vec<(String, f64)> = self.lock().iter().map(|(d, &s)| (crate::files::hex(d), s)).collect();
        all.sort_by(|a, b| a.0.cmp(&b.0));
        all
    }

    /// The scores `saved` held ([`Scores::saved`]) in place of those kept; a digest that is not
    /// 32 hex digits is refused, naming it.
    pub fn restore(&self, saved: &[(String, f64)]) -> crate::error::Result<()> {
        let mut values = std::collections::HashMap::with_capacity(saved.len());
        for (hex, score) in saved {
            let bytes = unhex(hex).ok_or_else(|| {
                crate::error::Error::format(format!("a selection score's digest {hex:?} (expected 32 hex digits)"))
            })?;
            values.insert(bytes, *score);
        }
        *self.lock() = values;
        Ok(())
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, std::collections::HashMap<[u8; 16], f64>> {
        self.values.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
    }
}

/// The 16 bytes written as 32 hex digits ([`crate::files::hex`]), if `hex` is that.
fn unhex(hex: &str) -> Option<[u8; 16]> {
    if hex.len() != 32 || !hex.bytes().all(|b| b.is_ascii_hexdigit()) {
        return None;
    }
    let mut out = [0u8; 16];
    for (i, byte) in out.iter_mut().enumerate() {
        *byte = u8::from_str_radix(&hex[2 * i..2 * i + 2], 16).ok()?;
    }
    Some(out)
}

/// The first 16 bytes of the SHA-256 of a controller's tables (their lengths and entries): its
/// key in [`Scores`].
fn digest(c: &Controller) -> [u8; 16] {
    use sha2::{Digest, Sha256};
    let mut h = Sha256::new();
    for table in [&c.act, &c.on, &c.next] {
        h.update((table.len() as u64).to_le_bytes());
        for v in table {
            h.update(v.to_le_bytes());
        }
    }
    let mut out = [0u8; 16];
    out.copy_from_slice(&h.finalize()[..16]);
    out
}

/// An iteration's controllers with their values, in draw order (`None`: left out), as valued.
pub(super) struct Valuation {
    pub(super) drawn: Vec<Option<Scored>>,
    /// Each decision row's steps' credit, where counted.
    pub(super) credit: Option<StepCredit>,
    /// The groups the controllers were valued in (sampled values).
    pub(super) groups: Option<Groups>,
    /// What left some out, if anything.
    pub(super) cut: Option<StopReason>,
}
