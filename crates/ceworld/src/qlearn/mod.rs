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

use crate::error::Error;
use crate::error::Result;
use crate::rng::EngineRng;
use crate::settings::{Setting, Settings};
use crate::world::World;
use serde::{Deserialize, Serialize};

mod any;
mod checkpoint;
mod learner;
mod table;
mod tracking;
mod windows;

pub use crate::memory::{available_memory, check_memory};
pub use any::{AnyLearner, evaluate_policy_windows};
pub use checkpoint::read_header;
pub use learner::{QLearner, QProgress, RunStats, TrainOutcome};
pub use table::{QTable, table_bytes};
pub use windows::{Greedy, WindowConfig, WindowPolicy, WindowReport, evaluate_windows, percent};

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
/// Seconds between two checkpoints of a long run, unless told otherwise.
pub const CHECKPOINT_EVERY: f64 = 600.0;

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

/// `ε_t = min(1, 1/ln t)` for update `t` (counted from 1): 1 while `ln t ≤ 1`, i.e. `t ≤ 2`.
#[inline]
pub fn epsilon(t: u64) -> f64 {
    if t < 3 { 1.0 } else { 1.0 / (t as f64).ln() }
}

/// How a greedy action is chosen among actions of equal value.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
#[serde(rename_all = "snake_case")]
pub enum Ties {
    /// Uniformly at random among the maximal actions.
    #[default]
    Random,
    /// The lowest index (deterministic).
    Lowest,
}

impl Ties {
    /// Every rule.
    pub const ALL: [Ties; 2] = [Ties::Random, Ties::Lowest];

    /// `"random"` or `"lowest"`.
    pub const fn as_str(self) -> &'static str {
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

/// The learning settings; `Default` is the paper's (`γ = 0.99`, `α = 0.1`), random ties. The
/// one home of each setting: its doc is the CLI's help (`ceworld qlearn --help`), its name the
/// Python keyword ([`Settings::set`]) and the Q-table file's header key.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[cfg_attr(feature = "cli", derive(clap::Args))]
pub struct QConfig {
    /// Discount gamma in [0, 1).
    #[cfg_attr(feature = "cli", arg(long, default_value_t = GAMMA))]
    pub gamma: f64,
    /// Learning rate alpha in (0, 1].
    #[cfg_attr(feature = "cli", arg(long, default_value_t = ALPHA))]
    pub alpha: f64,
    /// Seed of the run's random stream.
    #[cfg_attr(feature = "cli", arg(long, default_value_t = 0))]
    pub seed: u64,
    /// How greedy ties are broken, in learning and in the evaluated greedy policy.
    #[cfg_attr(feature = "cli", arg(long, value_enum, default_value_t = Ties::Random))]
    pub ties: Ties,
}

impl Settings for QConfig {
    fn set(&mut self, s: &Setting<'_>) -> Result<()> {
        match s.name {
            "gamma" => self.gamma = s.real()?,
            "alpha" => self.alpha = s.real()?,
            "seed" => self.seed = s.seed()?,
            "ties" => self.ties = s.choice(Ties::parse)?,
            other => return Err(self.unknown(other)),
        }
        Ok(())
    }
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

#[cfg(test)]
pub(crate) mod tests;
