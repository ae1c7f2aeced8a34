//! The world interface: any episodic, partially observable world given only as a sampler
//! (model §1). Nothing here assumes a Markov or tabular world, nor an additive reward.

use crate::rng::EngineRng;

pub mod cassandra;
pub mod pomdp;
pub mod pomdpx;
pub mod registry;
pub mod session;
pub mod tracking;

/// An episodic world that the optimiser can sample.
///
/// One episode runs, for `t = 1..=horizon()`: `observe` (emits `y_t`), then the policy draws
/// `d_t`, then `step` (the world accounts for time `t` and moves to `t + 1`); it ends early
/// where `done` says so after a step. After the last step, `reward` gives the episode's value
/// `V`, which may depend on the whole episode: the state is free to carry whatever the reward
/// needs.
pub trait World: Sync {
    /// The hidden state `x_t` plus whatever the reward needs to remember.
    type State: Clone + Send;

    /// Number of observations `Y` (values of `y_t` are `0..Y`).
    fn n_observations(&self) -> usize;
    /// Number of decisions `D` (values of `d_t` are `0..D`).
    fn n_decisions(&self) -> usize;
    /// Number of steps `T` of one episode.
    fn horizon(&self) -> usize;
    /// Draws the initial state `x_1`.
    fn reset(&self, rng: &mut EngineRng) -> Self::State;
    /// Emits `y_t` from the current state (may draw noise).
    fn observe(&self, state: &Self::State, rng: &mut EngineRng) -> usize;
    /// Accounts for step `t` with decision `d_t`, then moves the state to `t + 1`.
    fn step(&self, state: &mut Self::State, decision: usize, rng: &mut EngineRng);
    /// The episode's reward `V`, read after the last step.
    fn reward(&self, state: &Self::State) -> f64;
    /// `Some(γ)` where `reward`, read after any step, is the sum of the steps' rewards so far
    /// discounted by `γ` (`r_1 + γ r_2 + ...`): then each step's reward is known, and a learner
    /// may keep it (model §10). `None` (the default) where the reward is of the whole episode.
    fn discount(&self) -> Option<f64> {
        None
    }
    /// Whether the episode has ended (read after each step): it stops there, before the horizon,
    /// and the optimiser counts only the steps it ran (model §1). By default an episode always
    /// runs to the horizon.
    fn done(&self, _state: &Self::State) -> bool {
        false
    }

    /// Names of the numbers `describe` writes for one state (for rollouts and plots).
    fn state_labels(&self) -> Vec<&'static str> {
        Vec::new()
    }
    /// Writes the state as numbers, in the order of `state_labels`.
    fn describe(&self, _state: &Self::State, _out: &mut Vec<i64>) {}
    /// The world's name and every parameter, as stored in policy files (model §6).
    fn to_json(&self) -> serde_json::Value;

    /// The world as a tabular POMDP (model §7), where it is one: what exact values, policy
    /// graphs and controller values on exact values need. `None` by default.
    fn tabular(&self) -> Option<&pomdp::PomdpWorld> {
        None
    }

    /// The best mean reward any policy can reach, where the world knows it exactly.
    fn exact_optimum(&self) -> crate::Result<f64> {
        Err(crate::Error::invalid("world", format!("{} (no exact optimum is known for this world)", self.to_json())))
    }
}
