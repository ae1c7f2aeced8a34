//! The checkpoints of every optimiser (the CE method of model §3 and the controller search of
//! model §8): the whole state of an optimisation between two iterations, saved atomically, from
//! which it continues exactly as if it had never stopped.
//!
//! Each optimiser draws iteration `i` from streams keyed by `(seed, i, k)` (model §3,
//! reproducibility), so the state between iterations holds no random generator: an optimiser
//! ([`Resumable`]) says what its run in progress and its finished runs hold, and which of its
//! settings shape the run. The file is one JSON document (floats written in their shortest
//! exact form and read back exactly) with the world and the settings; resuming refuses a
//! checkpoint of another world, another optimiser or other settings, naming the first that
//! differs.

use std::path::Path;
use std::time::Instant;

use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};
use serde_json::Value;

use crate::episodes::Episodes;
use crate::error::{Error, Result};

/// The settings a resumed run may change: its stopping rules, its budgets and its thread count
/// (none of them changes what an iteration does).
pub const FREE_SETTINGS: [&str; 6] = ["patience", "max_iterations", "time_limit", "max_env_steps", "target", "threads"];
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
    /// The files the run's caller writes from its result (the command line's --out and
    /// --history): recorded in the checkpoint, so that the resume of this run, and only this
    /// run, may replace them ([`Peek::outputs`]).
    pub outputs: Vec<std::path::PathBuf>,
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

/// What an optimiser keeps in its checkpoints.
pub trait Resumable {
    /// The `"format"` of its checkpoint files.
    const FORMAT: &'static str;
    /// The version of that format written.
    const VERSION: u64;
    /// The oldest version read: versions before [`Resumable::VERSION`] were written before
    /// checkpoints had to carry their digest, and are read as unverified where they carry none
    /// ([`Peek::unverified`]); a file of the current version without its digest is refused.
    const OLDEST: u64;
    /// Its settings.
    type Config: Clone + Serialize + DeserializeOwned;
    /// The state of a run between two iterations.
    type Run: Clone + Serialize + DeserializeOwned;
    /// A run that is over.
    type Finished: Clone + Serialize + DeserializeOwned;
    /// The settings that shape a run, by name, as text: every setting the config serialises
    /// but those that may change between sessions ([`FREE_SETTINGS`]).
    fn shaping(config: &Self::Config) -> Vec<(String, String)> {
        let value = serde_json::to_value(config).unwrap_or(Value::Null);
        let Value::Object(map) = value else { return Vec::new() };
        map.into_iter()
            .filter(|(k, _)| !FREE_SETTINGS.contains(&k.as_str()))
            .map(|(k, v)| {
                let text = if let Value::String(s) = &v { s.clone() } else { v.to_string() };
                (k, text)
            })
            .collect()
    }
    /// The runs the settings ask for.
    fn restarts(config: &Self::Config) -> usize;
    /// What is inconsistent in the state of the run in progress (its history against its
    /// counters, its best against its history), if anything.
    fn check_run(config: &Self::Config, run: &Self::Run) -> Option<String>;
    /// What is inconsistent in a finished run, if anything.
    fn check_finished(config: &Self::Config, finished: &Self::Finished) -> Option<String>;
    /// The first number of the state that JSON cannot hold exactly, if any.
    fn non_finite(run: Option<&Self::Run>, finished: &[Self::Finished]) -> Option<String>;
}

/// The whole state of an optimisation between two iterations.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(bound = "")]
pub struct Checkpoint<K: Resumable> {
    /// [`Resumable::FORMAT`].
    pub format: String,
    /// [`Resumable::VERSION`].
    pub version: u64,
    /// The world's JSON (model §6).
    pub world: Value,
    /// The settings.
    pub config: K::Config,
    /// The run in progress (0 for the run with the given seed).
    pub restart: usize,
    /// The runs already over, in order.
    pub finished: Vec<K::Finished>,
    /// The state of the run in progress (`None`: it has not started).
    pub run: Option<K::Run>,
    /// Wall seconds spent so far, every session together.
    pub seconds: f64,
    /// The world's steps learning took so far, every session together, as of the state saved
    /// (an iteration cut by an interrupt is dropped with its steps: a resume draws it again).
    #[serde(default)]
    pub env_steps: u64,
    /// The engine that wrote it.
    pub engine_version: String,
    /// What the runs start from, when the settings do not say it (episode CE: the SHA-256 of
    /// the initial policy, so that another `--init`, `--random-init` or `--clock-init` is
    /// refused on resume).
    #[serde(default)]
    pub start: Option<String>,
    /// The files written from the run's result ([`Checkpointing::outputs`], resolved).
    #[serde(default)]
    pub outputs: Vec<String>,
}

impl<K: Resumable> Checkpoint<K> {
    /// The state of an optimisation that has not started.
    pub fn fresh(world: Value, config: &K::Config, start: Option<String>) -> Checkpoint<K> {
        Checkpoint {
            format: K::FORMAT.into(),
            version: K::VERSION,
            world,
            config: config.clone(),
            restart: 0,
            finished: Vec::new(),
            run: None,
            seconds: 0.0,
            env_steps: 0,
            engine_version: crate::VERSION.into(),
            start,
            outputs: Vec::new(),
        }
    }

    /// Saves the checkpoint through a temporary file renamed over `path`.
    pub fn save(&self, path: &Path) -> Result<()> {
        if let Some(what) = K::non_finite(self.run.as_ref(), &self.finished) {
            return Err(Error::Internal(format!("checkpoint: {what} is not a finite number")));
        }
        // The SHA-256 of the content rides along: a file changed since (damaged, or edited) is
        // refused on load, whatever field it touched.
        let mut doc = serde_json::to_value(self).map_err(|e| Error::Internal(format!("checkpoint: {e}")))?;
        let digest = content_digest(&doc);
        doc["digest"] = Value::String(digest);
        crate::files::write_atomic(path, |out| serde_json::to_writer(out, &doc).map_err(std::io::Error::other))
    }

    /// Reads a checkpoint saved by [`Checkpoint::save`].
    pub fn load(path: &Path) -> Result<Checkpoint<K>> {
        let (mut doc, version) = Self::document(path)?;
        let bad = |message: String| Error::CheckpointFormat { path: path.to_path_buf(), message };
        match doc.as_object_mut().and_then(|m| m.remove("digest")) {
            Some(stated) => {
                let actual = content_digest(&doc);
                if stated.as_str() != Some(actual.as_str()) {
                    return Err(bad(format!(
                        "its content does not match its digest (it was changed after it was written: {stated} stated, {actual} found)"
                    )));
                }
            }
            // Only files of the versions written before the digest was required lack it (read
            // as unverified: [`Checkpoint::peek`] tells).
            None if version == K::VERSION => {
                return Err(bad(format!(
                    "it has no \"digest\" (a checkpoint of version {version} carries the SHA-256 of its content: \
                     this one was changed after it was written)"
                )));
            }
            None => {}
        }
        let checkpoint: Checkpoint<K> = serde_json::from_value(doc).map_err(|e| bad(e.to_string()))?;
        checkpoint.check_consistent().map_err(bad)?;
        Ok(checkpoint)
    }

    /// What the checkpoint at `path` says of itself before a run resumes from it (read again
    /// and verified whole by [`Checkpoint::load`] when the run starts).
    pub fn peek(path: &Path) -> Result<Peek> {
        let (doc, version) = Self::document(path)?;
        let unverified = (doc.get("digest").is_none() && version < K::VERSION).then(|| {
            format!(
                "{} is a checkpoint of version {version}, written before checkpoints carried the digest of their \
                 content: it is resumed unverified (a change made to it since cannot be detected)",
                path.display()
            )
        });
        let outputs = match doc.get("outputs") {
            Some(Value::Array(paths)) => paths.iter().filter_map(Value::as_str).map(std::path::PathBuf::from).collect(),
            _ => Vec::new(),
        };
        Ok(Peek { unverified, outputs })
    }

    /// The JSON document of the checkpoint at `path` and its version, checked to be of this
    /// optimiser's format and of a version read.
    fn document(path: &Path) -> Result<(Value, u64)> {
        let bytes = crate::files::read_limited(path, MAX_CHECKPOINT_BYTES, "checkpoint")?;
        let bad = |message: String| Error::CheckpointFormat { path: path.to_path_buf(), message };
        let doc: Value =
            serde_json::from_slice(&bytes).map_err(|e| bad(format!("not a checkpoint: invalid JSON ({e})")))?;
        match doc.get("format").and_then(Value::as_str) {
            Some(f) if f == K::FORMAT => {}
            _ => return Err(bad(format!("not a checkpoint (expected \"format\": \"{}\")", K::FORMAT))),
        }
        match doc.get("version").and_then(Value::as_u64) {
            Some(v) if (K::OLDEST..=K::VERSION).contains(&v) => Ok((doc, v)),
            other => Err(bad(format!(
                "checkpoint version {} (expected {} to {})",
                other.map_or_else(|| "missing".to_string(), |v| v.to_string()),
                K::OLDEST,
                K::VERSION
            ))),
        }
    }

    /// Refuses a state that no run could have saved (a tampered or corrupted file).
    fn check_consistent(&self) -> std::result::Result<(), String> {
        let restarts = K::restarts(&self.config);
        if self.finished.len() != self.restart {
            return Err(format!(
                "run {} with {} runs finished (expected as many as the run index)",
                self.restart,
                self.finished.len()
            ));
        }
        if self.restart > restarts || (self.restart == restarts && self.run.is_some()) {
            return Err(format!("run {} of {restarts} runs", self.restart));
        }
        if !(self.seconds.is_finite() && self.seconds >= 0.0) {
            return Err(format!("seconds {} (expected a finite number >= 0)", self.seconds));
        }
        for (i, f) in self.finished.iter().enumerate() {
            if let Some(what) = K::check_finished(&self.config, f) {
                return Err(format!("finished run {i}: {what}"));
            }
        }
        match self.run.as_ref().and_then(|r| K::check_run(&self.config, r)) {
            Some(what) => Err(format!("run {}: {what}", self.restart)),
            None => Ok(()),
        }
    }

    /// Refuses a checkpoint of another world or other settings (those that shape the run).
    pub fn check_matches(&self, world: &Value, config: &K::Config) -> Result<()> {
        let mismatch = |what: &str, saved: String, given: String| {
            Err(Error::CheckpointMismatch(format!(
                "the checkpoint was made with {what} {saved}, not {given} (resume with the same settings, or start afresh)"
            )))
        };
        if &self.world != world {
            return mismatch("the world", self.world.to_string(), world.to_string());
        }
        for ((name, saved), (_, given)) in K::shaping(&self.config).into_iter().zip(K::shaping(config)) {
            if saved != given {
                return mismatch(&name, saved, given);
            }
        }
        Ok(())
    }
}

/// What a checkpoint says of itself before a run resumes from it ([`Checkpoint::peek`]).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Peek {
    /// Why its content cannot be verified (a file of an earlier version, without a digest), to
    /// be told as a warning; `None` for a verified file.
    pub unverified: Option<String>,
    /// The files the run that wrote it writes from its result (resolved paths): its resume may
    /// replace them.
    pub outputs: Vec<std::path::PathBuf>,
}

/// What to tell the user of a result whose last checkpoint failed with `error`.
pub fn checkpoint_warning(error: &str) -> String {
    format!("the last checkpoint could not be written ({error}); the run went on")
}

/// The SHA-256 of a checkpoint's JSON (without its `"digest"`), written compactly with sorted
/// keys.
fn content_digest(doc: &Value) -> String {
    crate::world::pomdp::sha256_hex(&serde_json::to_vec(doc).unwrap_or_default())
}

/// The seconds an optimisation has spent, every session together.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Clock {
    before: f64,
    started: Instant,
}

impl Clock {
    /// Seconds spent, every session together.
    pub fn seconds(&self) -> f64 {
        self.before + self.started.elapsed().as_secs_f64()
    }
}

/// Keeps the checkpoint of a run and saves it when due.
pub(crate) struct Saver<'a, K: Resumable> {
    checkpointing: Option<&'a Checkpointing>,
    /// What is saved: the runs over, the run in progress when saving.
    pub state: Checkpoint<K>,
    /// Seconds spent by earlier sessions.
    pub before: f64,
    started: Instant,
    last_save: Instant,
    /// Why the last save that failed failed (`None` once one succeeds after it).
    pub failed: Option<String>,
}

impl<'a, K: Resumable> Saver<'a, K> {
    /// The state of a fresh run, or the checkpoint to resume from.
    pub fn new<E: Episodes + ?Sized>(
        world: &E,
        config: &K::Config,
        checkpointing: Option<&'a Checkpointing>,
        start: Option<String>,
    ) -> Result<Saver<'a, K>> {
        let world_json = world.description();
        let state = match checkpointing {
            Some(c) => {
                c.validate()?;
                // Found now, not at the first save after a long stretch of work.
                crate::files::check_writable("checkpoint", &c.path)?;
                if c.resume && c.path.exists() {
                    let saved = Checkpoint::<K>::load(&c.path)?;
                    saved.check_matches(&world_json, config)?;
                    Some(saved)
                } else {
                    None
                }
            }
            None => None,
        };
        if let Some(saved) = &state
            && saved.start.is_some()
            && saved.start != start
        {
            return Err(Error::CheckpointMismatch(
                "the checkpoint's runs start from another initial policy (another --init, --random-init, \
                 --clock-init or levels): resume from the same one, or start afresh"
                    .into(),
            ));
        }
        let mut state = state.unwrap_or_else(|| Checkpoint::fresh(world_json, config, start));
        if let Some(c) = checkpointing {
            state.outputs = c.outputs.iter().map(|p| crate::files::resolved(p).display().to_string()).collect();
        }
        let now = Instant::now();
        Ok(Saver { checkpointing, before: state.seconds, state, started: now, last_save: now, failed: None })
    }

    /// Seconds spent, every session together.
    pub fn seconds(&self) -> f64 {
        self.clock().seconds()
    }

    /// The clock of [`Saver::seconds`], apart from the saver.
    pub fn clock(&self) -> Clock {
        Clock { before: self.before, started: self.started }
    }

    /// Whether a save is due (always when `force`).
    fn due(&self, force: bool) -> bool {
        self.checkpointing.is_some_and(|c| force || self.last_save.elapsed().as_secs_f64() >= c.every)
    }

    /// Saves the state when checkpointing and a save is due (always when `force`). A save that
    /// fails (a full disk) does not stop the run: its error is kept in [`Saver::failed`] for the
    /// result, and the next save tries again (the file on disk, if any, is the last good one).
    pub fn save(&mut self, force: bool) {
        if let Some(c) = self.checkpointing
            && self.due(force)
        {
            self.state.seconds = self.seconds();
            self.failed = self.state.save(&c.path).err().map(|e| e.to_string());
            self.last_save = Instant::now();
        }
    }

    /// Saves the state with the run in progress, `run()`, when a save is due (always when
    /// `force`); the run is built only then.
    pub fn save_run(&mut self, force: bool, run: impl FnOnce() -> K::Run) {
        if self.due(force) {
            self.state.run = Some(run());
            self.save(true);
            self.state.run = None;
        }
    }
}
