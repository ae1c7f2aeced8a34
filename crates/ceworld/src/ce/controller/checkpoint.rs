//! The checkpoints of the controller search (model §8), on the spine of every optimiser's
//! ([`crate::ce::resume`]): the state of a run between two iterations is its laws, the best
//! controller so far, the history, the iterations without progress, the elite threshold's
//! record and the escapes taken; the runs already over keep their best controller.

use serde::{Deserialize, Serialize};

use crate::ce::controller::ControllerIteration;
use crate::ce::controller::config::{ControllerConfig, ValueKind};
use crate::ce::controller::laws::Laws;
use crate::ce::record::{IterationRecord, check_history};
use crate::ce::resume::{Checkpoint, Resumable};
use crate::ce::stopping::StopReason;
use crate::policy::controller::Controller;

/// The `"format"` of a controller search's checkpoint file.
pub const FORMAT: &str = "cehmm-controller-checkpoint";

/// The state of one run between two iterations.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct SearchState {
    /// The laws the next iteration draws from.
    pub laws: Laws,
    /// The best controller so far: its value, itself and the iteration that drew it.
    pub best: Option<(f64, Controller, usize)>,
    /// Every iteration so far.
    pub history: Vec<ControllerIteration>,
    /// Iterations in a row without progress.
    pub since_progress: usize,
    /// The highest elite threshold so far (`None`: none since the start or the last escape).
    pub best_threshold: Option<f64>,
    /// Entropy injections taken.
    pub injections: usize,
    /// Growths taken (the laws have `nodes + growths` nodes).
    #[serde(default)]
    pub growths: usize,
    /// The best memoryless policy of the memoryless stage, once it is over (its value and
    /// itself): the later runs start their memory around it.
    #[serde(default)]
    pub memoryless: Option<(f64, Controller)>,
    /// What the search has computed so far, filled as the state is saved.
    #[serde(flatten)]
    pub known: Known,
}

/// A run that is over.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct FinishedSearch {
    /// Its best value (exact, or on the selection episodes).
    pub value: f64,
    /// Its best controller.
    pub controller: Controller,
    /// The iteration that drew it.
    pub best_iteration: usize,
    /// Its iterations.
    pub history: Vec<ControllerIteration>,
    /// Why it stopped.
    pub stop: StopReason,
    /// The best memoryless policy of its memoryless stage, if it had one.
    #[serde(default)]
    pub memoryless: Option<(f64, Controller)>,
    /// What the search had computed when it ended (the last run over alone keeps it, for a
    /// resume before the next run's first save).
    #[serde(flatten)]
    pub known: Known,
}

/// What a search has computed that depends on no run, kept by its checkpoints so that a
/// resumed search runs no episode again and records the uninterrupted history.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
pub struct Known {
    /// The scores on the selection episodes, by controller digest ([`super::selection::Scores`]).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub scores: Vec<(String, f64)>,
    /// What a memoryless stage's best must beat and its noise, once computed.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub bar: Option<(f64, f64)>,
}

/// What is inconsistent in one run's records, if anything (every record of the same run).
fn check_records(history: &[ControllerIteration]) -> Option<String> {
    let records: Vec<IterationRecord> = history.iter().map(|r| r.record.clone()).collect();
    check_history(&records).or_else(|| {
        let first = history.first().map(|r| r.restart);
        history
            .iter()
            .find(|r| Some(r.restart) != first)
            .map(|r| format!("records of runs {:?} and {} in one run", first, r.restart))
    })
}

/// What a checkpoint records of a search's settings: the settings and how values are known.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct SearchSettings {
    /// The settings.
    #[serde(flatten)]
    pub config: ControllerConfig,
    /// Exact or sampled values.
    pub value: ValueKind,
}

/// The controller search as a [`Resumable`] optimiser.
#[derive(Clone, Debug)]
pub struct ControllerSearch;

/// The whole state of a controller search between two iterations.
pub type ControllerCheckpoint = Checkpoint<ControllerSearch>;

impl Resumable for ControllerSearch {
    /// 2: the records' fields renamed as episode CE's (`best`, `elite_threshold`), the
    /// settings flattened; 3: the digest required, the outputs recorded.
    const VERSION: u64 = 3;
    const OLDEST: u64 = 2;
    const FORMAT: &'static str = FORMAT;
    type Config = SearchSettings;
    type Run = SearchState;
    type Finished = FinishedSearch;

    fn restarts(settings: &SearchSettings) -> usize {
        // With `restarts` 0, as many as a time limit allows: the limit may differ on resume.
        if settings.config.restarts == 0 { super::MAX_RESTARTS } else { settings.config.restarts }
    }

    fn check_run(settings: &SearchSettings, run: &SearchState) -> Option<String> {
        let c = &settings.config;
        if let Some(what) = check_records(&run.history) {
            return Some(what);
        }
        let (injected, grown) =
            (run.history.iter().filter(|r| r.injected).count(), run.history.iter().filter(|r| r.grown).count());
        if (run.injections, run.growths) != (injected, grown)
            || run.injections > c.injections
            || run.growths > c.growths
        {
            return Some(format!(
                "{} injections and {} growths (its history has {injected} and {grown}; at most {} and {})",
                run.injections, run.growths, c.injections, c.growths
            ));
        }
        match &run.best {
            None if !run.history.is_empty() => Some("no best controller after iterations".into()),
            Some((value, controller, i)) => {
                if run.history.get(*i).is_none_or(|r| r.best_so_far != *value)
                    || run.history.last().is_some_and(|r| r.best_so_far != *value)
                {
                    Some(format!("best controller of iteration {i} with value {value} (not its history's best so far)"))
                } else if controller.nodes() > c.most_nodes().max(c.model_nodes + run.growths) {
                    Some(format!(
                        "a best controller of {} nodes (at most {})",
                        controller.nodes(),
                        c.most_nodes().max(c.model_nodes + run.growths)
                    ))
                } else {
                    None
                }
            }
            None => None,
        }
        .or_else(|| {
            (run.since_progress > run.history.len())
                .then(|| format!("{} iterations without progress of {}", run.since_progress, run.history.len()))
        })
    }

    fn check_finished(_: &SearchSettings, finished: &FinishedSearch) -> Option<String> {
        check_records(&finished.history).or_else(|| match finished.history.get(finished.best_iteration) {
            Some(r) if r.best_so_far == finished.value => None,
            _ => Some(format!(
                "best iteration {} with value {} (not in its history)",
                finished.best_iteration, finished.value
            )),
        })
    }

    fn non_finite(run: Option<&SearchState>, finished: &[FinishedSearch]) -> Option<String> {
        let records = run.iter().flat_map(|r| &r.history).chain(finished.iter().flat_map(|f| &f.history));
        records.into_iter().find_map(|r| {
            let best = (!r.best_so_far.is_finite()).then(|| format!("best_so_far ({})", r.best_so_far));
            r.record
                .non_finite()
                .or(best)
                .map(|what| format!("run {} iteration {}'s {what}", r.restart, r.record.iteration))
        })
    }
}
