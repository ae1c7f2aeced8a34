//! A Q-learning run: the update loop, training in chunks with checkpoints, progress.

use crate::error::Result;
use rand::Rng;
use serde::Serialize;

use super::CHUNK;
use super::KnownState;
use super::QConfig;
use super::QTable;
use super::epsilon;
use crate::ce::stopping::StopReason;
use crate::control::Flow;
use crate::error::Error;
use crate::rng::EngineRng;
use crate::rng::Purpose;
use crate::rng::stream;
use std::path::Path;
use std::time::Instant;

/// What one call of [`QLearner::run`] did.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RunStats {
    /// Updates run.
    pub updates: u64,
    /// Sum of their rewards.
    pub reward: f64,
    /// Wall seconds.
    pub seconds: f64,
}

/// A Q-learning run on a continuing world: the table, the world's current state, the update
/// count and the random stream; everything a checkpoint holds.
pub struct QLearner<W: KnownState> {
    pub(super) world: W,
    pub(super) config: QConfig,
    pub(super) table: QTable,
    pub(super) state: W::State,
    pub(super) y: usize,
    pub(super) updates: u64,
    pub(super) rng: EngineRng,
    pub(super) reward_total: f64,
    pub(super) seconds: f64,
}

impl<W: KnownState> QLearner<W> {
    /// A fresh run: a zero table (memory checked first), the world's initial state.
    pub fn new(world: W, config: QConfig) -> Result<Self> {
        config.validate()?;
        let table = QTable::zeros(world.n_states()?, world.n_decisions())?;
        let mut rng = stream(config.seed, Purpose::QLearning, 0, 0);
        let state = world.reset(&mut rng);
        let y = world.observe(&state, &mut rng);
        Ok(QLearner { world, config, table, state, y, updates: 0, rng, reward_total: 0.0, seconds: 0.0 })
    }

    /// The world.
    pub fn world(&self) -> &W {
        &self.world
    }

    /// The settings.
    pub fn config(&self) -> &QConfig {
        &self.config
    }

    /// The table.
    pub fn table(&self) -> &QTable {
        &self.table
    }

    /// Updates run so far (`t` of the last update).
    pub fn updates(&self) -> u64 {
        self.updates
    }

    /// Sum of the rewards of every update so far.
    pub fn reward_total(&self) -> f64 {
        self.reward_total
    }

    /// Wall seconds spent in [`QLearner::run`] so far, over every resumed session.
    pub fn seconds(&self) -> f64 {
        self.seconds
    }

    /// The world's current state and observation.
    pub fn current(&self) -> (&W::State, usize) {
        (&self.state, self.y)
    }

    /// Runs `updates` more ε-greedy steps of the continuing task, updating the table after each.
    pub fn run(&mut self, updates: u64) -> RunStats {
        let started = Instant::now();
        let (alpha, gamma) = (self.config.alpha as f32, self.config.gamma as f32);
        let n_actions = self.table.n_actions as u64;
        let ties = self.config.ties;
        let mut s = self.world.known_state(&self.state, self.y);
        let mut reward_sum = 0.0;
        for _ in 0..updates {
            self.updates += 1;
            // ε compared on the high 32 bits; the low 32 bits pick the random decision, or break
            // a greedy tie.
            let draw = self.rng.next_u64();
            let explore = ((draw >> 32) as f64) < epsilon(self.updates) * 4_294_967_296.0;
            let a = if explore {
                (((draw & 0xffff_ffff) * n_actions) >> 32) as usize
            } else {
                self.table.greedy_with(s, ties, || draw as u32)
            };
            let reward = self.world.step_reward(&mut self.state, a, &mut self.rng);
            self.y = self.world.observe(&self.state, &mut self.rng);
            let s_next = self.world.known_state(&self.state, self.y);
            self.table.update(s, a, reward as f32, s_next, alpha, gamma);
            s = s_next;
            reward_sum += reward;
        }
        let seconds = started.elapsed().as_secs_f64();
        self.reward_total += reward_sum;
        self.seconds += seconds;
        RunStats { updates, reward: reward_sum, seconds }
    }

    /// Runs until `until` updates in all, in chunks of [`CHUNK`], calling `observer` after each
    /// chunk (`Flow::Stop` stops there); with a checkpoint path, saves the run there every
    /// `checkpoint_every` seconds, when stopped, and at the end.
    pub fn train(
        &mut self,
        until: u64,
        checkpoint: Option<&Path>,
        checkpoint_every: Option<f64>,
        mut observer: impl FnMut(&QProgress) -> Flow,
    ) -> Result<TrainOutcome> {
        if let Some(every) = checkpoint_every {
            if every.is_nan() || every <= 0.0 {
                return Err(Error::invalid(
                    "checkpoint_every",
                    format!("{every} (expected a positive number of seconds)"),
                ));
            }
        }
        let started = Instant::now();
        let first = self.updates;
        let mut last_checkpoint = Instant::now();
        let mut checkpoints = 0;
        let mut checkpoint_error = None;
        let mut save = |learner: &Self, path: &std::path::Path| match learner.save(path) {
            Ok(()) => {
                checkpoints += 1;
                checkpoint_error = None;
            }
            Err(e) => checkpoint_error = Some(e.to_string()),
        };
        let mut stop = None;
        while self.updates < until {
            let stats = self.run(CHUNK.min(until - self.updates));
            let seconds = started.elapsed().as_secs_f64();
            let progress = QProgress {
                updates: self.updates,
                until,
                epsilon: epsilon(self.updates),
                updates_per_second: (self.updates - first) as f64 / seconds.max(1e-9),
                reward_per_100: 100.0 * stats.reward / stats.updates as f64,
                mean_reward_per_100: 100.0 * self.reward_total / self.updates as f64,
                seconds,
                table_bytes: self.table.bytes(),
            };
            stop = StopReason::asked(observer(&progress));
            if stop.is_some() {
                break;
            }
            if let (Some(path), Some(every)) = (checkpoint, checkpoint_every) {
                if last_checkpoint.elapsed().as_secs_f64() >= every && self.updates < until {
                    save(self, path);
                    last_checkpoint = Instant::now();
                }
            }
        }
        if let Some(path) = checkpoint {
            save(self, path);
        }
        Ok(TrainOutcome {
            updates: self.updates - first,
            seconds: started.elapsed().as_secs_f64(),
            interrupted: stop == Some(StopReason::Interrupted),
            stop,
            checkpoints,
            checkpoint_error,
        })
    }
}

/// Where a [`QLearner::train`] run stands, after each chunk of updates.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct QProgress {
    /// Updates so far (all sessions).
    pub updates: u64,
    /// The target number of updates.
    pub until: u64,
    /// The current `ε`.
    pub epsilon: f64,
    /// Updates per second in this session.
    pub updates_per_second: f64,
    /// Reward per 100 steps over the last chunk (the ε-greedy learning run itself).
    pub reward_per_100: f64,
    /// Reward per 100 steps over the whole run.
    pub mean_reward_per_100: f64,
    /// Wall seconds of this session.
    pub seconds: f64,
    /// Size of the table in bytes.
    pub table_bytes: u64,
}

impl QProgress {
    /// The live progress line (without carriage return).
    pub fn line(&self) -> String {
        let left = (self.until.saturating_sub(self.updates)) as f64 / self.updates_per_second.max(1e-9);
        format!(
            "updates {:.3e}/{:.3e} ({:>5.1}%)  {:.2}M/s  ε {:.4}  reward/100 steps {:>5.1} (run mean {:>5.1})  {:>6.0}s, {:.0}s left",
            self.updates as f64,
            self.until as f64,
            100.0 * self.updates as f64 / self.until.max(1) as f64,
            self.updates_per_second / 1e6,
            self.epsilon,
            self.reward_per_100,
            self.mean_reward_per_100,
            self.seconds,
            left
        )
    }
}

/// How a [`QLearner::train`] call ended.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TrainOutcome {
    /// Updates run in this call.
    pub updates: u64,
    /// Wall seconds of this call (checkpoints included).
    pub seconds: f64,
    /// Whether the observer stopped it as interrupted ([`Flow::Stop`]: Ctrl-C).
    pub interrupted: bool,
    /// Why the observer stopped it before `until`, if it did ([`StopReason::Interrupted`], or
    /// [`StopReason::Callback`] for [`Flow::Finish`]).
    pub stop: Option<StopReason>,
    /// Checkpoints written.
    pub checkpoints: u64,
    /// Why the last checkpoint that could not be written failed, if one failed: the run went on
    /// (a full disk must not cost it), and the caller tells the user.
    pub checkpoint_error: Option<String>,
}
