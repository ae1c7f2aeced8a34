//! What a controller search gives (model §8): a record per iteration and the outcome, with its
//! policy file.

use serde::Serialize;
use serde_json::json;

use crate::ce::controller::checkpoint::FinishedSearch;
use crate::ce::controller::{ControllerConfig, ValueKind};
use crate::ce::record::{Ending, IterationRecord};
use crate::ce::stepped::SteppedOutcome;
use crate::ce::stopping::StopReason;
use crate::episodes::Episodes;
use crate::evaluate::Evaluation;
use crate::policy::Hhmm;
use crate::policy::file::PolicyFile;
use crate::settings::Settings;

/// One iteration of a controller search: the statistics every optimiser records
/// ([`IterationRecord`], with a controller's value in place of an episode's reward) and the
/// search's own.
#[derive(Clone, Debug, PartialEq, Serialize, serde::Deserialize)]
pub struct ControllerIteration {
    /// The run (0-based; see `restarts`).
    pub restart: usize,
    /// The iteration's statistics: `iteration` within the run, the `mean`, `best`, elite
    /// threshold and elite mean of its controllers' values (exact, or over their `K` episodes),
    /// `successful` when it counted as progress (a better controller so far or a higher elite
    /// threshold: it reset the patience count), `seconds` since the start.
    #[serde(flatten)]
    pub record: IterationRecord,
    /// The best value so far in this run: exact, or on the selection episodes.
    pub best_so_far: f64,
    /// Mean over the laws' rows of their largest probability (1: every draw is the same controller).
    pub concentration: f64,
    /// Controllers evaluated (fewer than `samples` when the time limit cut the iteration).
    pub evaluated: usize,
    /// Sampled values: the world's episodes this iteration ran (its controllers', the new
    /// selection scores', the blind policies' once): what it cost, like `seconds` (a resumed
    /// search may run some again: its store of selection scores starts empty); 0 on exact
    /// values.
    #[serde(default)]
    pub episodes: u64,
    /// Whether the laws were mixed with the uniform law after this iteration (an escape).
    pub injected: bool,
    /// Whether the laws grew a node after this iteration (an escape).
    #[serde(default)]
    pub grown: bool,
    /// Whether the memoryless stage ended after this iteration: the laws widened from one node
    /// to `nodes` around the best memoryless policy.
    #[serde(default)]
    pub widened: bool,
}

/// The model start of a search on a discounted tabular world (`model_nodes`, model §8): the
/// controller built from the world's model, whether the search kept it or not.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Start {
    /// The exact value of the controller the point-based values make (model §8).
    pub built: f64,
    /// Its exact value once improved node by node (`ce::controller::improve`).
    pub value: f64,
    /// Its nodes.
    pub nodes: usize,
    /// The best blind policy's exact value ("always `a`"), which it must beat to be kept.
    pub blind: f64,
    /// Whether it beat the best blind policy by the tolerance: the search then starts around it
    /// and values it first, so that it returns nothing worse.
    pub kept: bool,
}

/// The outcome of a controller search.
#[derive(Clone, Debug)]
pub struct ControllerOutcome {
    /// The best controller found, as a two-level one-hot HHMM.
    pub policy: Hhmm,
    /// Its value: exact (infinite-horizon for `γ < 1`, else at the world's horizon), or on
    /// sampled values the mean of `evaluation`'s fresh episodes.
    pub value: f64,
    /// How the controllers were valued.
    pub kind: ValueKind,
    /// Sampled values: the returned controller on `eval_episodes` fresh episodes (streams
    /// `(seed, Evaluate, 0, k)`, as `evaluate` gives for its policy).
    pub evaluation: Option<Evaluation>,
    /// The iteration that drew it, within its run.
    pub best_iteration: usize,
    /// The run that found it.
    pub restart: usize,
    /// The best value of each run, in order (exact, or on the selection episodes).
    pub run_values: Vec<f64>,
    /// One record per iteration, run after run.
    pub history: Vec<ControllerIteration>,
    /// Why the search stopped: why its last run stopped, or the time limit where it left no
    /// time for another run.
    pub stop: StopReason,
    /// Seconds taken.
    pub seconds: f64,
    /// Why the last checkpoint that could not be written failed, if one failed (the search
    /// went on).
    pub checkpoint_error: Option<String>,
    /// Sampled values: the world's steps learning took, every run and session together
    /// (selection scores included); 0 on exact values.
    pub env_steps: u64,
    /// Sampled values: the world's steps of `evaluation`, counted apart.
    pub eval_env_steps: u64,
    /// The model start, where one was built (this session's: it is built again on resume).
    pub start: Option<Start>,
}

/// What the controller search's result says beside its policy, history and evaluation
/// (`cehmm.ControllerResult`'s other fields).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ControllerSummary {
    /// How the search ended.
    #[serde(flatten)]
    pub ending: Ending,
    /// The best controller's value ([`ControllerOutcome::value`]).
    pub value: f64,
    /// How the controllers were valued: `"exact"` or `"sampled"`.
    pub kind: &'static str,
    /// The iteration that drew it, within its run.
    pub best_iteration: usize,
    /// The run that found it.
    pub restart: usize,
    /// The best value of each run, in order.
    pub run_values: Vec<f64>,
    /// The model start, where one was built ([`ControllerOutcome::start`]).
    pub start: Option<Start>,
}

impl ControllerSummary {
    /// A controller search's summary of the model search's `outcome` (model §10; one run,
    /// sampled values): its value is its evaluation's mean, its best iteration the last that
    /// replaced the best so far, its run's value the best so far on the selection episodes.
    pub fn of_stepped(outcome: &SteppedOutcome) -> ControllerSummary {
        let best_iteration = outcome.history.iter().rposition(|r| r.successful).unwrap_or(0);
        ControllerSummary {
            ending: outcome.ending(),
            value: outcome.evaluation.mean,
            kind: ValueKind::Sampled.as_str(),
            best_iteration,
            restart: 0,
            run_values: outcome.history.last().map(|r| r.best).into_iter().collect(),
            start: None,
        }
    }
}

impl ControllerOutcome {
    /// What the result says beside its policy, history and evaluation, by the names the
    /// bindings hand on.
    pub fn summary(&self) -> ControllerSummary {
        let ending = Ending {
            stop_reason: self.stop,
            seconds: self.seconds,
            env_steps: self.env_steps,
            eval_env_steps: self.eval_env_steps,
        };
        ControllerSummary {
            ending,
            value: self.value,
            kind: self.kind.as_str(),
            best_iteration: self.best_iteration,
            restart: self.restart,
            run_values: self.run_values.clone(),
            start: self.start,
        }
    }

    /// The outcome of a search's `runs` (those over, then the one cut, if any): run `best`'s
    /// controller, the search stopped for `stop`; its evaluation, seconds and steps left to the
    /// caller.
    pub(super) fn of_runs(
        runs: &[&FinishedSearch],
        best: usize,
        stop: StopReason,
        kind: ValueKind,
        (y1, n_actions): (usize, usize),
    ) -> crate::error::Result<ControllerOutcome> {
        let kept = runs[best];
        Ok(ControllerOutcome {
            policy: kept.controller.to_hhmm(y1, n_actions)?,
            value: kept.value,
            kind,
            evaluation: None,
            best_iteration: kept.best_iteration,
            restart: best,
            run_values: runs.iter().map(|r| r.value).collect(),
            history: runs.iter().flat_map(|r| r.history.iter().cloned()).collect(),
            stop,
            seconds: 0.0,
            checkpoint_error: None,
            env_steps: 0,
            eval_env_steps: 0,
            start: None,
        })
    }

    /// The policy file of the best controller (model §6), with its provenance.
    pub fn to_file(&self, world: &dyn Episodes, config: &ControllerConfig) -> PolicyFile {
        let mut map = config.provenance();
        for (key, value) in [
            ("method", json!("controller-ce")),
            ("value", json!(self.kind.as_str())),
            ("restart", json!(self.restart)),
            ("run_values", json!(self.run_values)),
            ("best_iteration", json!(self.best_iteration)),
            ("model_start", json!(self.start)),
        ] {
            map.insert(key.into(), value);
        }
        self.summary().ending.provenance(self.history.len(), &mut map);
        match &self.evaluation {
            None => {
                map.insert("exact_value".into(), json!(self.value));
            }
            Some(e) => {
                map.insert("evaluation_mean".into(), json!(e.mean));
                map.insert("evaluation_std_error".into(), json!(e.std_error));
                map.insert("evaluation_episodes".into(), json!(e.episodes));
            }
        }
        let provenance = serde_json::Value::Object(map);
        PolicyFile { policy: self.policy.clone(), world: world.description(), provenance }
    }
}
