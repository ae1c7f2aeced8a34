//! Evaluation of a policy on fresh episodes.

use rayon::prelude::*;
use serde::Serialize;

use crate::ce::episode::run_with;
use crate::error::{Error, Result};
use crate::policy::Hhmm;
use crate::rng::{Purpose, stream};
use crate::world::World;

/// Summary of the reward over `episodes` fresh episodes.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Evaluation {
    /// Number of episodes.
    pub episodes: usize,
    /// Mean reward.
    pub mean: f64,
    /// Standard error of the mean (sample std / √M).
    pub std_error: f64,
    /// Sample standard deviation.
    pub std: f64,
    /// Smallest reward.
    pub min: f64,
    /// Largest reward.
    pub max: f64,
    /// `(q, value)` for q = 0.05, 0.25, 0.5, 0.75, 0.95 (nearest-rank).
    pub quantiles: Vec<(f64, f64)>,
}

impl Evaluation {
    /// Summarises the rewards (in any order).
    pub fn from_rewards(rewards: &[f64]) -> Evaluation {
        let n = rewards.len();
        let mean = rewards.iter().sum::<f64>() / n as f64;
        let var = if n > 1 { rewards.iter().map(|r| (r - mean).powi(2)).sum::<f64>() / (n - 1) as f64 } else { 0.0 };
        let mut sorted = rewards.to_vec();
        sorted.sort_by(f64::total_cmp);
        let quantiles = [0.05, 0.25, 0.5, 0.75, 0.95]
            .into_iter()
            .map(|q| (q, sorted[((q * n as f64).ceil() as usize).clamp(1, n) - 1]))
            .collect();
        Evaluation {
            episodes: n,
            mean,
            std_error: (var / n as f64).sqrt(),
            std: var.sqrt(),
            min: sorted[0],
            max: sorted[n - 1],
            quantiles,
        }
    }
}

/// Largest number of episodes of one evaluation (their rewards are kept for the quantiles).
pub const MAX_EPISODES: usize = 100_000_000;

/// Rewards of `episodes` fresh episodes (streams `(seed, Evaluate, 0, k)`), in episode order.
pub fn rewards<W: World>(world: &W, policy: &Hhmm, episodes: usize, seed: u64) -> Result<Vec<f64>> {
    check_fits(world, policy)?;
    if episodes == 0 || episodes > MAX_EPISODES {
        return Err(Error::invalid("episodes", format!("{episodes} (expected 1..={MAX_EPISODES})")));
    }
    Ok(episode_rewards(world, policy, episodes, seed, Purpose::Evaluate))
}

/// Rewards of the episodes of streams `(seed, purpose, 0, k)`, `k < episodes`, in order.
fn episode_rewards<W: World>(world: &W, policy: &Hhmm, episodes: usize, seed: u64, purpose: Purpose) -> Vec<f64> {
    (0..episodes)
        .into_par_iter()
        .map(|k| {
            let mut rng = stream(seed, purpose, 0, k as u64);
            run_with(world, policy, &mut rng, |_, _, _, _, _| {})
        })
        .collect()
}

/// Mean reward over `episodes` episodes of the `Select` streams: a score for choosing between
/// policies that leaves the `Evaluate` episodes fresh for reporting the chosen one.
pub fn selection_mean<W: World>(world: &W, policy: &Hhmm, episodes: usize, seed: u64) -> Result<f64> {
    check_fits(world, policy)?;
    // Summed in episode order, so the score does not depend on the thread count.
    let total: f64 = episode_rewards(world, policy, episodes, seed, Purpose::Select).iter().sum();
    Ok(total / episodes as f64)
}

/// Mean, standard error, extremes and quantiles of the reward over fresh episodes.
pub fn evaluate<W: World>(world: &W, policy: &Hhmm, episodes: usize, seed: u64) -> Result<Evaluation> {
    Ok(Evaluation::from_rewards(&rewards(world, policy, episodes, seed)?))
}

/// Checks that the policy's observation and decision counts are the world's.
pub fn check_fits<W: World>(world: &W, policy: &Hhmm) -> Result<()> {
    let l = policy.layout();
    if l.n_obs != world.n_observations() || l.n_actions != world.n_decisions() {
        return Err(Error::Mismatch(format!(
            "the policy has {} observations and {} decisions, the world {} and {}",
            l.n_obs,
            l.n_actions,
            world.n_observations(),
            world.n_decisions()
        )));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn summary_of_known_rewards() {
        let e = Evaluation::from_rewards(&[1.0, 2.0, 3.0, 4.0]);
        assert_eq!(e.mean, 2.5);
        assert_eq!((e.min, e.max), (1.0, 4.0));
        assert!((e.std - (5.0f64 / 3.0).sqrt()).abs() < 1e-12);
        assert!((e.std_error - e.std / 2.0).abs() < 1e-12);
        assert_eq!(e.quantiles[2], (0.5, 2.0));
    }
}
