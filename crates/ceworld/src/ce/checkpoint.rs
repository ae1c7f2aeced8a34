//! The checkpoints of the cross-entropy method (model §3), on the spine of every optimiser's
//! ([`crate::ce::resume`]): the state of a run between two iterations is the current tables, the
//! history, the best iteration so far and its tables, the count of unsuccessful iterations;
//! with restarts, the runs already finished keep their selection scores.

use serde::{Deserialize, Deserializer, Serialize, Serializer};

use crate::ce::config::CeConfig;
use crate::ce::record::{CeResult, IterationRecord, check_history, trailing_unsuccessful};
use crate::ce::resume::{Checkpoint, Resumable};
use crate::policy::Hhmm;

/// The `"format"` of a CE checkpoint file.
pub const FORMAT: &str = "cehmm-ce-checkpoint";

/// The state of one run between two iterations.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct RunState {
    /// The tables the next iteration samples from.
    #[serde(with = "crate::policy::flat::policy_serde")]
    pub policy: Hhmm,
    /// Every iteration so far.
    pub history: Vec<IterationRecord>,
    /// The best iteration so far: its mean, index and the tables that drew it.
    #[serde(with = "best_serde")]
    pub best: Option<(f64, usize, Hhmm)>,
    /// Unsuccessful iterations in a row.
    pub unsuccessful: usize,
}

/// A run that is over, with its score on the selection episodes (restarts).
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct FinishedRun {
    /// Its score on the selection episodes.
    pub score: f64,
    /// Its result.
    pub result: CeResult,
}

/// The cross-entropy method as a [`Resumable`] optimiser.
#[derive(Clone, Debug)]
pub struct CeRun;

/// The whole state of a CE optimisation between two iterations.
pub type CeCheckpoint = Checkpoint<CeRun>;

impl Resumable for CeRun {
    const FORMAT: &'static str = FORMAT;
    /// 2: the digest required, the outputs recorded.
    const VERSION: u64 = 2;
    const OLDEST: u64 = 1;
    type Config = CeConfig;
    type Run = RunState;
    type Finished = FinishedRun;

    fn restarts(config: &CeConfig) -> usize {
        config.restarts
    }

    fn check_run(_: &CeConfig, run: &RunState) -> Option<String> {
        let h = &run.history;
        if let Some(what) = check_history(h) {
            return Some(what);
        }
        // An iteration is successful when its mean beats every earlier one's (model §3).
        let mut top = f64::NEG_INFINITY;
        for r in h {
            if r.successful != (r.mean > top) {
                return Some(format!(
                    "iteration {} marked successful {} (its mean {} against {top})",
                    r.iteration, r.successful, r.mean
                ));
            }
            top = top.max(r.mean);
        }
        match &run.best {
            None if !h.is_empty() => return Some("no best iteration after iterations".into()),
            Some((mean, i, _)) if h.get(*i).is_none_or(|r| r.mean != *mean || *mean != top) => {
                return Some(format!("best iteration {i} with mean {mean} (not the best of its history)"));
            }
            _ => {}
        }
        (run.unsuccessful != trailing_unsuccessful(h)).then(|| {
            format!("{} unsuccessful iterations (its history ends with {})", run.unsuccessful, trailing_unsuccessful(h))
        })
    }

    fn check_finished(_: &CeConfig, finished: &FinishedRun) -> Option<String> {
        let r = &finished.result;
        check_history(&r.history).or_else(|| {
            (r.best_iteration >= r.history.len())
                .then(|| format!("best iteration {} of {}", r.best_iteration, r.history.len()))
        })
    }

    fn non_finite(run: Option<&RunState>, finished: &[FinishedRun]) -> Option<String> {
        let records = run.iter().flat_map(|r| &r.history).chain(finished.iter().flat_map(|f| &f.result.history));
        records.into_iter().find_map(|r| r.non_finite().map(|what| format!("iteration {}'s {what}", r.iteration)))
    }
}

mod best_serde {
    use super::{Deserialize, Deserializer, Hhmm, Serialize, Serializer};
    use crate::policy::flat::PolicyTables;

    #[derive(Serialize, Deserialize)]
    struct Best {
        mean: f64,
        iteration: usize,
        policy: PolicyTables,
    }

    #[allow(clippy::ref_option)] // the signature serde's `with` asks for
    pub fn serialize<S: Serializer>(best: &Option<(f64, usize, Hhmm)>, s: S) -> Result<S::Ok, S::Error> {
        best.as_ref()
            .map(|(mean, iteration, policy)| Best {
                mean: *mean,
                iteration: *iteration,
                policy: PolicyTables::of(policy),
            })
            .serialize(s)
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Option<(f64, usize, Hhmm)>, D::Error> {
        Option::<Best>::deserialize(d)?.map(|b| Ok((b.mean, b.iteration, b.policy.into_policy()?))).transpose()
    }
}
