//! What an optimisation records (model §3): each iteration's statistics, why it stopped, and its
//! outcome.

use serde::{Deserialize, Serialize};
use serde_json::{Map, Value, json};

use crate::ce::config::CeConfig;
use crate::ce::stopping::StopReason;
use crate::episodes::Episodes;
use crate::evaluate::Evaluation;
use crate::policy::Hhmm;
use crate::policy::file::PolicyFile;
use crate::settings::Settings;

/// One iteration's statistics.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct IterationRecord {
    /// Iteration number, from 0.
    pub iteration: usize,
    /// Mean reward of the N episodes.
    pub mean: f64,
    /// Best reward of the N episodes.
    pub best: f64,
    /// Smallest reward kept in the elite.
    pub elite_threshold: f64,
    /// Mean reward of the elite.
    pub elite_mean: f64,
    /// Seconds since the optimisation started, at the end of the iteration.
    pub seconds: f64,
    /// Whether the mean beat every earlier iteration's.
    pub successful: bool,
    /// The world's steps learning had taken at the end of the iteration, every run and every
    /// session together (what a budget in steps counts: [`crate::ce::budget`]; 0 on exact values).
    #[serde(default)]
    pub env_steps: u64,
}

impl IterationRecord {
    /// The first statistic that is not a finite number, as `name (value)`, if any.
    pub fn non_finite(&self) -> Option<String> {
        [
            ("mean", self.mean),
            ("best", self.best),
            ("elite_threshold", self.elite_threshold),
            ("elite_mean", self.elite_mean),
        ]
        .into_iter()
        .find(|(_, v)| !v.is_finite())
        .map(|(name, v)| format!("{name} ({v})"))
    }
}

/// What is inconsistent in a run's records, if anything: iterations numbered from 0 in order,
/// seconds finite and never decreasing.
pub fn check_history(history: &[IterationRecord]) -> Option<String> {
    let mut last = 0.0;
    for (i, r) in history.iter().enumerate() {
        if r.iteration != i {
            return Some(format!("record {i} is iteration {} (expected {i})", r.iteration));
        }
        if !(r.seconds.is_finite() && r.seconds >= last) {
            return Some(format!("iteration {i}'s seconds {} (expected at least {last})", r.seconds));
        }
        last = r.seconds;
    }
    None
}

/// The iterations since the last successful one, at the end of `history`.
pub fn trailing_unsuccessful(history: &[IterationRecord]) -> usize {
    history.iter().rev().take_while(|r| !r.successful).count()
}

/// The outcome of an optimisation.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct CeResult {
    /// The policy that drew the best iteration (highest mean reward).
    #[serde(with = "crate::policy::flat::policy_serde")]
    pub policy: Hhmm,
    /// The policy after the last update.
    #[serde(with = "crate::policy::flat::policy_serde")]
    pub last_policy: Hhmm,
    /// Index of the best iteration.
    pub best_iteration: usize,
    /// Per-iteration statistics.
    pub history: Vec<IterationRecord>,
    /// Why it stopped.
    pub stop: StopReason,
    /// `policy` evaluated on fresh episodes (an unbiased estimate, unlike the best mean).
    pub evaluation: Evaluation,
    /// Wall seconds, evaluation included (of every restart).
    pub seconds: f64,
    /// Which restart this is (0 for the run with the given seed).
    pub restart: usize,
    /// With `restarts > 1`: every run's score on the selection episodes, in run order (the
    /// returned run is the first with the highest); empty for a single run.
    pub restart_scores: Vec<f64>,
    /// Why the last checkpoint that could not be written failed, if one failed: the run went on
    /// (a full disk must not cost the result), and the caller tells the user.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub checkpoint_error: Option<String>,
    /// The world's steps learning took, every run and every session together (each run's score
    /// between restarts included).
    #[serde(default)]
    pub env_steps: u64,
    /// The world's steps of `evaluation`, counted apart.
    #[serde(default)]
    pub eval_env_steps: u64,
}

impl CeResult {
    /// Whether the caller stopped it early.
    pub fn interrupted(&self) -> bool {
        self.stop == StopReason::Interrupted
    }

    /// What the result says beside its policies, history and evaluation, by the names the
    /// bindings hand on.
    pub fn summary(&self) -> CeSummary {
        let ending = Ending {
            stop_reason: self.stop,
            seconds: self.seconds,
            env_steps: self.env_steps,
            eval_env_steps: self.eval_env_steps,
        };
        CeSummary { ending, best_iteration: self.best_iteration }
    }
}

/// How a run ended, the same on every optimiser's result: the fields that `cehmm.OptimizeResult`,
/// `cehmm.ControllerResult` and `cehmm.RunResult` share (the bindings hand this on by these
/// names, and Python's `cehmm.ending.Ending` declares them), and what a policy file's provenance
/// says of the run ([`Ending::provenance`]).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Ending {
    /// Why it stopped.
    pub stop_reason: StopReason,
    /// Wall seconds, every run and session together, the final evaluation included.
    pub seconds: f64,
    /// The world's steps learning took, every run and session together (0 on exact values).
    pub env_steps: u64,
    /// The world's steps of the final evaluation, counted apart (0 on exact values).
    pub eval_env_steps: u64,
}

impl Ending {
    /// Writes into a policy file's `provenance` how the run of `iterations` iterations ended:
    /// `iterations`, `stop`, `interrupted`, `env_steps`, and the engine's `version`.
    pub fn provenance(&self, iterations: usize, provenance: &mut Map<String, Value>) {
        for (key, value) in [
            ("iterations", json!(iterations)),
            ("stop", json!(self.stop_reason.as_str())),
            ("interrupted", json!(self.stop_reason == StopReason::Interrupted)),
            ("env_steps", json!(self.env_steps)),
            ("version", json!(crate::VERSION)),
        ] {
            provenance.insert(key.into(), value);
        }
    }
}

/// What episode CE's result says beside its policies, history and evaluation
/// (`cehmm.OptimizeResult`'s other fields).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct CeSummary {
    /// How the run ended.
    #[serde(flatten)]
    pub ending: Ending,
    /// Index of the best iteration.
    pub best_iteration: usize,
}

impl CeResult {
    /// The file of an optimisation's best policy, with its provenance (model §6).
    pub fn to_file<E: Episodes + ?Sized>(&self, world: &E, config: &CeConfig) -> PolicyFile {
        let result = self;
        let best = &result.history[result.best_iteration];
        let mut provenance = config.provenance();
        // SPEC §6 names the smoothing `alpha`.
        provenance.insert("alpha".into(), json!(config.smoothing));
        for (key, value) in [
            ("restart", json!(result.restart)),
            ("best_iteration", json!(result.best_iteration)),
            ("best_iteration_mean", json!(best.mean)),
            ("mean_reward", json!(result.evaluation.mean)),
            ("evaluation_episodes", json!(result.evaluation.episodes)),
            ("evaluation_std_error", json!(result.evaluation.std_error)),
        ] {
            provenance.insert(key.into(), value);
        }
        result.summary().ending.provenance(result.history.len(), &mut provenance);
        if !result.restart_scores.is_empty() {
            provenance.insert("restart_scores".into(), json!(result.restart_scores));
        }
        let provenance = serde_json::Value::Object(provenance);
        PolicyFile { policy: result.policy.clone(), world: world.description(), provenance }
    }

    /// The file of an optimisation's last policy: the provenance of [`CeResult::to_file`]
    /// with `"policy": "last"`, without the figures that describe the best policy (its
    /// evaluation and best iteration).
    pub fn last_to_file<E: Episodes + ?Sized>(&self, world: &E, config: &CeConfig) -> PolicyFile {
        let mut file = self.to_file(world, config);
        if let Some(map) = file.provenance.as_object_mut() {
            map.retain(|k, _| !(k == "mean_reward" || k.starts_with("evaluation") || k.starts_with("best_iteration")));
            map.insert("policy".into(), json!("last"));
        }
        file.policy = self.last_policy.clone();
        file
    }
}
