//! Evaluation of a policy on fresh episodes, and the record of one of them (a rollout).

use std::time::Instant;

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

/// The mean of `values`, finite when they are: their plain sum over their count (so that no
/// result changes), or, where that sum overflows, the sum of the values scaled by the largest
/// magnitude (rewards of 1e308 have the mean 1e308, not infinity).
pub fn mean<I: Iterator<Item = f64> + Clone>(values: I) -> f64 {
    let (sum, n) = (values.clone().sum::<f64>(), values.clone().count());
    if sum.is_finite() || n == 0 {
        return sum / n as f64;
    }
    let scale = values.clone().fold(0.0, |m: f64, v| m.max(v.abs()));
    if !scale.is_finite() {
        return sum / n as f64;
    }
    values.map(|v| v / scale).sum::<f64>() / n as f64 * scale
}

/// The sample standard deviation of `rewards` about `mean` and the standard error of the mean,
/// scaled as [`mean`] is where the plain sum of squares overflows.
fn spread(rewards: &[f64], mean: f64) -> (f64, f64) {
    let n = rewards.len();
    if n < 2 {
        return (0.0, 0.0);
    }
    let var = rewards.iter().map(|r| (r - mean).powi(2)).sum::<f64>() / (n - 1) as f64;
    let scale = rewards.iter().fold(0.0, |m: f64, v| m.max((v - mean).abs()));
    if var.is_finite() || !scale.is_finite() || scale == 0.0 {
        return (var.sqrt(), (var / n as f64).sqrt());
    }
    let std = scale * (rewards.iter().map(|r| ((r - mean) / scale).powi(2)).sum::<f64>() / (n - 1) as f64).sqrt();
    (std, std / (n as f64).sqrt())
}

impl Evaluation {
    /// Summarises the rewards (in any order); without any (an evaluation cut before its first
    /// episode), every figure is NaN.
    pub fn from_rewards(rewards: &[f64]) -> Evaluation {
        let n = rewards.len();
        if n == 0 {
            let quantiles = [0.05, 0.25, 0.5, 0.75, 0.95].into_iter().map(|q| (q, f64::NAN)).collect();
            let nan = f64::NAN;
            return Evaluation { episodes: 0, mean: nan, std_error: nan, std: nan, min: nan, max: nan, quantiles };
        }
        let mut sorted = rewards.to_vec();
        sorted.sort_by(f64::total_cmp);
        // Equal rewards: their mean and spread exactly (a sum would leave rounding noise).
        let (mean, (std, std_error)) = if sorted[0] == sorted[n - 1] {
            (sorted[0], (0.0, 0.0))
        } else {
            let mean = mean(rewards.iter().copied());
            (mean, spread(rewards, mean))
        };
        let quantiles = [0.05, 0.25, 0.5, 0.75, 0.95]
            .into_iter()
            .map(|q| (q, sorted[((q * n as f64).ceil() as usize).clamp(1, n) - 1]))
            .collect();
        Evaluation { episodes: n, mean, std_error, std, min: sorted[0], max: sorted[n - 1], quantiles }
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

/// Rewards of the episodes `0..episodes` of streams `(seed, purpose, 0, k)` that finish before
/// the world's interrupt cuts them (all of them where nothing does), before `deadline` and
/// before a budget in steps is `spent`, in order, run in slices of [`Episodes::slice`] episodes
/// (of at most [`CLOSING_SLICE`] under a deadline or a budget, the first always run): what an
/// interrupted run can still tell of what it kept, and what a run's time limit leaves time for.
/// An abort is an error.
pub(crate) fn rewards_until_cut<E: Episodes + ?Sized>(
    world: &E,
    policy: &Hhmm,
    episodes: usize,
    seed: u64,
    purpose: Purpose,
    deadline: Option<Instant>,
    spent: Option<&(dyn Fn() -> bool + Sync)>,
) -> Result<Vec<f64>> {
    let cut = deadline.is_some() || spent.is_some();
    let slice = if cut { world.slice().min(CLOSING_SLICE) } else { world.slice() }.max(1);
    let mut rewards = Vec::with_capacity(episodes);
    for start in (0..episodes).step_by(slice) {
        if start > 0 && (deadline.is_some_and(|d| Instant::now() >= d) || spent.is_some_and(|s| s())) {
            break;
        }
        match episode_rewards(world, policy, start..episodes.min(start + slice), seed, purpose) {
            Ok(part) => rewards.extend(part),
            Err(Error::Interrupted) if !world.interrupt().is_some_and(crate::control::Interrupt::aborted) => break,
            Err(e) => return Err(e),
        }
    }
    Ok(rewards)
}

/// The episodes of a closing evaluation run between two looks at its deadline.
pub const CLOSING_SLICE: usize = 256;

/// The most of a time limit that a run keeps for its closing evaluations: its iterations have
/// at least the rest.
pub const MOST_CLOSING_SHARE: f64 = 0.5;

/// The seconds a run with a time limit of `limit` seconds keeps for closing evaluations of
/// `episodes` episodes in all, at `per_episode` seconds an episode (as its iterations ran them),
/// so that the evaluations fit inside the limit: at most [`MOST_CLOSING_SHARE`] of it (an
/// evaluation that needs more is cut at the limit, and has fewer episodes); 0 without a limit.
pub fn closing_reserve(limit: Option<f64>, per_episode: f64, episodes: usize) -> f64 {
    limit.map_or(0.0, |t| (per_episode.max(0.0) * episodes as f64).min(t * MOST_CLOSING_SHARE))
}

/// The instant `seconds` from now (`None`: none; now where none are left).
fn deadline_in(seconds: Option<f64>) -> Option<Instant> {
    seconds.map(|s| {
        let now = Instant::now();
        if s.is_finite() && s > 0.0 { now + std::time::Duration::from_secs_f64(s.min(1e9)) } else { now }
    })
}

/// The rewards with which a run closes (its final evaluation, the score that chooses between
/// restarts): of the episodes `0..episodes` of streams `(seed, purpose, 0, k)`, in slices, those
/// that finish before the world's interrupt cuts them (all of them where nothing does) and
/// within the `left` seconds of a time limit and before a budget in steps is `spent` (fewer
/// episodes, the run not interrupted), and whether the interrupt cut them. An `interrupted` run
/// closes within the interrupt's grace; a run that ended by its own rules and is interrupted
/// while it closes keeps the slices done (Ctrl-C during the final evaluation gives the result
/// with a shorter evaluation). An abort is an error.
pub(crate) fn closing_rewards<E: Episodes + ?Sized>(
    world: &E,
    policy: &Hhmm,
    episodes: usize,
    seed: u64,
    purpose: Purpose,
    left: Option<f64>,
    spent: Option<&(dyn Fn() -> bool + Sync)>,
) -> Result<(Vec<f64>, bool)> {
    check_fits(world, policy)?;
    let rewards = rewards_until_cut(world, policy, episodes, seed, purpose, deadline_in(left), spent)?;
    let cut = rewards.len() < episodes && world.interrupt().is_some_and(crate::control::Interrupt::stopping);
    Ok((rewards, cut))
}

/// A run's final evaluation: [`closing_rewards`] on the `Evaluate` streams, within the `left`
/// seconds of its time limit, and whether an interrupt cut it (the result stands, with the
/// episodes evaluated so far). What an `interrupted` run kept is evaluated for at most the
/// interrupt's grace.
pub(crate) fn final_evaluation<E: Episodes + ?Sized>(
    world: &E,
    policy: &Hhmm,
    episodes: usize,
    seed: u64,
    interrupted: bool,
    left: Option<f64>,
) -> Result<(Evaluation, bool)> {
    world.interrupt().filter(|_| interrupted).inspect(|i| i.grace(crate::control::GRACE));
    let (rewards, cut) = closing_rewards(world, policy, episodes, seed, Purpose::Evaluate, left, None)?;
    Ok((Evaluation::from_rewards(&rewards), cut))
}

/// Mean reward over `episodes` episodes of the `Select` streams: a score for choosing between
/// policies that leaves the `Evaluate` episodes fresh for reporting the chosen one.
pub fn selection_mean<E: Episodes + ?Sized>(world: &E, policy: &Hhmm, episodes: usize, seed: u64) -> Result<f64> {
    check_fits(world, policy)?;
    // Summed in episode order, so the score does not depend on the thread count.
    Ok(mean(episode_rewards(world, policy, 0..episodes, seed, Purpose::Select)?.iter().copied()))
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
    fn finite_rewards_have_a_finite_mean_and_spread() {
        let e = Evaluation::from_rewards(&[1e308; 10]);
        assert_eq!((e.mean, e.std, e.std_error), (1e308, 0.0, 0.0));
        // 10,000 rewards of 0.1: a sum would give a mean of 0.09999999999999…, a spread of 1e-17.
        let e = Evaluation::from_rewards(&vec![0.1; 10_000]);
        assert_eq!((e.mean, e.std, e.std_error), (0.1, 0.0, 0.0));
        let e = Evaluation::from_rewards(&[1.5e308, 0.5e308, 1.5e308, 0.5e308]);
        assert!((e.mean / 1e308 - 1.0).abs() < 1e-12, "{}", e.mean);
        assert!(e.std.is_finite() && (e.std / (0.5e308 * (4.0f64 / 3.0).sqrt()) - 1.0).abs() < 1e-12, "{}", e.std);
        assert_eq!(mean([f64::MAX, -f64::MAX].into_iter()), 0.0);
        // Ordinary values keep the plain sum over the count, bit for bit.
        let v = [0.1, 0.2, 0.7, 1.3];
        assert_eq!(mean(v.iter().copied()).to_bits(), (v.iter().sum::<f64>() / 4.0).to_bits());
        assert!(mean([f64::INFINITY, 1.0].into_iter()).is_infinite());
    }

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
