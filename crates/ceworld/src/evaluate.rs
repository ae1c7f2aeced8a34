//! Evaluation of a policy on fresh episodes, and the record of one of them (a rollout).

use serde::Serialize;

pub use crate::episodes::check_fits;
use crate::episodes::run::{Rollout, run_with};
use crate::episodes::{Batch, Episodes, Streams};
use crate::error::{Error, Result};
use crate::policy::Hhmm;
use crate::rng::{Purpose, stream};
use crate::world::World;

/// Summary of the reward over `episodes` fresh episodes.
#[derive(Clone, Debug, PartialEq, Serialize, serde::Deserialize)]
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
pub fn rewards<E: Episodes + ?Sized>(world: &E, policy: &Hhmm, episodes: usize, seed: u64) -> Result<Vec<f64>> {
    check_episodes(episodes)?;
    rewards_of(world, policy, 0..episodes, seed)
}

/// `episodes` is a number of evaluation episodes the engine takes: `1..=MAX_EPISODES`.
pub fn check_episodes(episodes: usize) -> Result<()> {
    if episodes == 0 || episodes > MAX_EPISODES {
        return Err(Error::invalid("episodes", format!("{episodes} (expected 1..={MAX_EPISODES})")));
    }
    Ok(())
}

/// Rewards of the evaluation episodes `range` (streams `(seed, Evaluate, 0, k)`), in order: a
/// slice of [`rewards`], so that a long evaluation can be cut into slices with the same result.
pub fn rewards_of<E: Episodes + ?Sized>(
    world: &E,
    policy: &Hhmm,
    range: std::ops::Range<usize>,
    seed: u64,
) -> Result<Vec<f64>> {
    check_fits(world, policy)?;
    episode_rewards(world, policy, range, seed, Purpose::Evaluate)
}

/// Rewards of the episodes of streams `(seed, purpose, 0, k)`, `k` in `range`, in order.
fn episode_rewards<E: Episodes + ?Sized>(
    world: &E,
    policy: &Hhmm,
    range: std::ops::Range<usize>,
    seed: u64,
    purpose: Purpose,
) -> Result<Vec<f64>> {
    let mut values = vec![0.0; range.len()];
    let streams = Streams { seed, purpose, iteration: 0 };
    world.run(policy, streams, range.start, Batch { values: &mut values, records: None })?;
    Ok(values)
}

/// Mean reward over `episodes` episodes of the `Select` streams: a score for choosing between
/// policies that leaves the `Evaluate` episodes fresh for reporting the chosen one.
pub fn selection_mean<E: Episodes + ?Sized>(world: &E, policy: &Hhmm, episodes: usize, seed: u64) -> Result<f64> {
    check_fits(world, policy)?;
    // Summed in episode order, so the score does not depend on the thread count.
    let total: f64 = episode_rewards(world, policy, 0..episodes, seed, Purpose::Select)?.iter().sum();
    Ok(total / episodes as f64)
}

/// Mean, standard error, extremes and quantiles of the reward over fresh episodes.
pub fn evaluate<E: Episodes + ?Sized>(world: &E, policy: &Hhmm, episodes: usize, seed: u64) -> Result<Evaluation> {
    Ok(Evaluation::from_rewards(&rewards(world, policy, episodes, seed)?))
}

/// Episode `episode` of [`evaluate`] with the same `seed` (stream `(seed, Evaluate, 0, episode)`),
/// recorded step by step.
pub fn rollout<W: World>(world: &W, policy: &Hhmm, seed: u64, episode: u64) -> Result<Rollout> {
    check_fits(world, policy)?;
    let mut rng = stream(seed, Purpose::Evaluate, 0, episode);
    let (mut x, mut y, mut d, mut memory) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    let reward = run_with(world, policy, &mut rng, |_, yt, dt, m, state| {
        world.describe(state, &mut x);
        y.push(yt as i64);
        d.push(dt as i64);
        memory.extend(m.iter().map(|&v| i64::from(v)));
    });
    Ok(Rollout { x_labels: world.state_labels(), x, y, d, memory, levels: policy.levels().len(), reward })
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

    #[test]
    fn slices_of_an_evaluation_are_its_episodes() {
        let world = crate::TargetTracking::new(3).unwrap();
        let policy = crate::random_policy(&world, &[4], 2).unwrap();
        let all = rewards(&world, &policy, 10, 5).unwrap();
        let mut parts = rewards_of(&world, &policy, 0..4, 5).unwrap();
        parts.extend(rewards_of(&world, &policy, 4..10, 5).unwrap());
        assert_eq!(parts, all);
        assert!(check_episodes(0).is_err() && check_episodes(MAX_EPISODES + 1).is_err() && check_episodes(1).is_ok());
    }

    #[test]
    fn a_rollout_is_the_evaluated_episode_recorded() {
        let world = crate::TargetTracking::new(3).unwrap();
        let policy = crate::random_policy(&world, &[4, 2], 7).unwrap();
        let all = rewards(&world, &policy, 5, 11).unwrap();
        for (k, &reward) in all.iter().enumerate() {
            let r = rollout(&world, &policy, 11, k as u64).unwrap();
            assert_eq!(r.reward, reward);
            assert_eq!((r.len(), r.levels, r.x_labels.len()), (world.horizon(), 2, 8));
            assert_eq!((r.x.len(), r.memory.len(), r.d.len()), (8 * r.len(), 2 * r.len(), r.len()));
            assert!(r.y.iter().all(|&y| (0..16).contains(&y)) && r.d.iter().all(|&d| (0..16).contains(&d)));
            assert!(r.memory.chunks(2).all(|m| m[0] < 4 && m[1] < 2));
            // The first row is the start state: both mobiles on their start cells (model §4).
            let p = world.params();
            let h = i64::from(p.start_heading);
            let start = [p.start_b[0].into(), p.start_b[1].into(), h, p.start_c[0].into(), p.start_c[1].into(), h];
            assert_eq!(&r.x[..6], &start[..]);
        }
        let other = crate::TargetTracking::new(2).unwrap();
        assert!(matches!(rollout(&other, &policy, 0, 0), Err(Error::Mismatch(_))));
    }
}
