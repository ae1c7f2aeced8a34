//! Checkpoints of the cross-entropy method (model §3): the whole state of an optimisation between
//! two iterations, saved atomically, from which `crate::ce::optimize::optimize_with` continues
//! exactly as if it had never stopped.
//!
//! The episodes of iteration `i` are drawn from streams keyed by `(seed, i, k)` (model §3,
//! reproducibility), so the state between iterations holds no random generator: it is the
//! current tables, the history, the best iteration so far and its tables, the count of
//! unsuccessful iterations, and, with restarts, the runs already finished with their selection
//! scores. The file is one JSON document (floats written in their shortest exact form and read
//! back exactly) with the world and the settings that shape the run; resuming refuses a
//! checkpoint of another world or other settings, naming the first that differs.

use std::path::Path;
use std::time::Instant;

use serde::{Deserialize, Deserializer, Serialize, Serializer};
use serde_json::Value;

use crate::ce::config::CeConfig;
use crate::ce::record::{CeResult, IterationRecord};
use crate::episodes::Episodes;
use crate::error::{Error, Result};
use crate::policy::Hhmm;

/// The `"format"` of a checkpoint file.
pub const FORMAT: &str = "cehmm-ce-checkpoint";
/// The version of the format written.
pub const VERSION: u64 = 1;
/// Largest checkpoint file read (bytes); a larger file is refused before it is read.
pub const MAX_CHECKPOINT_BYTES: u64 = 1 << 34;
/// Seconds between two checkpoints when none is given.
pub const DEFAULT_EVERY: f64 = 60.0;

/// Where and how often to save checkpoints, and whether to start from one.
#[derive(Clone, Debug, PartialEq)]
pub struct Checkpointing {
    /// The checkpoint file (written atomically: a reader never sees a partial file).
    pub path: std::path::PathBuf,
    /// Seconds between two saves (also saved when the run stops, however it stops).
    pub every: f64,
    /// Continue from `path` when it exists (a missing file starts a fresh run).
    pub resume: bool,
}

impl Checkpointing {
    /// Refuses a period that is not a positive number of seconds.
    pub fn validate(&self) -> Result<()> {
        if self.every.is_nan() || self.every <= 0.0 {
            return Err(Error::invalid(
                "checkpoint_every",
                format!("{} (expected a positive number of seconds)", self.every),
            ));
        }
        Ok(())
    }
}

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

/// The whole state of an optimisation between two iterations.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct CeCheckpoint {
    /// [`FORMAT`].
    pub format: String,
    /// [`VERSION`].
    pub version: u64,
    /// The world's JSON (model §6).
    pub world: Value,
    /// The settings.
    pub config: CeConfig,
    /// The run in progress (0 for the run with the given seed).
    pub restart: usize,
    /// The runs already over, in order.
    pub finished: Vec<FinishedRun>,
    /// The state of the run in progress (`None`: it has not started).
    pub run: Option<RunState>,
    /// Wall seconds spent so far, every session together.
    pub seconds: f64,
    /// The engine that wrote it.
    pub engine_version: String,
}

impl CeCheckpoint {
    /// The state of an optimisation that has not started.
    pub fn fresh(world: Value, config: &CeConfig) -> CeCheckpoint {
        CeCheckpoint {
            format: FORMAT.into(),
            version: VERSION,
            world,
            config: config.clone(),
            restart: 0,
            finished: Vec::new(),
            run: None,
            seconds: 0.0,
            engine_version: crate::VERSION.into(),
        }
    }

    /// Saves the checkpoint through a temporary file renamed over `path`.
    pub fn save(&self, path: &Path) -> Result<()> {
        if let Some(what) = self.non_finite() {
            return Err(Error::Internal(format!("checkpoint: {what} is not a finite number")));
        }
        crate::files::write_atomic(path, |out| serde_json::to_writer(out, self).map_err(std::io::Error::other))
    }

    /// Reads a checkpoint saved by [`CeCheckpoint::save`].
    pub fn load(path: &Path) -> Result<CeCheckpoint> {
        let bytes = crate::files::read_limited(path, MAX_CHECKPOINT_BYTES, "checkpoint")?;
        let bad = |message: String| Error::PolicyFormat { path: Some(path.to_path_buf()), message };
        let doc: Value =
            serde_json::from_slice(&bytes).map_err(|e| bad(format!("not a checkpoint: invalid JSON ({e})")))?;
        match doc.get("format").and_then(Value::as_str) {
            Some(FORMAT) => {}
            _ => return Err(bad(format!("not a checkpoint (expected \"format\": \"{FORMAT}\")"))),
        }
        match doc.get("version").and_then(Value::as_u64) {
            Some(VERSION) => {}
            other => return Err(bad(format!("checkpoint version {other:?} (expected {VERSION})"))),
        }
        serde_json::from_value(doc).map_err(|e| bad(format!("invalid checkpoint: {e}")))
    }

    /// Refuses a checkpoint of another world or other settings (those that shape the run: the
    /// stopping rules, the time limit and the thread count may change).
    pub fn check_matches(&self, world: &Value, config: &CeConfig) -> Result<()> {
        let mismatch = |what: &str, saved: String, given: String| {
            Err(Error::CheckpointMismatch(format!(
                "the checkpoint was made with {what} {saved}, not {given} (resume with the same settings, or start afresh)"
            )))
        };
        if &self.world != world {
            return mismatch("the world", self.world.to_string(), world.to_string());
        }
        let c = &self.config;
        let pairs: [(&str, String, String); 8] = [
            ("samples", c.samples.to_string(), config.samples.to_string()),
            ("rho", c.rho.to_string(), config.rho.to_string()),
            ("smoothing", c.smoothing.to_string(), config.smoothing.to_string()),
            ("decision_smoothing", format!("{:?}", c.decision_smoothing), format!("{:?}", config.decision_smoothing)),
            ("seed", c.seed.to_string(), config.seed.to_string()),
            ("memory_update", c.memory_update.as_str().into(), config.memory_update.as_str().into()),
            ("restarts", c.restarts.to_string(), config.restarts.to_string()),
            ("eval_episodes", c.eval_episodes.to_string(), config.eval_episodes.to_string()),
        ];
        for (name, saved, given) in pairs {
            if saved != given {
                return mismatch(name, saved, given);
            }
        }
        Ok(())
    }

    /// The first number that JSON cannot hold exactly, if any.
    fn non_finite(&self) -> Option<String> {
        let records =
            self.run.iter().flat_map(|r| &r.history).chain(self.finished.iter().flat_map(|f| &f.result.history));
        for r in records {
            for (name, v) in [
                ("mean", r.mean),
                ("best", r.best),
                ("elite_threshold", r.elite_threshold),
                ("elite_mean", r.elite_mean),
            ] {
                if !v.is_finite() {
                    return Some(format!("iteration {}'s {name} ({v})", r.iteration));
                }
            }
        }
        None
    }
}

/// Keeps the checkpoint of a run and saves it when due.
pub(crate) struct Saver<'a> {
    checkpointing: Option<&'a Checkpointing>,
    /// What is saved: the runs over, the run in progress when saving.
    pub state: CeCheckpoint,
    /// Seconds spent by earlier sessions.
    pub before: f64,
    started: Instant,
    last_save: Instant,
}

impl<'a> Saver<'a> {
    /// The state of a fresh run, or the checkpoint to resume from.
    pub fn new<E: Episodes + ?Sized>(
        world: &E,
        config: &CeConfig,
        checkpointing: Option<&'a Checkpointing>,
    ) -> Result<Saver<'a>> {
        let world_json = world.description();
        let state = match checkpointing {
            Some(c) => {
                c.validate()?;
                if c.resume && c.path.exists() {
                    let saved = CeCheckpoint::load(&c.path)?;
                    saved.check_matches(&world_json, config)?;
                    Some(saved)
                } else {
                    None
                }
            }
            None => None,
        };
        let state = state.unwrap_or_else(|| CeCheckpoint::fresh(world_json, config));
        let now = Instant::now();
        Ok(Saver { checkpointing, before: state.seconds, state, started: now, last_save: now })
    }

    /// Seconds spent, every session together.
    pub fn seconds(&self) -> f64 {
        self.before + self.started.elapsed().as_secs_f64()
    }

    /// Whether a save is due (always when `force`).
    fn due(&self, force: bool) -> bool {
        self.checkpointing.is_some_and(|c| force || self.last_save.elapsed().as_secs_f64() >= c.every)
    }

    /// Saves the state when checkpointing and a save is due (always when `force`).
    pub fn save(&mut self, force: bool) -> Result<()> {
        if let Some(c) = self.checkpointing
            && self.due(force)
        {
            self.state.seconds = self.seconds();
            self.state.save(&c.path)?;
            self.last_save = Instant::now();
        }
        Ok(())
    }

    /// Saves the state with the run in progress, `run()`, when a save is due (always when
    /// `force`); the run is built only then.
    pub fn save_run(&mut self, force: bool, run: impl FnOnce() -> RunState) -> Result<()> {
        if self.due(force) {
            self.state.run = Some(run());
            let saved = self.save(true);
            self.state.run = None;
            saved?;
        }
        Ok(())
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
