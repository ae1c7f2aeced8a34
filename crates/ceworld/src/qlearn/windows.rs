//! The paper's comparison of policies: 100-step windows of a continuing run, from the start
//! and after many cycles, for an HHMM or the greedy Q-policy alike.

use crate::error::Result;
use rand::Rng;
use rayon::prelude::*;
use serde::Serialize;

use super::ContinuingWorld;
use super::KnownState;
use super::QLearner;
use super::QTable;
use super::Ties;
use crate::episodes::check_fits;
use crate::error::Error;
use crate::evaluate::Evaluation;
use crate::policy::Hhmm;
use crate::rng::EngineRng;
use crate::rng::Purpose;
use crate::rng::stream;
use crate::settings::{Setting, Settings};
use crate::world::World;

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

/// How to cut runs into windows (the paper: 100 steps). The one home of each setting: its doc
/// is the CLI's help (`ceworld qlearn-eval --help`), its name the Python keyword
/// ([`Settings::set`]) and the report's key.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[cfg_attr(feature = "cli", derive(clap::Args))]
pub struct WindowConfig {
    /// Steps per window (the paper: 100).
    #[cfg_attr(feature = "cli", arg(long, default_value_t = WindowConfig::default().window))]
    pub window: usize,
    /// (a) Windows from the initial state: one per fresh start of the world.
    #[cfg_attr(feature = "cli", arg(long, default_value_t = WindowConfig::default().episodes))]
    pub episodes: usize,
    /// (b) Independent continuing runs, each from a fresh start.
    #[cfg_attr(feature = "cli", arg(long, default_value_t = WindowConfig::default().chains))]
    pub chains: usize,
    /// (b) Steps each continuing run makes before its first window ("after many cycles").
    #[cfg_attr(feature = "cli", arg(long, default_value_t = WindowConfig::default().burn_in))]
    pub burn_in: u64,
    /// (b) Consecutive windows per continuing run after the burn-in.
    #[cfg_attr(feature = "cli", arg(long, default_value_t = WindowConfig::default().windows_per_chain))]
    pub windows_per_chain: usize,
}

impl Default for WindowConfig {
    fn default() -> Self {
        WindowConfig { window: 100, episodes: 10_000, chains: 16, burn_in: 100_000, windows_per_chain: 10_000 }
    }
}

impl Settings for WindowConfig {
    fn set(&mut self, s: &Setting<'_>) -> Result<()> {
        match s.name {
            "window" => self.window = s.count()?,
            "episodes" => self.episodes = s.count()?,
            "chains" => self.chains = s.count()?,
            "burn_in" => self.burn_in = s.seed()?,
            "windows_per_chain" => self.windows_per_chain = s.count()?,
            other => return Err(self.unknown(other)),
        }
        Ok(())
    }
}

impl WindowConfig {
    /// Checks every setting, naming the bad one.
    pub fn validate(&self) -> Result<()> {
        let max = crate::evaluate::MAX_EPISODES;
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
/// `episodes` fresh starts (the target drawn as in the world's `reset`), start `k` on the
/// stream `(seed, Evaluate, 0, k)`, (b) consecutive windows of `chains` long runs after a
/// burn-in, run `k` on the stream `(seed, Evaluate, 1, k)`; in parallel on the current rayon
/// pool, reproducible from `seed` whatever the thread count.
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
