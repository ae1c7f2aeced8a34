//! Rubinstein's cross-entropy method over HHMM policies (model §3).

use std::time::Instant;

use rayon::prelude::*;
use serde::Serialize;

use crate::ce::counting::count_episode;
use crate::ce::episode::run_recorded;
pub use crate::ce::limits::MAX_RECORD_BYTES;
use crate::ce::limits::{FB_BLOCK, RunSize, check_iteration_size, check_run_memory};
use crate::control::{Flow, check_threads, thread_pool};
use crate::error::{Error, Result};
use crate::evaluate::{Evaluation, MAX_EPISODES, check_fits, evaluate, selection_mean};
use crate::policy::Hhmm;
use crate::rng::{Purpose, stream, stream_key};
use crate::world::World;

/// The settings of one optimisation; `Default` gives the paper's (N = 1000, ρ = 0.5, α = 1,
/// weak criterion).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct CeConfig {
    /// Episodes drawn per iteration, `N`.
    pub samples: usize,
    /// Selective rate ρ in (0, 1): the best `ceil(ρN)` episodes are kept.
    pub rho: f64,
    /// Smoothing α in (0, 1]: `h := α·new + (1 − α)·h`; 1 is the paper's basic CE.
    pub smoothing: f64,
    /// The smoothing of the decision table `h0` alone, in (0, 1] (`None`: `smoothing`). A
    /// smaller value lets the memory tables take shape before the decisions settle: on tabular
    /// worlds whose optimum needs memory, the decisions otherwise lock onto the best memoryless
    /// policy within a few iterations (model §3).
    pub decision_smoothing: Option<f64>,
    /// Stop after this many consecutive unsuccessful iterations (weak 100, strong 500).
    pub patience: usize,
    /// Stop after this many iterations.
    pub max_iterations: Option<usize>,
    /// Stop after this many seconds (checked between iterations).
    pub time_limit: Option<f64>,
    /// Stop as soon as an iteration's mean reward reaches this value.
    pub target: Option<f64>,
    /// Seed of every random stream.
    pub seed: u64,
    /// Worker threads (`None`: one per core). Results do not depend on it.
    pub threads: Option<usize>,
    /// Fresh episodes used to evaluate the returned policy.
    pub eval_episodes: usize,
    /// How the elite's memory is counted: as sampled (the paper) or re-inferred.
    pub memory_update: MemoryUpdate,
    /// Independent runs (the first with `seed`, the others with seeds derived from it); the one
    /// whose policy scores best on `eval_episodes` selection episodes is returned, evaluated on
    /// other, fresh episodes. The time limit is shared by all the runs.
    pub restarts: usize,
}

/// How the CE update counts the memory of the elite episodes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum MemoryUpdate {
    /// Count the memory states that were sampled (model §3, the paper).
    #[default]
    Sampled,
    /// Count their posterior expectation given the episode's observations and decisions
    /// (forward–backward, one EM step on the elite); levels `Λ <= 2` only.
    ForwardBackward,
}

impl MemoryUpdate {
    /// Every kind.
    pub const ALL: [MemoryUpdate; 2] = [MemoryUpdate::Sampled, MemoryUpdate::ForwardBackward];

    /// `"sampled"` or `"forward-backward"`.
    pub const fn as_str(self) -> &'static str {
        match self {
            MemoryUpdate::Sampled => "sampled",
            MemoryUpdate::ForwardBackward => "forward-backward",
        }
    }
}

impl std::str::FromStr for MemoryUpdate {
    type Err = Error;
    fn from_str(s: &str) -> Result<Self> {
        match s {
            "sampled" => Ok(MemoryUpdate::Sampled),
            "forward-backward" => Ok(MemoryUpdate::ForwardBackward),
            other => Err(Error::invalid(
                "memory_update",
                format!("{other:?} (expected \"sampled\" or \"forward-backward\")"),
            )),
        }
    }
}

impl Default for CeConfig {
    fn default() -> Self {
        CeConfig {
            samples: 1000,
            rho: 0.5,
            smoothing: 1.0,
            decision_smoothing: None,
            patience: 100,
            max_iterations: None,
            time_limit: None,
            target: None,
            seed: 0,
            threads: None,
            eval_episodes: 10_000,
            memory_update: MemoryUpdate::Sampled,
            restarts: 1,
        }
    }
}

/// The elite's counts: integers when the memory is counted as sampled, reals when re-inferred.
enum Counts {
    Integer(Vec<u32>),
    Real(Vec<f64>),
}

/// The memory sizes used when none are given: `[16, 16]`, an input/output HMM of the paper's
/// table.
pub const DEFAULT_LEVELS: [usize; 2] = [16, 16];

/// The paper's weak convergence criterion: 100 unsuccessful iterations in a row.
pub const WEAK_PATIENCE: usize = 100;
/// The paper's strong convergence criterion: 500 unsuccessful iterations in a row.
pub const STRONG_PATIENCE: usize = 500;

impl CeConfig {
    /// Number of elite episodes, `ceil(ρN)`.
    pub fn elite_count(&self) -> usize {
        ((self.rho * self.samples as f64).ceil() as usize).clamp(1, self.samples)
    }

    /// Checks every setting, naming the bad one.
    pub fn validate(&self) -> Result<()> {
        if self.samples == 0 {
            return Err(Error::invalid("samples", "0 (expected at least 1 episode per iteration)"));
        }
        if !(self.rho > 0.0 && self.rho < 1.0) {
            return Err(Error::invalid("rho", format!("{} (expected 0 < rho < 1)", self.rho)));
        }
        if !(self.smoothing > 0.0 && self.smoothing <= 1.0) {
            return Err(Error::invalid("smoothing", format!("{} (expected 0 < smoothing <= 1)", self.smoothing)));
        }
        if let Some(d) = self.decision_smoothing
            && !(d > 0.0 && d <= 1.0)
        {
            return Err(Error::invalid("decision_smoothing", format!("{d} (expected 0 < decision_smoothing <= 1)")));
        }
        if self.patience == 0 {
            return Err(Error::invalid("patience", "0 (expected at least 1 iteration)"));
        }
        if self.max_iterations == Some(0) {
            return Err(Error::invalid("max_iterations", "0 (expected at least 1, or none)"));
        }
        if let Some(t) = self.time_limit {
            if t.is_nan() || t <= 0.0 {
                return Err(Error::invalid("time_limit", format!("{t} (expected a positive number of seconds)")));
            }
        }
        if let Some(t) = self.target {
            if t.is_nan() {
                return Err(Error::invalid("target", "NaN (expected a reward)"));
            }
        }
        if let Some(n) = self.threads {
            check_threads(n)?;
        }
        if self.restarts == 0 {
            return Err(Error::invalid("restarts", "0 (expected at least 1 run)"));
        }
        if self.eval_episodes == 0 || self.eval_episodes > MAX_EPISODES {
            return Err(Error::invalid(
                "eval_episodes",
                format!("{} (expected 1..={MAX_EPISODES})", self.eval_episodes),
            ));
        }
        Ok(())
    }
}

/// One iteration's statistics.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct IterationRecord {
    /// Iteration number, from 0.
    pub iteration: usize,
    /// Mean reward of the N episodes.
    pub mean: f64,
    /// Best reward of the N episodes.
    pub best: f64,
    /// Smallest reward kept in the elite.
    pub elite_threshold: f64,
    /// Mean reward of the elite.
    pub elite_mean: f64,
    /// Seconds since the optimisation started, at the end of the iteration.
    pub seconds: f64,
    /// Whether the mean beat every earlier iteration's.
    pub successful: bool,
}

/// Why an optimisation stopped.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum StopReason {
    /// `patience` unsuccessful iterations in a row (converged).
    Patience,
    /// `max_iterations` reached.
    MaxIterations,
    /// `time_limit` reached.
    TimeLimit,
    /// An iteration's mean reached `target`.
    Target,
    /// The caller asked to stop (Ctrl-C).
    Interrupted,
}

impl StopReason {
    /// The snake-case name (`"patience"`, `"interrupted"`, ...).
    pub fn as_str(self) -> &'static str {
        match self {
            StopReason::Patience => "patience",
            StopReason::MaxIterations => "max_iterations",
            StopReason::TimeLimit => "time_limit",
            StopReason::Target => "target",
            StopReason::Interrupted => "interrupted",
        }
    }
}

/// The outcome of an optimisation.
#[derive(Clone, Debug)]
pub struct CeResult {
    /// The policy that drew the best iteration (highest mean reward).
    pub policy: Hhmm,
    /// The policy after the last update.
    pub last_policy: Hhmm,
    /// Index of the best iteration.
    pub best_iteration: usize,
    /// Per-iteration statistics.
    pub history: Vec<IterationRecord>,
    /// Why it stopped.
    pub stop: StopReason,
    /// `policy` evaluated on fresh episodes (an unbiased estimate, unlike the best mean).
    pub evaluation: Evaluation,
    /// Wall seconds, evaluation included (of every restart).
    pub seconds: f64,
    /// Which restart this is (0 for the run with the given seed).
    pub restart: usize,
    /// With `restarts > 1`: every run's score on the selection episodes, in run order (the
    /// returned run is the first with the highest); empty for a single run.
    pub restart_scores: Vec<f64>,
}

impl CeResult {
    /// Whether the caller stopped it early.
    pub fn interrupted(&self) -> bool {
        self.stop == StopReason::Interrupted
    }
}

/// Runs the cross-entropy method from `initial` until a stopping rule holds, calling
/// `observer` after every iteration (on the calling thread; iterations count from 0 again at
/// each restart).
pub fn optimize<W: World>(
    world: &W,
    initial: Hhmm,
    config: &CeConfig,
    mut observer: impl FnMut(&IterationRecord) -> Flow,
) -> Result<CeResult> {
    config.validate()?;
    if config.restarts == 1 {
        return optimize_once(world, initial, config, &mut observer);
    }
    let started = Instant::now();
    let pool = thread_pool(config.threads)?;
    let mut best: Option<(f64, CeResult)> = None;
    let mut scores = Vec::with_capacity(config.restarts);
    let mut interrupted = false;
    for restart in 0..config.restarts {
        let mut run = CeConfig { restarts: 1, ..config.clone() };
        if restart > 0 {
            run.seed = stream_key(config.seed, Purpose::Restart, restart as u64, 0);
        }
        if let Some(limit) = config.time_limit {
            let left = limit - started.elapsed().as_secs_f64();
            if left <= 0.0 && restart > 0 {
                break;
            }
            // The first run always runs (at least one iteration), however little time is left.
            run.time_limit = Some(left.max(f64::MIN_POSITIVE));
        }
        let mut result = optimize_once(world, initial.clone(), &run, &mut observer)?;
        result.restart = restart;
        interrupted |= result.interrupted();
        let score = pool.install(|| selection_mean(world, &result.policy, config.eval_episodes, config.seed))?;
        scores.push(score);
        if best.as_ref().is_none_or(|(s, _)| score > *s) {
            best = Some((score, result));
        }
        if interrupted {
            break;
        }
    }
    let (_, mut result) = best.expect("the first run always completes");
    if interrupted {
        result.stop = StopReason::Interrupted;
    }
    result.seconds = started.elapsed().as_secs_f64();
    result.restart_scores = scores;
    Ok(result)
}

/// One run of [`optimize`] (its `restarts` is ignored).
fn optimize_once<W: World>(
    world: &W,
    initial: Hhmm,
    config: &CeConfig,
    observer: &mut dyn FnMut(&IterationRecord) -> Flow,
) -> Result<CeResult> {
    check_fits(world, &initial)?;
    if config.memory_update == MemoryUpdate::ForwardBackward {
        crate::ce::posterior::check_supported(initial.layout())?;
    }
    let pool = thread_pool(config.threads)?;
    let layout = initial.layout().clone();
    let horizon = world.horizon();
    let stride = horizon * layout.record_width();
    let (n, elite_count) = (config.samples, config.elite_count());
    check_iteration_size(n, elite_count, horizon, stride)?;
    let size = RunSize {
        samples: n,
        elite: elite_count,
        horizon,
        eval_episodes: config.eval_episodes,
        forward_backward: config.memory_update == MemoryUpdate::ForwardBackward,
        threads: pool.current_num_threads(),
    };
    check_run_memory(&layout, &size)?;
    let started = Instant::now();
    let mut policy = initial;
    let mut records = vec![0u16; n * stride];
    let mut rewards = vec![0.0f64; n];
    let mut keys = vec![0u64; n];
    let mut order: Vec<usize> = (0..n).collect();
    let mut history = Vec::new();
    let mut best: Option<(f64, usize, Hhmm)> = None;
    let mut unsuccessful = 0;
    let chunk = elite_count.div_ceil(pool.current_num_threads()).max(1);
    let stop = loop {
        let iteration = history.len();
        let seed = config.seed;
        pool.install(|| {
            records.par_chunks_mut(stride).zip(rewards.par_iter_mut()).enumerate().for_each(|(k, (record, reward))| {
                let mut rng = stream(seed, Purpose::Optimise, iteration as u64, k as u64);
                *reward = run_recorded(world, &policy, &mut rng, record);
            });
        });
        pool.install(|| {
            keys.par_iter_mut().enumerate().for_each(|(k, key)| {
                *key = stream_key(seed, Purpose::TieBreak, iteration as u64, k as u64);
            });
        });
        // A strict total order (reward, then random key, then index): the elite set is the
        // same whatever the algorithm, and selection is O(N) where a sort would be O(N log N).
        let better =
            |&a: &usize, &b: &usize| rewards[b].total_cmp(&rewards[a]).then(keys[a].cmp(&keys[b])).then(a.cmp(&b));
        order.iter_mut().enumerate().for_each(|(k, o)| *o = k);
        if elite_count < n {
            order.select_nth_unstable_by(elite_count - 1, better);
        }
        let elite = &order[..elite_count];
        let threshold = elite.iter().copied().max_by(better).expect("the elite is never empty");
        let record_of = |k: usize| &records[k * stride..(k + 1) * stride];
        let counts = pool.install(|| count_elite(&policy, elite, &record_of, config.memory_update, chunk));

        let mean = rewards.iter().sum::<f64>() / n as f64;
        let successful = best.as_ref().is_none_or(|(m, _, _)| mean > *m);
        if successful {
            best = Some((mean, iteration, policy.clone()));
            unsuccessful = 0;
        } else {
            unsuccessful += 1;
        }
        pool.install(|| match &counts {
            Counts::Integer(c) => policy.refit(c, config.smoothing, config.decision_smoothing),
            Counts::Real(c) => policy.refit(c, config.smoothing, config.decision_smoothing),
        });
        let record = IterationRecord {
            iteration,
            mean,
            best: rewards.iter().copied().fold(f64::NEG_INFINITY, f64::max),
            elite_threshold: rewards[threshold],
            elite_mean: elite.iter().map(|&k| rewards[k]).sum::<f64>() / elite_count as f64,
            seconds: started.elapsed().as_secs_f64(),
            successful,
        };
        history.push(record.clone());
        if observer(&record) == Flow::Stop {
            break StopReason::Interrupted;
        }
        if let Some(reason) = stopping_rule(config, &record, unsuccessful) {
            break reason;
        }
    };
    let (_, best_iteration, best_policy) = best.expect("at least one iteration ran");
    let evaluation = pool.install(|| evaluate(world, &best_policy, config.eval_episodes, config.seed))?;
    Ok(CeResult {
        policy: best_policy,
        last_policy: policy,
        best_iteration,
        history,
        stop,
        evaluation,
        seconds: started.elapsed().as_secs_f64(),
        restart: 0,
        restart_scores: Vec::new(),
    })
}

/// The stopping rule that holds after iteration `record` with `unsuccessful` unsuccessful
/// iterations in a row, if any (model §3), in the order target, patience, maximum, time.
fn stopping_rule(config: &CeConfig, record: &IterationRecord, unsuccessful: usize) -> Option<StopReason> {
    if config.target.is_some_and(|t| record.mean >= t) {
        Some(StopReason::Target)
    } else if unsuccessful >= config.patience {
        Some(StopReason::Patience)
    } else if config.max_iterations.is_some_and(|m| record.iteration + 1 >= m) {
        Some(StopReason::MaxIterations)
    } else if config.time_limit.is_some_and(|t| record.seconds >= t) {
        Some(StopReason::TimeLimit)
    } else {
        None
    }
}

/// The elite's counts, laid out as the policy's tables (model §3): integers summed per chunk of
/// `chunk` episodes, or, with the forward–backward update, reals summed per block of
/// [`FB_BLOCK`] episodes in block order, so that neither depends on the thread count. Runs on the
/// current rayon pool.
fn count_elite<'a>(
    policy: &Hhmm,
    elite: &[usize],
    record_of: &(dyn Fn(usize) -> &'a [u16] + Sync),
    memory_update: MemoryUpdate,
    chunk: usize,
) -> Counts {
    let layout = policy.layout();
    match memory_update {
        MemoryUpdate::Sampled => Counts::Integer(
            elite
                .par_chunks(chunk)
                .map(|episodes| {
                    let mut counts = vec![0u32; layout.len];
                    for &k in episodes {
                        count_episode(layout, record_of(k), &mut counts);
                    }
                    counts
                })
                .reduce_with(|mut a, b| {
                    a.iter_mut().zip(&b).for_each(|(x, y)| *x += y);
                    a
                })
                .expect("the elite is never empty"),
        ),
        MemoryUpdate::ForwardBackward => {
            let blocks: Vec<Vec<f64>> = elite
                .par_chunks(FB_BLOCK)
                .map_init(crate::ce::posterior::Scratch::default, |scratch, episodes| {
                    let mut counts = vec![0.0f64; layout.len];
                    for &k in episodes {
                        crate::ce::posterior::add_expected_counts(policy, record_of(k), &mut counts, scratch);
                    }
                    counts
                })
                .collect();
            let mut total = vec![0.0f64; layout.len];
            for block in &blocks {
                total.iter_mut().zip(block).for_each(|(x, y)| *x += y);
            }
            Counts::Real(total)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn memory_update_names_round_trip_and_unknown_names_are_refused() {
        for m in [MemoryUpdate::Sampled, MemoryUpdate::ForwardBackward] {
            assert_eq!(m.as_str().parse::<MemoryUpdate>().unwrap(), m);
        }
        assert_eq!(MemoryUpdate::ForwardBackward.as_str(), "forward-backward");
        let e = "viterbi".parse::<MemoryUpdate>().unwrap_err().to_string();
        assert!(e.contains("memory_update") && e.contains("viterbi"), "{e}");
    }

    #[test]
    fn settings_are_checked_at_their_bounds() {
        let ok = |c: CeConfig| c.validate().is_ok();
        let base = CeConfig::default();
        for t in [0.0, -1.0, f64::NAN] {
            assert!(!ok(CeConfig { time_limit: Some(t), ..base.clone() }), "time_limit {t}");
        }
        assert!(ok(CeConfig { time_limit: Some(1e-9), ..base.clone() }));
        assert!(!ok(CeConfig { eval_episodes: 0, ..base.clone() }));
        assert!(ok(CeConfig { eval_episodes: MAX_EPISODES, ..base.clone() }));
        assert!(!ok(CeConfig { eval_episodes: MAX_EPISODES + 1, ..base.clone() }));
        assert!(ok(CeConfig { threads: Some(crate::control::MAX_THREADS), ..base.clone() }));
        assert!(!ok(CeConfig { threads: Some(crate::control::MAX_THREADS + 1), ..base.clone() }));
        assert!(!ok(CeConfig { threads: Some(0), ..base.clone() }));
        for rho in [0.0, 1.0, f64::NAN] {
            assert!(!ok(CeConfig { rho, ..base.clone() }), "rho {rho}");
        }
        assert!(ok(CeConfig { rho: 0.999, ..base.clone() }));
        assert!(!ok(CeConfig { smoothing: 0.0, ..base.clone() }));
        assert!(!ok(CeConfig { decision_smoothing: Some(0.0), ..base.clone() }));
        assert!(!ok(CeConfig { decision_smoothing: Some(1.5), ..base.clone() }));
        assert!(!ok(CeConfig { decision_smoothing: Some(f64::NAN), ..base.clone() }));
        assert!(ok(CeConfig { decision_smoothing: Some(1.0), ..base.clone() }));
        assert!(ok(CeConfig { smoothing: 1.0, ..base.clone() }));
        assert!(!ok(CeConfig { samples: 0, ..base.clone() }));
        assert!(!ok(CeConfig { patience: 0, ..base.clone() }));
        assert!(!ok(CeConfig { max_iterations: Some(0), ..base.clone() }));
        assert!(!ok(CeConfig { restarts: 0, ..base.clone() }));
        assert!(!ok(CeConfig { target: Some(f64::NAN), ..base }));
    }

    #[test]
    fn iteration_size_limits_are_checked_at_their_bounds() {
        // The elite's counts: ceil(ρN)·T steps must fit in u32.
        let max = u32::MAX as usize;
        assert!(check_iteration_size(1, max, 1, 1).is_ok());
        assert!(check_iteration_size(1, max + 1, 1, 1).is_err());
        assert!(check_iteration_size(1, max / 2 + 1, 2, 1).is_err());
        // The records: N · stride numbers of 2 bytes, at most MAX_RECORD_BYTES (2^33).
        assert!(check_iteration_size(1 << 22, 1, 1, 1 << 10).is_ok());
        assert!(check_iteration_size((1 << 22) + 1, 1, 1, 1 << 10).is_err());
        let e = check_iteration_size(1 << 24, 1, 1, 1 << 10).unwrap_err().to_string();
        assert!(e.contains("32768 MiB (at most 8192 MiB)"), "{e}");
    }

    #[test]
    fn stop_reasons_have_snake_case_names() {
        let names: Vec<_> = [
            StopReason::Patience,
            StopReason::MaxIterations,
            StopReason::TimeLimit,
            StopReason::Target,
            StopReason::Interrupted,
        ]
        .iter()
        .map(|s| s.as_str())
        .collect();
        assert_eq!(names, ["patience", "max_iterations", "time_limit", "target", "interrupted"]);
    }
}
