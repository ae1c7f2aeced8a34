//! Tabular Q-learning on a world whose state is known: the paper's baseline (section 5,
//! "Comparison with the Q-learning"; model §5, last two rows), and the evaluation of any policy
//! on 100-step windows of a continuing run, which is how the paper compares the two.
//!
//! # The task
//!
//! The learner sees `s_t = (y_t, x_t without the target)`: for target tracking, the observation
//! and both mobiles' cells and headings (`16 × 1600 × 1600` states on the 20 × 20 grid), and
//! picks one of the `D = 16` joint decisions. The world is stepped forever (an infinite-horizon
//! continuing task, never reset; the paper's `T = ∞`), each step paying 1 when it is an
//! encounter (model §4 (2)), with the update of Sutton and Barto:
//! `Q(s, a) += α (r + γ max_a' Q(s', a') − Q(s, a))`, `γ = 0.99`, `α = 0.1`.
//!
//! # Conventions the paper leaves open
//!
//! * `t` counts the updates from 1 and `ε_t = min(1, 1/ln t)` ([`epsilon`]): 1 for `t ≤ 2`
//!   (`ln t ≤ 1`), 0.91 at `t = 3`, 0.072 at 10^6, 0.048 at 10^9, 0.043 at 10^10.
//! * One random draw per step for the decision: its high 32 bits decide whether to explore
//!   (probability `ε_t`), its low 32 bits pick the random decision, uniform over all `D` (the
//!   greedy one included, as in Sutton and Barto's ε-greedy).
//! * Greedy ties ([`Ties`]) are broken uniformly at random by default, in learning and in the
//!   evaluation of the greedy policy alike: the paper writes `a ∈ argmax_a Q(s, a)` and leaves
//!   the choice open. With a zero table, the lowest index would make every unlearnt state
//!   answer decision 0 (both mobiles turn left): they spin in place, explore badly, and the
//!   greedy policy locks into such spins (see `docs/qlearning.md`). [`Ties::Lowest`] is kept
//!   for that comparison. The learner breaks ties with the low 32 bits of the step's draw
//!   (unused when it does not explore), so it spends no extra draw.
//! * The table starts at 0 (the paper: "arbitrary"). Optimism (e.g. `1/(1−γ)`) would push the
//!   learner into every one of the 655 million pairs before it could exploit anything.
//! * One random stream, `(seed, QLearning, 0, 0)`, drives the whole run (Q-learning is
//!   sequential); its state, `t`, the world's state and the table make a checkpoint, so that a
//!   resumed run continues exactly as an uninterrupted one.
//!
//! # Value type and layout
//!
//! `f32`, row-major `[state][action]`, each 16-value row on one 64-byte cache line (the table
//! is aligned to 64 bytes): the greedy choice, the max over `a'` and the update each touch one
//! line, so a step costs one random memory access. `f32` holds every reachable value
//! (`0 ≤ Q ≤ 1/(1−γ) = 100`) to within 2^-17 ≈ 8·10^-6 near 100, far below the smallest change
//! the learning makes. Half precision (f16: 0.06 near 100) or 16-bit fixed point (0.003 over
//! 0..100) would silently drop the updates `α·δ` smaller than half a step, which is most of
//! them once `Q` is large: values would stall short of their fixed point. `f64` would double the
//! table to 5.2 GB and the cache lines touched per row, for no gain.
//!
//! The table (2.6 GB for the paper's world) is zeroed lazily by the system (pages come zeroed
//! on first touch); before allocating, the memory the system reports available is checked and
//! a clear [`Error::Memory`] is returned when the table would not fit.

use std::fs::File;
use std::io::{BufReader, BufWriter, Read, Write};
use std::path::{Path, PathBuf};
use std::time::Instant;

use rand::Rng;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use serde_json::{Value, json};

use crate::error::{Error, Result};
use crate::evaluate::{Evaluation, check_fits};
use crate::optimize::Flow;
use crate::policy::Hhmm;
use crate::rng::{EngineRng, Purpose, stream};
use crate::tracking::{Mobile, TargetTracking, TrackingState};
use crate::world::World;

/// The paper's discount `γ`.
pub const GAMMA: f64 = 0.99;
/// The paper's learning rate `α`.
pub const ALPHA: f64 = 0.1;
/// The paper's best case-3 reward, the 100 % of its comparison table (model §5).
pub const PAPER_REFERENCE: f64 = 69.0;
/// The `format` of a Q-table file's header.
pub const FORMAT: &str = "cehmm-qtable";
/// The file version this engine reads and writes.
pub const VERSION: u64 = 1;
/// The first 8 bytes of a Q-table file.
pub const MAGIC: &[u8; 8] = b"CEQTABLE";
/// Updates run between two progress reports (and stop, checkpoint checks) by [`QLearner::train`].
pub const CHUNK: u64 = 1 << 20;

/// A world that can run as a continuing task: stepped forever, each step paying its own reward.
pub trait ContinuingWorld: World {
    /// Like [`World::step`] (accounts for the current step with `decision`, moves to the next
    /// state), returning this step's reward; the state keeps no unbounded running total.
    fn step_reward(&self, state: &mut Self::State, decision: usize, rng: &mut EngineRng) -> f64;
}

/// A continuing world whose state, with the last observation, is known to the learner: the
/// index of a row of the Q table.
pub trait KnownState: ContinuingWorld {
    /// Number of known states (rows of the table); an error when it overflows the address space.
    fn n_states(&self) -> Result<usize>;
    /// The known state `s` of `state` seen through observation `y`, in `0..n_states()`.
    fn known_state(&self, state: &Self::State, y: usize) -> usize;
    /// The state written by [`World::describe`] (for checkpoints), checked.
    fn restore(&self, values: &[i64]) -> Result<Self::State>;
}

/// Index of a mobile's configuration `(j·width + i)·4 + heading`.
#[inline]
fn configuration(m: Mobile, width: i32) -> usize {
    ((m.j * width + m.i) * 4 + m.heading as i32) as usize
}

impl ContinuingWorld for TargetTracking {
    #[inline]
    fn step_reward(&self, state: &mut TrackingState, decision: usize, rng: &mut EngineRng) -> f64 {
        // The score counts this one step only, so it never overflows however long the run.
        state.score = 0;
        self.step(state, decision, rng);
        let reward = state.score;
        state.score = 0;
        reward as f64
    }
}

impl KnownState for TargetTracking {
    /// `Y · (4·width·height)²`: 16 × 1600 × 1600 = 40,960,000 on the paper's grid.
    fn n_states(&self) -> Result<usize> {
        let p = self.params();
        let configurations = p.width as u128 * p.height as u128 * 4;
        let n = self.n_observations() as u128 * configurations * configurations;
        usize::try_from(n)
            .map_err(|_| Error::invalid("world", format!("{n} known states (more than this machine can address)")))
    }

    /// `(y · P + B) · P + C` with `P = 4·width·height` and `B`, `C` each mobile's
    /// `(j·width + i)·4 + heading`.
    #[inline]
    fn known_state(&self, state: &TrackingState, y: usize) -> usize {
        let p = self.params();
        let configurations = (p.width * p.height * 4) as usize;
        (y * configurations + configuration(state.b, p.width)) * configurations + configuration(state.c, p.width)
    }

    fn restore(&self, values: &[i64]) -> Result<TrackingState> {
        let p = self.params();
        let bad = || {
            Error::format(format!(
                "world state {values:?} (expected b_i, b_j, b_heading, c_i, c_j, c_heading, target_i, target_j on the {}×{} grid)",
                p.width, p.height
            ))
        };
        let &[bi, bj, bh, ci, cj, ch, ti, tj] = values else { return Err(bad()) };
        let column = |v: i64| (0..p.width as i64).contains(&v);
        let row = |v: i64| (0..p.height as i64).contains(&v);
        let heading = |v: i64| (0..4).contains(&v);
        if !(column(bi) && row(bj) && heading(bh) && column(ci) && row(cj) && heading(ch) && column(ti) && row(tj)) {
            return Err(bad());
        }
        Ok(TrackingState {
            b: Mobile { i: bi as i32, j: bj as i32, heading: bh as u8 },
            c: Mobile { i: ci as i32, j: cj as i32, heading: ch as u8 },
            target: [ti as i32, tj as i32],
            score: 0,
        })
    }
}

/// `ε_t = min(1, 1/ln t)` for update `t` (counted from 1): 1 while `ln t ≤ 1`, i.e. `t ≤ 2`.
#[inline]
pub fn epsilon(t: u64) -> f64 {
    if t < 3 { 1.0 } else { 1.0 / (t as f64).ln() }
}

/// The memory the system says a new allocation can take, in bytes: `MemAvailable` from
/// `/proc/meminfo`, lowered to what a cgroup (v2) limit leaves; `None` when unknown.
pub fn available_memory() -> Option<u64> {
    let meminfo = std::fs::read_to_string("/proc/meminfo").ok()?;
    let kib = meminfo.lines().find_map(|l| l.strip_prefix("MemAvailable:"))?.trim().strip_suffix("kB")?.trim();
    let mut available = kib.parse::<u64>().ok()?.checked_mul(1024)?;
    let read = |name: &str| std::fs::read_to_string(format!("/sys/fs/cgroup/{name}")).ok()?.trim().parse::<u64>().ok();
    if let (Some(limit), Some(used)) = (read("memory.max"), read("memory.current")) {
        available = available.min(limit.saturating_sub(used));
    }
    Some(available)
}

/// `Ok` when `needed` bytes fit in `available` (unknown: assumed to fit), else [`Error::Memory`].
pub fn check_memory(what: &str, needed: u64, available: Option<u64>) -> Result<()> {
    match available {
        Some(available) if needed > available => Err(Error::Memory { what: what.to_string(), needed, available }),
        _ => Ok(()),
    }
}

/// Bytes of a table of `n_states × n_actions` `f32` values (with the 64 bytes of alignment slack).
pub fn table_bytes(n_states: usize, n_actions: usize) -> Result<u64> {
    let values = (n_states as u128) * (n_actions as u128);
    let bytes = values * 4 + 64;
    if bytes > isize::MAX as u128 {
        return Err(Error::invalid(
            "world",
            format!("a Q table of {n_states} × {n_actions} values ({bytes} bytes) exceeds the address space"),
        ));
    }
    Ok(bytes as u64)
}

/// The Q table: `f32` values, row-major `[state][action]`, rows aligned to 64 bytes.
#[derive(Clone)]
pub struct QTable {
    /// The values, with up to 16 leading slack values so that `values[offset]` is 64-byte aligned.
    values: Vec<f32>,
    offset: usize,
    n_states: usize,
    n_actions: usize,
}

/// Slack values allocated so that the table can start on a 64-byte boundary.
const ALIGN_SLACK: usize = 64 / std::mem::size_of::<f32>();

impl QTable {
    /// A table of zeros, after checking that it fits in the available memory.
    pub fn zeros(n_states: usize, n_actions: usize) -> Result<QTable> {
        if n_states == 0 || n_actions == 0 {
            return Err(Error::invalid("table", format!("{n_states} × {n_actions} (expected at least 1 × 1)")));
        }
        let needed = table_bytes(n_states, n_actions)?;
        check_memory(
            &format!("a Q table of {n_states} states × {n_actions} actions (f32)"),
            needed,
            available_memory(),
        )?;
        // `vec![0.0; n]` asks the allocator for zeroed memory: fresh pages, zeroed on first touch.
        let values = vec![0f32; n_states * n_actions + ALIGN_SLACK];
        let offset = values.as_ptr().align_offset(64);
        let offset = if offset < ALIGN_SLACK { offset } else { 0 };
        advise_huge_pages(&values);
        Ok(QTable { values, offset, n_states, n_actions })
    }

    /// Number of states (rows).
    pub fn n_states(&self) -> usize {
        self.n_states
    }

    /// Number of actions (columns).
    pub fn n_actions(&self) -> usize {
        self.n_actions
    }

    /// Size of the values in bytes.
    pub fn bytes(&self) -> u64 {
        (self.n_states * self.n_actions * 4) as u64
    }

    /// Every value, row-major `[state][action]`.
    pub fn values(&self) -> &[f32] {
        &self.values[self.offset..self.offset + self.n_states * self.n_actions]
    }

    fn values_mut(&mut self) -> &mut [f32] {
        let len = self.n_states * self.n_actions;
        &mut self.values[self.offset..self.offset + len]
    }

    /// The values `Q(s, ·)`.
    #[inline]
    pub fn row(&self, s: usize) -> &[f32] {
        let start = self.offset + s * self.n_actions;
        &self.values[start..start + self.n_actions]
    }

    /// The lowest greedy action of state `s` (the first index of the largest value).
    #[inline]
    pub fn greedy(&self, s: usize) -> usize {
        greedy_and_max(self.row(s)).0
    }

    /// A greedy action of state `s`, ties broken by `ties`; `bits` (called only when there is a
    /// tie to break at random) gives 32 random bits.
    #[inline]
    pub fn greedy_with(&self, s: usize, ties: Ties, bits: impl FnOnce() -> u32) -> usize {
        let row = self.row(s);
        let (first, max) = greedy_and_max(row);
        if ties == Ties::Lowest {
            return first;
        }
        let count = row.iter().filter(|&&v| v == max).count();
        if count == 1 {
            return first;
        }
        let k = ((bits() as u64 * count as u64) >> 32) as usize;
        row.iter().enumerate().filter(|&(_, &v)| v == max).nth(k).map_or(first, |(a, _)| a)
    }

    /// `Q(s, a) += α (r + γ max_a' Q(s', a') − Q(s, a))`; returns `max_a' Q(s', a')` as read
    /// before the update.
    #[inline]
    pub fn update(&mut self, s: usize, a: usize, reward: f32, s_next: usize, alpha: f32, gamma: f32) -> f32 {
        let (_, max) = greedy_and_max(self.row(s_next));
        let q = &mut self.values[self.offset + s * self.n_actions + a];
        *q += alpha * (reward + gamma * max - *q);
        max
    }
}

impl PartialEq for QTable {
    fn eq(&self, other: &QTable) -> bool {
        self.n_actions == other.n_actions && self.values() == other.values()
    }
}

impl std::fmt::Debug for QTable {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "QTable({} states × {} actions, {} bytes)", self.n_states, self.n_actions, self.bytes())
    }
}

/// Asks Linux to back the table with 2 MiB pages (transparent huge pages, where the system
/// allows them on request): a step reads one random row of a multi-gigabyte table, and with
/// 4 KiB pages nearly every read would also miss the TLB. Advisory only: no effect on results.
fn advise_huge_pages(values: &[f32]) {
    #[cfg(target_os = "linux")]
    {
        const HUGE: usize = 2 << 20;
        let start = values.as_ptr() as usize;
        let end = start + std::mem::size_of_val(values);
        let (first, last) = (start.next_multiple_of(HUGE), end / HUGE * HUGE);
        if last > first {
            // SAFETY: madvise only advises the kernel on pages inside the live allocation
            // `values`; it reads and writes no memory, and its failure is harmless.
            unsafe {
                libc::madvise(first as *mut libc::c_void, last - first, libc::MADV_HUGEPAGE);
            }
        }
    }
    #[cfg(not(target_os = "linux"))]
    let _ = values;
}

/// The first index of the largest value, and that value.
#[inline]
fn greedy_and_max(row: &[f32]) -> (usize, f32) {
    let mut best = (0, row[0]);
    for (k, &v) in row.iter().enumerate().skip(1) {
        if v > best.1 {
            best = (k, v);
        }
    }
    best
}

/// How a greedy action is chosen among actions of equal value.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Ties {
    /// Uniformly at random among the maximal actions.
    #[default]
    Random,
    /// The lowest index (deterministic).
    Lowest,
}

impl Ties {
    /// `"random"` or `"lowest"`.
    pub fn as_str(self) -> &'static str {
        match self {
            Ties::Random => "random",
            Ties::Lowest => "lowest",
        }
    }

    /// From `"random"` or `"lowest"`.
    pub fn parse(text: &str) -> Result<Ties> {
        match text {
            "random" => Ok(Ties::Random),
            "lowest" => Ok(Ties::Lowest),
            other => Err(Error::invalid("ties", format!("{other:?} (expected \"random\" or \"lowest\")"))),
        }
    }
}

/// The learning settings; `Default` is the paper's (`γ = 0.99`, `α = 0.1`), random ties.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct QConfig {
    /// Discount `γ` in `[0, 1)`.
    pub gamma: f64,
    /// Learning rate `α` in `(0, 1]`.
    pub alpha: f64,
    /// Seed of the run's random stream.
    pub seed: u64,
    /// How greedy ties are broken, in learning and in the greedy policy.
    pub ties: Ties,
}

impl Default for QConfig {
    fn default() -> Self {
        QConfig { gamma: GAMMA, alpha: ALPHA, seed: 0, ties: Ties::Random }
    }
}

impl QConfig {
    /// Checks every setting, naming the bad one.
    pub fn validate(&self) -> Result<()> {
        if !(0.0..1.0).contains(&self.gamma) {
            return Err(Error::invalid("gamma", format!("{} (expected 0 <= gamma < 1)", self.gamma)));
        }
        if !(self.alpha > 0.0 && self.alpha <= 1.0) {
            return Err(Error::invalid("alpha", format!("{} (expected 0 < alpha <= 1)", self.alpha)));
        }
        Ok(())
    }
}

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
    world: W,
    config: QConfig,
    table: QTable,
    state: W::State,
    y: usize,
    updates: u64,
    rng: EngineRng,
    reward_total: f64,
    seconds: f64,
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
        let mut interrupted = false;
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
            if observer(&progress) == Flow::Stop {
                interrupted = true;
                break;
            }
            if let (Some(path), Some(every)) = (checkpoint, checkpoint_every) {
                if last_checkpoint.elapsed().as_secs_f64() >= every && self.updates < until {
                    self.save(path)?;
                    checkpoints += 1;
                    last_checkpoint = Instant::now();
                }
            }
        }
        if let Some(path) = checkpoint {
            self.save(path)?;
            checkpoints += 1;
        }
        Ok(TrainOutcome {
            updates: self.updates - first,
            seconds: started.elapsed().as_secs_f64(),
            interrupted,
            checkpoints,
        })
    }

    /// The header of the run's file: every setting, the counters, the random stream's state and
    /// the world's current state.
    pub fn header(&self) -> Value {
        let mut state = Vec::new();
        self.world.describe(&self.state, &mut state);
        json!({
            "format": FORMAT,
            "version": VERSION,
            "world": self.world.to_json(),
            "n_states": self.table.n_states,
            "n_actions": self.table.n_actions,
            "value_type": "f32",
            "byte_order": "little-endian",
            "layout": "row-major [state][action]; target tracking: state = (y * P + B) * P + C, P = 4 * width * height, B and C = (j * width + i) * 4 + heading",
            "gamma": self.config.gamma,
            "alpha": self.config.alpha,
            "epsilon": "min(1, 1/ln t), t = 1, 2, ... the update count",
            "seed": self.config.seed,
            "ties": self.config.ties.as_str(),
            "updates": self.updates,
            "reward_total": self.reward_total,
            "seconds": self.seconds,
            "rng": serde_json::to_value(&self.rng).expect("the generator serialises"),
            "world_state": state,
            "observation": self.y,
            "engine_version": crate::VERSION,
        })
    }

    /// Writes the run (header and table) to `path`, through a temporary file renamed at the end,
    /// so that an interrupted save never leaves a broken file. Format: [`MAGIC`], the header's
    /// length (u64, little-endian), the header (JSON), zero padding to a multiple of 64 bytes,
    /// then the `n_states × n_actions` values (f32, little-endian, row-major).
    pub fn save(&self, path: impl AsRef<Path>) -> Result<()> {
        let path = path.as_ref();
        let io = |source| Error::Io { path: path.to_path_buf(), source };
        let mut tmp_name = path.as_os_str().to_owned();
        tmp_name.push(".tmp");
        let tmp = PathBuf::from(tmp_name);
        let header = serde_json::to_vec(&self.header()).expect("JSON values serialise");
        let file = File::create(&tmp).map_err(|source| Error::Io { path: tmp.clone(), source })?;
        let mut out = BufWriter::with_capacity(8 << 20, file);
        let written = (|| -> std::io::Result<()> {
            out.write_all(MAGIC)?;
            out.write_all(&(header.len() as u64).to_le_bytes())?;
            out.write_all(&header)?;
            out.write_all(&vec![0u8; padding(header.len())])?;
            let mut bytes = Vec::with_capacity(1 << 22);
            for chunk in self.table.values().chunks(1 << 20) {
                bytes.clear();
                bytes.extend(chunk.iter().flat_map(|v| v.to_le_bytes()));
                out.write_all(&bytes)?;
            }
            out.into_inner().map_err(std::io::IntoInnerError::into_error)?.sync_all()
        })();
        written.map_err(|source| Error::Io { path: tmp.clone(), source })?;
        std::fs::rename(&tmp, path).map_err(io)
    }

    /// Reads a run saved by [`QLearner::save`] for `world` (which must be the file's world).
    pub fn load(path: impl AsRef<Path>, world: W) -> Result<Self> {
        let path = path.as_ref();
        let with_path = |message: String| Error::PolicyFormat { path: Some(path.to_path_buf()), message };
        let (header, data_offset, mut reader) = open_table(path)?;
        if header.get("world") != Some(&world.to_json()) {
            return Err(Error::Mismatch(format!(
                "the Q table was learnt in the world {}, not {}",
                header.get("world").unwrap_or(&Value::Null),
                world.to_json()
            )));
        }
        let number = |key: &str| {
            header
                .get(key)
                .and_then(Value::as_u64)
                .ok_or_else(|| with_path(format!("header key {key:?} is missing or not a count")))
        };
        let float = |key: &str| {
            header
                .get(key)
                .and_then(Value::as_f64)
                .ok_or_else(|| with_path(format!("header key {key:?} is missing or not a number")))
        };
        let (n_states, n_actions) = (number("n_states")? as usize, number("n_actions")? as usize);
        if n_states != world.n_states()? || n_actions != world.n_decisions() {
            return Err(with_path(format!(
                "{n_states} × {n_actions} values (the world has {} states × {} actions)",
                world.n_states()?,
                world.n_decisions()
            )));
        }
        if header.get("value_type").and_then(Value::as_str) != Some("f32") {
            return Err(with_path(format!("value_type {:?} (expected \"f32\")", header.get("value_type"))));
        }
        let ties = header.get("ties").and_then(Value::as_str).unwrap_or("missing");
        let ties = Ties::parse(ties).map_err(|e| with_path(e.to_string()))?;
        let config = QConfig { gamma: float("gamma")?, alpha: float("alpha")?, seed: number("seed")?, ties };
        config.validate().map_err(|e| with_path(e.to_string()))?;
        let rng: EngineRng = serde_json::from_value(header.get("rng").cloned().unwrap_or(Value::Null))
            .map_err(|e| with_path(format!("rng: {e}")))?;
        let values: Vec<i64> = serde_json::from_value(header.get("world_state").cloned().unwrap_or(Value::Null))
            .map_err(|e| with_path(format!("world_state: {e}")))?;
        let state = world.restore(&values).map_err(|e| with_path(e.to_string()))?;
        let y = number("observation")? as usize;
        if y >= world.n_observations() {
            return Err(with_path(format!("observation {y} (expected < {})", world.n_observations())));
        }
        let expected = data_offset + (n_states * n_actions * 4) as u64;
        let length = std::fs::metadata(path).map_err(|source| Error::Io { path: path.to_path_buf(), source })?.len();
        if length != expected {
            return Err(with_path(format!(
                "{length} bytes (expected {expected}: the header and {n_states} × {n_actions} f32 values)"
            )));
        }
        let mut table = QTable::zeros(n_states, n_actions)?;
        let mut bytes = vec![0u8; 1 << 22];
        for chunk in table.values_mut().chunks_mut(1 << 20) {
            let bytes = &mut bytes[..chunk.len() * 4];
            reader.read_exact(bytes).map_err(|source| Error::Io { path: path.to_path_buf(), source })?;
            for (v, b) in chunk.iter_mut().zip(bytes.chunks_exact(4)) {
                *v = f32::from_le_bytes([b[0], b[1], b[2], b[3]]);
            }
        }
        Ok(QLearner {
            world,
            config,
            table,
            state,
            y,
            updates: number("updates")?,
            rng,
            reward_total: float("reward_total")?,
            seconds: float("seconds")?,
        })
    }
}

/// Zero bytes after a header of `len` bytes so that the values start on a multiple of 64.
fn padding(len: usize) -> usize {
    (64 - (16 + len) % 64) % 64
}

/// Opens a Q-table file: its header, the offset of its values, and a reader positioned there.
fn open_table(path: &Path) -> Result<(Value, u64, BufReader<File>)> {
    let io = |source| Error::Io { path: path.to_path_buf(), source };
    let bad = |message: String| Error::PolicyFormat { path: Some(path.to_path_buf()), message };
    let mut reader = BufReader::with_capacity(8 << 20, File::open(path).map_err(io)?);
    let mut start = [0u8; 16];
    reader.read_exact(&mut start).map_err(|_| bad("not a cehmm Q table (shorter than its 16-byte prefix)".into()))?;
    if &start[..8] != MAGIC {
        return Err(bad(format!("not a cehmm Q table (the file does not start with {:?})", "CEQTABLE")));
    }
    let len = u64::from_le_bytes(start[8..16].try_into().expect("8 bytes"));
    if len > 1 << 24 {
        return Err(bad(format!("header of {len} bytes (expected at most 16 MiB)")));
    }
    let mut text = vec![0u8; len as usize + padding(len as usize)];
    reader.read_exact(&mut text).map_err(|_| bad("truncated header".into()))?;
    let header: Value =
        serde_json::from_slice(&text[..len as usize]).map_err(|e| bad(format!("header is not JSON: {e}")))?;
    if header.get("format").and_then(Value::as_str) != Some(FORMAT) {
        return Err(bad(format!("format {:?} (expected {FORMAT:?})", header.get("format"))));
    }
    if header.get("version").and_then(Value::as_u64) != Some(VERSION) {
        return Err(bad(format!("version {:?} (expected {VERSION})", header.get("version"))));
    }
    Ok((header, 16 + text.len() as u64, reader))
}

/// The header of a Q-table file (its world, settings and counters), without reading the table.
pub fn read_header(path: impl AsRef<Path>) -> Result<Value> {
    Ok(open_table(path.as_ref())?.0)
}

/// Reads a Q-table file of the target-tracking world, rebuilding the world from its header.
pub fn load_tracking(path: impl AsRef<Path>) -> Result<QLearner<TargetTracking>> {
    let path = path.as_ref();
    let header = read_header(path)?;
    let world = TargetTracking::from_json(header.get("world").unwrap_or(&Value::Null))?;
    QLearner::load(path, world)
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
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct TrainOutcome {
    /// Updates run in this call.
    pub updates: u64,
    /// Wall seconds of this call (checkpoints included).
    pub seconds: f64,
    /// Whether the observer stopped it.
    pub interrupted: bool,
    /// Checkpoints written.
    pub checkpoints: u64,
}

/// A policy that can be run step after step for as long as wanted (a continuing run).
pub trait WindowPolicy<W: World>: Sync {
    /// Memory cells the policy carries from step to step (`Λ` for an HHMM).
    fn memory_len(&self) -> usize {
        0
    }
    /// Checks that the policy fits the world.
    fn check(&self, world: &W) -> Result<()>;
    /// The decision for `state` seen through `y`; `first` only at the run's very first step.
    fn decide(
        &self,
        world: &W,
        state: &W::State,
        y: usize,
        memory: &mut [u16],
        first: bool,
        rng: &mut EngineRng,
    ) -> usize;
}

impl<W: World> WindowPolicy<W> for Hhmm {
    fn memory_len(&self) -> usize {
        self.levels().len()
    }

    fn check(&self, world: &W) -> Result<()> {
        check_fits(world, self)
    }

    #[inline]
    fn decide(&self, _: &W, _: &W::State, y: usize, memory: &mut [u16], first: bool, rng: &mut EngineRng) -> usize {
        self.step(y, memory, first, rng)
    }
}

/// The greedy policy of a Q table.
#[derive(Clone, Copy, Debug)]
pub struct Greedy<'a> {
    /// The table.
    pub table: &'a QTable,
    /// How ties are broken (at random: with a draw of the run's stream, only when there is a tie).
    pub ties: Ties,
}

impl<W: KnownState> QLearner<W> {
    /// The greedy policy of the table, ties broken as in learning.
    pub fn greedy_policy(&self) -> Greedy<'_> {
        Greedy { table: &self.table, ties: self.config.ties }
    }
}

impl<W: KnownState> WindowPolicy<W> for Greedy<'_> {
    fn check(&self, world: &W) -> Result<()> {
        let t = self.table;
        if t.n_states != world.n_states()? || t.n_actions != world.n_decisions() {
            return Err(Error::Mismatch(format!(
                "the Q table has {} states × {} actions, the world {} × {}",
                t.n_states,
                t.n_actions,
                world.n_states()?,
                world.n_decisions()
            )));
        }
        Ok(())
    }

    #[inline]
    fn decide(&self, world: &W, state: &W::State, y: usize, _: &mut [u16], _: bool, rng: &mut EngineRng) -> usize {
        self.table.greedy_with(world.known_state(state, y), self.ties, || (rng.next_u64() >> 32) as u32)
    }
}

/// How to cut runs into windows (the paper: 100 steps).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct WindowConfig {
    /// Steps per window.
    pub window: usize,
    /// (a) Windows from the initial state: one per fresh start (target drawn as in the world's
    /// `reset`), stream `(seed, Evaluate, 0, k)`.
    pub episodes: usize,
    /// (b) Independent continuing runs, each from a fresh start, stream `(seed, Evaluate, 1, k)`.
    pub chains: usize,
    /// (b) Steps each continuing run makes before its first window ("after many cycles").
    pub burn_in: u64,
    /// (b) Consecutive windows taken from each continuing run after its burn-in.
    pub windows_per_chain: usize,
}

impl Default for WindowConfig {
    fn default() -> Self {
        WindowConfig { window: 100, episodes: 10_000, chains: 16, burn_in: 100_000, windows_per_chain: 10_000 }
    }
}

impl WindowConfig {
    /// Checks every setting, naming the bad one.
    pub fn validate(&self) -> Result<()> {
        let max = crate::optimize::MAX_EPISODES;
        for (name, v) in [("window", self.window), ("episodes", self.episodes), ("chains", self.chains)] {
            if v == 0 || v > max {
                return Err(Error::invalid(name, format!("{v} (expected 1..={max})")));
            }
        }
        if self.windows_per_chain == 0 || self.chains.saturating_mul(self.windows_per_chain) > max {
            return Err(Error::invalid(
                "windows_per_chain",
                format!("{} (expected at least 1, and chains × windows_per_chain <= {max})", self.windows_per_chain),
            ));
        }
        Ok(())
    }
}

/// The non-discounted reward of 100-step windows, as the paper compares Q-learning and CE.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct WindowReport {
    /// (a) Windows from the initial state (`min` is the worst window, `max` the best).
    pub from_start: Evaluation,
    /// (b) Consecutive windows of continuing runs after the burn-in (they are correlated: the
    /// standard error of `continuing` understates the uncertainty).
    pub continuing: Evaluation,
    /// The settings.
    pub config: WindowConfig,
}

/// `reward` as a percentage of `reference` (the paper: of 69, [`PAPER_REFERENCE`]).
pub fn percent(reward: f64, reference: f64) -> f64 {
    100.0 * reward / reference
}

/// Runs `policy` for `steps` steps of the continuing task; returns the sum of their rewards.
#[inline]
fn run_steps<W: ContinuingWorld, P: WindowPolicy<W>>(
    world: &W,
    policy: &P,
    state: &mut W::State,
    memory: &mut [u16],
    first: &mut bool,
    steps: u64,
    rng: &mut EngineRng,
) -> f64 {
    let mut reward = 0.0;
    for _ in 0..steps {
        let y = world.observe(state, rng);
        let d = policy.decide(world, state, y, memory, *first, rng);
        *first = false;
        reward += world.step_reward(state, d, rng);
    }
    reward
}

/// Evaluates `policy` on windows of the continuing task: (a) one window from each of
/// `episodes` fresh starts, (b) consecutive windows of `chains` long runs after a burn-in; in
/// parallel on the current rayon pool, reproducible from `seed` whatever the thread count.
///
/// For an HHMM, (a) gives exactly the rewards of [`crate::evaluate::rewards`] with the same
/// seed when `window` is the world's horizon.
pub fn evaluate_windows<W: ContinuingWorld, P: WindowPolicy<W>>(
    world: &W,
    policy: &P,
    config: &WindowConfig,
    seed: u64,
) -> Result<WindowReport> {
    config.validate()?;
    policy.check(world)?;
    let window = config.window as u64;
    let from_start: Vec<f64> = (0..config.episodes)
        .into_par_iter()
        .map(|k| {
            let mut rng = stream(seed, Purpose::Evaluate, 0, k as u64);
            let mut memory = vec![0u16; policy.memory_len()];
            let mut state = world.reset(&mut rng);
            run_steps(world, policy, &mut state, &mut memory, &mut true, window, &mut rng)
        })
        .collect();
    let continuing: Vec<f64> = (0..config.chains)
        .into_par_iter()
        .flat_map_iter(|k| {
            let mut rng = stream(seed, Purpose::Evaluate, 1, k as u64);
            let mut memory = vec![0u16; policy.memory_len()];
            let mut state = world.reset(&mut rng);
            let mut first = true;
            run_steps(world, policy, &mut state, &mut memory, &mut first, config.burn_in, &mut rng);
            (0..config.windows_per_chain)
                .map(|_| run_steps(world, policy, &mut state, &mut memory, &mut first, window, &mut rng))
                .collect::<Vec<f64>>()
        })
        .collect();
    Ok(WindowReport {
        from_start: Evaluation::from_rewards(&from_start),
        continuing: Evaluation::from_rewards(&continuing),
        config: config.clone(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tracking::TrackingParams;

    /// A two-state cycle 0 → 1 → 0 → ... with one observation, `D` decisions that do not
    /// matter, and reward 1 for every step taken from state 1: the Q-learning updates can be
    /// worked out by hand.
    struct Cycle {
        decisions: usize,
    }

    impl World for Cycle {
        type State = u8;
        fn n_observations(&self) -> usize {
            1
        }
        fn n_decisions(&self) -> usize {
            self.decisions
        }
        fn horizon(&self) -> usize {
            4
        }
        fn reset(&self, _: &mut EngineRng) -> u8 {
            0
        }
        fn observe(&self, _: &u8, _: &mut EngineRng) -> usize {
            0
        }
        fn step(&self, s: &mut u8, _: usize, _: &mut EngineRng) {
            *s = 1 - *s;
        }
        fn reward(&self, _: &u8) -> f64 {
            0.0
        }
        fn describe(&self, s: &u8, out: &mut Vec<i64>) {
            out.push(*s as i64);
        }
        fn to_json(&self) -> Value {
            json!({ "name": "cycle", "decisions": self.decisions })
        }
    }

    impl ContinuingWorld for Cycle {
        fn step_reward(&self, s: &mut u8, d: usize, rng: &mut EngineRng) -> f64 {
            let reward = *s as f64;
            self.step(s, d, rng);
            reward
        }
    }

    impl KnownState for Cycle {
        fn n_states(&self) -> Result<usize> {
            Ok(2)
        }
        fn known_state(&self, s: &u8, _: usize) -> usize {
            *s as usize
        }
        fn restore(&self, v: &[i64]) -> Result<u8> {
            Ok(v[0] as u8)
        }
    }

    fn small_world() -> TargetTracking {
        TargetTracking::with_params(TrackingParams {
            width: 5,
            height: 5,
            start_b: [0, 4],
            start_c: [4, 4],
            target_rows: [0, 2],
            target_cell: [2, 2],
            ..TrackingParams::default()
        })
        .unwrap()
    }

    fn temp(name: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("ceworld-qlearn-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        dir.join(name)
    }

    #[test]
    fn update_rule_by_hand_on_a_two_state_cycle() {
        // One decision: ε does not matter. With α = 0.1, γ = 0.99, from Q = 0:
        // t=1, s=0 → 1, r=0: Q(0) = 0 + 0.1 (0 + 0.99·0 − 0)            = 0
        // t=2, s=1 → 0, r=1: Q(1) = 0 + 0.1 (1 + 0.99·0 − 0)            = 0.1
        // t=3, s=0 → 1, r=0: Q(0) = 0 + 0.1 (0 + 0.99·0.1 − 0)          = 0.0099
        // t=4, s=1 → 0, r=1: Q(1) = 0.1 + 0.1 (1 + 0.99·0.0099 − 0.1)   = 0.1909801
        let mut learner = QLearner::new(Cycle { decisions: 1 }, QConfig::default()).unwrap();
        let expected = [[0.0, 0.0], [0.0, 0.1], [0.0099, 0.1], [0.0099, 0.190_980_1]];
        for (t, want) in expected.iter().enumerate() {
            let stats = learner.run(1);
            assert_eq!(stats.reward, (t % 2) as f64);
            let q = learner.table().values();
            assert!((q[0] as f64 - want[0]).abs() < 1e-7 && (q[1] as f64 - want[1]).abs() < 1e-7, "t={}: {q:?}", t + 1);
        }
        assert_eq!(learner.updates(), 4);
        assert_eq!(learner.reward_total(), 2.0);
    }

    #[test]
    fn update_rule_on_given_values() {
        let mut table = QTable::zeros(3, 4).unwrap();
        table.values_mut().copy_from_slice(&[
            1.0, 2.0, 3.0, 4.0, //
            0.5, 2.0, 2.0, -1.0, //
            0.0, 0.0, 0.0, 0.0,
        ]);
        // Q(0, 2) = 3 + 0.5 (1 + 0.9·2 − 3) = 2.9; max of row 1 is 2, first reached at action 1.
        let max = table.update(0, 2, 1.0, 1, 0.5, 0.9);
        assert_eq!(max, 2.0);
        assert!((table.row(0)[2] - 2.9).abs() < 1e-6);
        assert_eq!(table.row(1), &[0.5, 2.0, 2.0, -1.0], "only Q(s, a) changes");
        assert_eq!(table.greedy(2), 0, "ties go to the lowest index");
        assert_eq!(table.greedy(0), 3);
        assert_eq!(table.greedy_with(1, Ties::Lowest, || panic!("no draw")), 1);
        assert_eq!(table.greedy_with(0, Ties::Random, || panic!("no draw without a tie")), 3);
        // Row 1 ties actions 1 and 2: the high half of the 32 bits picks the second.
        assert_eq!(table.greedy_with(1, Ties::Random, || 0x7fff_ffff), 1);
        assert_eq!(table.greedy_with(1, Ties::Random, || 0x8000_0000), 2);
        let mut counts = [0usize; 4];
        let mut rng = stream(0, Purpose::Evaluate, 0, 0);
        for _ in 0..40_000 {
            counts[table.greedy_with(2, Ties::Random, || (rng.next_u64() >> 32) as u32)] += 1;
        }
        assert!(counts.iter().all(|&c| (9_400..10_600).contains(&c)), "uniform among the four ties: {counts:?}");
    }

    #[test]
    fn epsilon_schedule() {
        assert_eq!(epsilon(1), 1.0);
        assert_eq!(epsilon(2), 1.0, "1/ln 2 = 1.44 is capped at 1");
        assert!((epsilon(3) - 1.0 / 3f64.ln()).abs() < 1e-15);
        assert!((epsilon(1_000_000_000) - 0.048_254).abs() < 1e-6);
        let mut previous = 1.0;
        for t in (1..2_000_000u64).step_by(997) {
            let e = epsilon(t);
            assert!(e <= previous && e > 0.0 && e <= 1.0);
            assert!((e - (1.0 / (t as f64).ln()).min(1.0)).abs() < 1e-15);
            previous = e;
        }
    }

    /// One state, no reward, four decisions: Q stays 0, so with lowest-index ties the greedy
    /// decision is always 0 and every other one comes from exploration, with probability (`3/4)·ε_t`.
    struct Explorer {
        explored: std::sync::atomic::AtomicU64,
    }

    impl World for Explorer {
        type State = ();
        fn n_observations(&self) -> usize {
            1
        }
        fn n_decisions(&self) -> usize {
            4
        }
        fn horizon(&self) -> usize {
            1
        }
        fn reset(&self, _: &mut EngineRng) {}
        fn observe(&self, (): &(), _: &mut EngineRng) -> usize {
            0
        }
        fn step(&self, (): &mut (), d: usize, _: &mut EngineRng) {
            if d != 0 {
                self.explored.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
            }
        }
        fn reward(&self, (): &()) -> f64 {
            0.0
        }
        fn to_json(&self) -> Value {
            json!({ "name": "explorer" })
        }
    }

    impl ContinuingWorld for Explorer {
        fn step_reward(&self, s: &mut (), d: usize, rng: &mut EngineRng) -> f64 {
            self.step(s, d, rng);
            0.0
        }
    }

    impl KnownState for Explorer {
        fn n_states(&self) -> Result<usize> {
            Ok(1)
        }
        fn known_state(&self, (): &(), _: usize) -> usize {
            0
        }
        fn restore(&self, _: &[i64]) -> Result<()> {
            Ok(())
        }
    }

    #[test]
    fn exploration_frequency_follows_epsilon() {
        let world = Explorer { explored: std::sync::atomic::AtomicU64::default() };
        let mut learner = QLearner::new(world, QConfig { seed: 3, ties: Ties::Lowest, ..QConfig::default() }).unwrap();
        let n = 1_000_000u64;
        learner.run(n);
        let p: Vec<f64> = (1..=n).map(|t| 0.75 * epsilon(t)).collect();
        let mean: f64 = p.iter().sum();
        let sd = p.iter().map(|p| p * (1.0 - p)).sum::<f64>().sqrt();
        let explored = learner.world().explored.load(std::sync::atomic::Ordering::Relaxed) as f64;
        assert!((explored - mean).abs() < 5.0 * sd, "{explored} explorations, expected {mean:.0} ± {sd:.0}");
        assert!(learner.table().values().iter().all(|&v| v == 0.0));
    }

    #[test]
    fn learning_on_a_small_grid_keeps_values_in_range() {
        let mut learner = QLearner::new(small_world(), QConfig { seed: 3, ..QConfig::default() }).unwrap();
        learner.run(100_000);
        assert_eq!(learner.updates(), 100_000);
        let bound = (1.0 / (1.0 - GAMMA)) as f32;
        assert!(learner.table().values().iter().all(|v| v.is_finite() && *v >= 0.0 && *v <= bound));
        assert!(learner.table().values().iter().any(|v| *v > 0.0), "some rewarded pairs were learnt");
    }

    #[test]
    fn known_state_is_a_bijection_with_the_papers_index() {
        let world = TargetTracking::new(3).unwrap();
        assert_eq!(world.n_states().unwrap(), 16 * 1600 * 1600);
        let s = TrackingState {
            b: Mobile { i: 3, j: 7, heading: 2 },
            c: Mobile { i: 19, j: 19, heading: 3 },
            target: [0, 0],
            score: 0,
        };
        let b = (7 * 20 + 3) * 4 + 2;
        let c = (19 * 20 + 19) * 4 + 3;
        assert_eq!(world.known_state(&s, 5), (5 * 1600 + b) * 1600 + c);
        let last = TrackingState { b: Mobile { i: 19, j: 19, heading: 3 }, ..s };
        assert_eq!(world.known_state(&last, 15), world.n_states().unwrap() - 1);
        let small = small_world();
        let mut seen = vec![false; small.n_states().unwrap()];
        let mobiles: Vec<Mobile> = (0..5)
            .flat_map(|j| (0..5).flat_map(move |i| (0..4).map(move |heading| Mobile { i, j, heading })))
            .collect();
        for y in 0..16 {
            for &b in &mobiles {
                for &c in &mobiles {
                    let k = small.known_state(&TrackingState { b, c, target: [0, 0], score: 0 }, y);
                    assert!(!seen[k], "index {k} twice");
                    seen[k] = true;
                }
            }
        }
        assert!(seen.iter().all(|&v| v));
    }

    #[test]
    fn step_reward_is_the_encounter_and_keeps_no_running_score() {
        let world = TargetTracking::new(3).unwrap();
        let mut rng = stream(0, Purpose::Evaluate, 0, 0);
        let mut s = world.initial_state([1, 17]);
        assert!(world.encounter(&s));
        assert_eq!(world.step_reward(&mut s, 15, &mut rng), 1.0);
        assert_eq!(s.score, 0);
        let mut far = world.initial_state([10, 0]);
        assert_eq!(world.step_reward(&mut far, 15, &mut rng), 0.0);
    }

    #[test]
    fn a_table_that_does_not_fit_is_refused_before_allocating() {
        let e = check_memory("a Q table", 2_621_440_064, Some(1 << 30)).unwrap_err();
        let text = e.to_string();
        assert!(text.contains("2621440064") && text.contains("1073741824"), "{text}");
        assert!(check_memory("a Q table", 10, None).is_ok());
        // A 1000 × 1000 grid needs 16 · 4e6² · 16 · 4 bytes ≈ 1.6e16: refused, never allocated.
        let huge =
            TargetTracking::with_params(TrackingParams { width: 1000, height: 1000, ..TrackingParams::default() })
                .unwrap();
        match QLearner::new(huge, QConfig::default()) {
            Err(Error::Memory { needed, .. }) => assert_eq!(needed, 16 * 4_000_000u64 * 4_000_000 * 16 * 4 + 64),
            Err(other) => panic!("unexpected error {other}"),
            Ok(_) => panic!("a 16-petabyte table was allocated"),
        }
        assert_eq!(table_bytes(16 * 1600 * 1600, 16).unwrap(), 2_621_440_064);
    }

    #[test]
    fn bad_settings_are_refused_by_name() {
        for (config, name) in [
            (QConfig { gamma: 1.0, ..QConfig::default() }, "gamma"),
            (QConfig { alpha: 0.0, ..QConfig::default() }, "alpha"),
            (QConfig { alpha: f64::NAN, ..QConfig::default() }, "alpha"),
        ] {
            let e = QLearner::new(Cycle { decisions: 2 }, config).err().unwrap().to_string();
            assert!(e.contains(name), "{e}");
        }
        let bad = WindowConfig { episodes: 0, ..WindowConfig::default() };
        assert!(
            evaluate_windows(
                &Cycle { decisions: 2 },
                &Greedy { table: &QTable::zeros(2, 2).unwrap(), ties: Ties::Random },
                &bad,
                0
            )
            .is_err()
        );
    }

    #[test]
    fn table_rows_are_cache_line_aligned() {
        let table = QTable::zeros(1000, 16).unwrap();
        assert_eq!(table.values().as_ptr() as usize % 64, 0);
        assert_eq!(table.values().len(), 16_000);
    }

    #[test]
    fn resume_from_a_checkpoint_continues_exactly() {
        let world = small_world();
        let config = QConfig { seed: 11, ..QConfig::default() };
        let mut straight = QLearner::new(world.clone(), config.clone()).unwrap();
        straight.run(2000);
        let mut first = QLearner::new(world.clone(), config).unwrap();
        first.run(1000);
        let path = temp("resume.qtable");
        first.save(&path).unwrap();
        drop(first);
        let mut resumed = QLearner::load(&path, world.clone()).unwrap();
        assert_eq!(resumed.updates(), 1000);
        resumed.run(1000);
        assert_eq!(resumed.updates(), straight.updates());
        assert!(straight.table() == resumed.table(), "the tables differ");
        assert_eq!(straight.current(), resumed.current());
        assert_eq!(straight.reward_total(), resumed.reward_total());
        assert_eq!(straight.rng, resumed.rng);
        // And a chunked `train` is the same run as one `run`.
        let mut trained = QLearner::new(world, QConfig { seed: 11, ..QConfig::default() }).unwrap();
        let outcome = trained.train(2000, None, None, |_| Flow::Continue).unwrap();
        assert_eq!((outcome.updates, outcome.interrupted, outcome.checkpoints), (2000, false, 0));
        assert!(trained.table() == straight.table());
    }

    #[test]
    fn train_checkpoints_and_stops_when_asked() {
        let path = temp("train.qtable");
        let mut learner = QLearner::new(small_world(), QConfig::default()).unwrap();
        let mut calls = 0;
        let outcome = learner
            .train(3 * CHUNK, Some(&path), Some(1e9), |p| {
                calls += 1;
                assert!(p.updates <= p.until && p.epsilon < 1.0);
                if calls == 2 { Flow::Stop } else { Flow::Continue }
            })
            .unwrap();
        assert!(outcome.interrupted);
        assert_eq!((outcome.updates, outcome.checkpoints), (2 * CHUNK, 1));
        let header = read_header(&path).unwrap();
        assert_eq!(header["updates"], 2 * CHUNK);
        assert_eq!(header["format"], FORMAT);
        let loaded = load_tracking(&path).unwrap();
        assert!(loaded.table() == learner.table());
    }

    #[test]
    fn loading_checks_the_file() {
        let world = small_world();
        let learner = QLearner::new(world.clone(), QConfig::default()).unwrap();
        let path = temp("check.qtable");
        learner.save(&path).unwrap();
        let other = TargetTracking::with_params(TrackingParams { reward_radius: 2, ..world.params().clone() }).unwrap();
        assert!(matches!(QLearner::load(&path, other), Err(Error::Mismatch(_))));
        let mut bytes = std::fs::read(&path).unwrap();
        bytes.pop();
        let cut = temp("cut.qtable");
        std::fs::write(&cut, &bytes).unwrap();
        let e = QLearner::load(&cut, world.clone()).err().unwrap().to_string();
        assert!(e.contains("bytes (expected"), "{e}");
        let junk = temp("junk.qtable");
        std::fs::write(&junk, b"{\"format\": \"cehmm-policy\"}").unwrap();
        let e = QLearner::load(&junk, world).err().unwrap().to_string();
        assert!(e.contains("not a cehmm Q table"), "{e}");
    }

    #[test]
    fn windows_of_a_deterministic_world_by_hand() {
        // Cycle pays 1 for every step from state 1, and the windows start in state 0 (a) or
        // after an odd burn-in in state 1 (b): a window of 5 steps gets 2 or 3.
        let config = WindowConfig { window: 5, episodes: 7, chains: 3, burn_in: 1, windows_per_chain: 4 };
        let table = QTable::zeros(2, 2).unwrap();
        let report =
            evaluate_windows(&Cycle { decisions: 2 }, &Greedy { table: &table, ties: Ties::Random }, &config, 0)
                .unwrap();
        assert_eq!((report.from_start.episodes, report.from_start.min, report.from_start.max), (7, 2.0, 2.0));
        // From state 1: windows of steps 1..6 (3), 6..11 (2: states 0,1,0,1,0), 11..16 (3), 16..21 (2).
        assert_eq!(report.continuing.episodes, 12);
        assert_eq!((report.continuing.min, report.continuing.mean, report.continuing.max), (2.0, 2.5, 3.0));
        assert!((percent(report.continuing.mean, 5.0) - 50.0).abs() < 1e-12);
    }

    #[test]
    fn hhmm_windows_from_start_are_the_episodes_of_evaluate() {
        let world = small_world();
        let policy = Hhmm::random(16, 16, &[4, 2], &mut stream(1, Purpose::Init, 0, 0)).unwrap();
        let config =
            WindowConfig { window: world.horizon(), episodes: 300, chains: 2, burn_in: 500, windows_per_chain: 10 };
        let report = evaluate_windows(&world, &policy, &config, 9).unwrap();
        let rewards = crate::evaluate::rewards(&world, &policy, 300, 9).unwrap();
        assert_eq!(report.from_start, Evaluation::from_rewards(&rewards));
        assert_eq!(report.continuing.episodes, 20);
        assert!(report.continuing.max <= 100.0);
    }

    #[test]
    fn greedy_q_policy_windows_are_reproducible_and_thread_independent() {
        let mut learner = QLearner::new(small_world(), QConfig::default()).unwrap();
        learner.run(200_000);
        let config =
            WindowConfig { episodes: 200, chains: 4, burn_in: 1000, windows_per_chain: 50, ..WindowConfig::default() };
        let one = crate::optimize::thread_pool(Some(1))
            .unwrap()
            .install(|| evaluate_windows(learner.world(), &learner.greedy_policy(), &config, 5))
            .unwrap();
        let two = crate::optimize::thread_pool(Some(2))
            .unwrap()
            .install(|| evaluate_windows(learner.world(), &learner.greedy_policy(), &config, 5))
            .unwrap();
        assert_eq!(one, two);
        assert!(one.from_start.mean > 0.0, "a learnt policy meets the target sometimes on a 5×5 grid");
    }
}
