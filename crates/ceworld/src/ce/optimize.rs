//! Rubinstein's cross-entropy method over HHMM policies (model §3).

use std::time::Instant;

use rayon::prelude::*;

use crate::ce::budget::{CUT_EPISODES, Groups, Metered};
use crate::ce::checkpoint::{CeRun, FinishedRun, RunState};
use crate::ce::config::{CeConfig, MemoryUpdate};
use crate::ce::counting::count_episode;
use crate::ce::iterations::{Ended, Iterations, Watch, iterate_run};
pub use crate::ce::limits::MAX_RECORD_BYTES;
use crate::ce::limits::{FB_BLOCK, RunSize, check_iteration_size, check_run_memory};
use crate::ce::record::{CeResult, IterationRecord};
use crate::ce::resume::{Checkpointing, Saver};
use crate::ce::runs::{Runs, over_runs};
use crate::ce::stopping::{Observed, StopReason};
use crate::control::{Flow, Interrupt, thread_pool};
use crate::episodes::{Batch, Episodes, Remote, Streams};
use crate::error::{Error, Result};
use crate::evaluate::{check_fits, closing_rewards, final_evaluation};
use crate::policy::{Hhmm, Layout};
use crate::rng::{Purpose, restart_seed, stream_key};

/// The elite's counts: integers when the memory is counted as sampled, reals when re-inferred.
enum Counts {
    Integer(Vec<u32>),
    Real(Vec<f64>),
}

/// Runs the cross-entropy method from `initial` until a stopping rule holds, calling
/// `observer` after every iteration (on the calling thread; iterations count from 0 again at
/// each restart).
pub fn optimize<E: Episodes + ?Sized>(
    world: &E,
    initial: Hhmm,
    config: &CeConfig,
    observer: impl FnMut(&IterationRecord) -> Flow,
) -> Result<CeResult> {
    optimize_with(world, initial, config, None, observer)
}

/// [`optimize`], saving the whole state to `checkpointing.path` every `checkpointing.every`
/// seconds and whenever it stops, and, with `checkpointing.resume`, continuing from that file
/// when it exists: the result is then the one an uninterrupted run gives, bit for bit (the
/// seconds and a time limit aside). `initial` is used by the runs that have not started.
pub fn optimize_with<E: Episodes + ?Sized>(
    world: &E,
    initial: Hhmm,
    config: &CeConfig,
    checkpointing: Option<&Checkpointing>,
    mut observer: impl FnMut(&IterationRecord) -> Flow,
) -> Result<CeResult> {
    optimize_observed(world, initial, config, checkpointing, |seen| observer(seen.step))
}

/// [`optimize_with`], its observer shown the best policy so far on demand too ([`Observed`]).
/// An observer's [`Flow::Finish`] ends every restart: the result is the best of the runs so far,
/// stopped for [`StopReason::Callback`], and a resume continues the run it cut.
#[allow(clippy::needless_pass_by_value)] // taken like `optimize`'s
pub fn optimize_observed<E: Episodes + ?Sized>(
    world: &E,
    initial: Hhmm,
    config: &CeConfig,
    checkpointing: Option<&Checkpointing>,
    mut observer: impl FnMut(&Observed<'_, IterationRecord>) -> Flow,
) -> Result<CeResult> {
    config.validate()?;
    check_fits(world, &initial)?;
    // The initial policy's digest: a resumed run must start its later runs from the same one.
    let start = Some(digest(&initial));
    let mut saver = Saver::<CeRun>::new(world, config, checkpointing, start)?;
    if let Some(run) = &saver.state.run
        && run.policy.levels() != initial.levels()
    {
        return Err(Error::CheckpointMismatch(format!(
            "the checkpoint's policy has levels {:?}, not {:?} (resume with the same levels, or start afresh)",
            run.policy.levels(),
            initial.levels()
        )));
    }
    let pool = thread_pool(config.threads)?;
    // Before any copy of the tables: the run must fit in the memory this process may use.
    check_size(world, initial.layout(), config, pool.current_num_threads())?;
    // Learning's episodes, their steps counted on from the sessions before.
    let world = &Metered::new(world, saver.state.env_steps);
    let mut runs = CeRuns { world, initial: &initial, config, pool: &pool, observer: &mut observer };
    let chosen = over_runs(&mut runs, config.restarts, &mut saver)?;
    let (runs, best) = chosen.all(&saver.state.finished, |r| r.score);
    let scores = if config.restarts > 1 { runs.iter().map(|r| r.score).collect() } else { Vec::new() };
    let mut result = runs[best].result.clone();
    // Stopped by the caller, or by a budget before a later run: the search is, whichever run
    // is returned.
    let halted = chosen.open.as_ref().map(|r| r.result.stop).filter(|s| s.halted());
    if let Some(stop) = chosen.ended.or(halted) {
        result.stop = stop;
    }
    result.seconds = saver.seconds();
    result.restart_scores = scores;
    result.checkpoint_error = saver.failed.take();
    result.env_steps = world.steps();
    Ok(result)
}

/// The runs of episode CE, as the loop over runs drives them.
struct CeRuns<'a, 'w, E: ?Sized> {
    world: &'a Metered<'w, E>,
    initial: &'a Hhmm,
    config: &'a CeConfig,
    pool: &'a rayon::ThreadPool,
    observer: &'a mut dyn FnMut(&Observed<'_, IterationRecord>) -> Flow,
}

impl<E: Episodes + ?Sized> Runs for CeRuns<'_, '_, E> {
    type Kind = CeRun;

    fn run(&mut self, restart: usize, resume: Option<RunState>, saver: &mut Saver<'_, CeRun>) -> Result<FinishedRun> {
        let config = self.config;
        let mut run = CeConfig { restarts: 1, seed: restart_seed(config.seed, restart), ..config.clone() };
        if let Some(limit) = config.budget.time_limit {
            // A run's time limit is what was left when it started (its records count from there).
            let run_before = resume.as_ref().and_then(|r| r.history.last()).map_or(0.0, |r| r.seconds);
            let spent = if restart == 0 && resume.is_none() { saver.before } else { saver.seconds() - run_before };
            // The first run always runs (at least one iteration), however little time is left.
            run.budget.time_limit = Some((limit - spent).max(f64::MIN_POSITIVE));
        }
        // A run closes with its evaluation, and between restarts with its score too.
        let closings = if config.restarts > 1 { 2 } else { 1 };
        let initial = self.initial.clone();
        let mut result = optimize_once(self.world, initial, &run, closings, resume, self.observer, saver)?;
        result.restart = restart;
        if config.restarts == 1 {
            return Ok(FinishedRun { score: f64::NAN, result });
        }
        let (policy, left) = (&result.policy, config.budget.time_limit.map(|t| t - saver.seconds()));
        let (episodes, seed, world) = (config.eval_episodes, config.seed, self.world);
        // Learning's steps: under a budget, the score is cut where it is spent (the first slice
        // always runs), as the time limit cuts it.
        let spent = || config.budget.spent(world.steps());
        let budget = config.budget.max_env_steps.map(|_| &spent as &(dyn Fn() -> bool + Sync));
        let (scored, cut) =
            self.pool.install(|| closing_rewards(world, policy, episodes, seed, Purpose::Select, left, budget))?;
        if cut {
            // Interrupted while scored: the checkpoint holds the run, which a resume closes again.
            result.stop = StopReason::Interrupted;
        }
        Ok(FinishedRun { score: crate::evaluate::mean(scored.iter().copied()), result })
    }

    fn stop(run: &FinishedRun) -> StopReason {
        run.result.stop
    }

    fn spent(&self, saver: &Saver<'_, CeRun>) -> Option<StopReason> {
        self.config.budget.exhausted(saver.seconds(), self.world.steps())
    }

    fn aborted(&self) -> bool {
        self.world.interrupt().is_some_and(Interrupt::aborted)
    }

    fn steps(&self) -> u64 {
        self.world.steps()
    }
}

/// Refuses, before anything is allocated, a run whose iteration or memory would not fit.
fn check_size<E: Episodes + ?Sized>(world: &E, layout: &Layout, config: &CeConfig, threads: usize) -> Result<()> {
    let horizon = world.shape().horizon;
    let (n, elite_count) = (config.samples, config.elite_count());
    check_iteration_size(n, elite_count, horizon, horizon * layout.record_width())?;
    let size = RunSize {
        samples: n,
        elite: elite_count,
        horizon,
        eval_episodes: config.eval_episodes,
        forward_backward: config.memory_update == MemoryUpdate::ForwardBackward,
        threads,
    };
    check_run_memory(layout, &size)
}

/// The SHA-256 of a policy's sizes and table entries (their bits), in hex.
fn digest(policy: &Hhmm) -> String {
    use sha2::{Digest, Sha256};
    let layout = policy.layout();
    let mut h = Sha256::new();
    for size in [layout.n_obs, layout.n_actions].iter().chain(&layout.levels) {
        h.update((*size as u64).to_le_bytes());
    }
    for p in policy.probs() {
        h.update(p.to_bits().to_le_bytes());
    }
    crate::files::hex(&h.finalize())
}

/// One run of [`optimize_with`] (its `restarts` is ignored), from `initial` or from the saved
/// state `resume`, keeping of its time limit what `closings` evaluations of `eval_episodes`
/// take ([`closing_reserve`]): its iterations stop that much before it.
fn optimize_once<E: Episodes + ?Sized>(
    world: &Metered<'_, E>,
    initial: Hhmm,
    config: &CeConfig,
    closings: usize,
    resume: Option<RunState>,
    observer: &mut dyn FnMut(&Observed<'_, IterationRecord>) -> Flow,
    saver: &mut Saver<'_, CeRun>,
) -> Result<CeResult> {
    if config.memory_update == MemoryUpdate::ForwardBackward {
        crate::ce::posterior::check_supported(initial.layout())?;
    }
    let pool = thread_pool(config.threads)?;
    let (remote, started) = (remote_of(world, config)?, Instant::now());
    let run = resume.unwrap_or(RunState { policy: initial, history: Vec::new(), best: None, unsuccessful: 0 });
    // Seconds of this run in earlier sessions.
    let before = run.history.last().map_or(0.0, |r| r.seconds);
    let earlier = saver.state.finished.iter().map(|r| r.result.history.len()).sum();
    let (budget, interrupt) = (&config.budget, world.interrupt());
    let watch = Watch { run: saver.state.restart, earlier, budget, meter: world, interrupt, reserve: 0.0 };
    let mut it = CeIterations { world, config, pool: &pool, remote, buffers: None, before, started, closings, ran: 0 };
    let Ended { run, stop, .. } = iterate_run(&mut it, run, saver, observer, &watch)?;
    let RunState { policy, history, best, .. } = run;
    let (_, best_iteration, best_policy) = best.expect("a best policy after an iteration");
    // Inside the time limit: the closing evaluations share what is left of it.
    let left = config.budget.time_limit.map(|t| (t - before - started.elapsed().as_secs_f64()) / closings as f64);
    let (episodes, interrupted) = (config.eval_episodes, stop == StopReason::Interrupted);
    // The final evaluation's steps are counted apart.
    let evaluated = Metered::new(world.inner(), 0);
    let (evaluation, cut) =
        pool.install(|| final_evaluation(&evaluated, &best_policy, episodes, config.seed, interrupted, left))?;
    Ok(CeResult {
        policy: best_policy,
        last_policy: policy,
        best_iteration,
        history,
        stop: if cut { StopReason::Interrupted } else { stop },
        evaluation,
        seconds: before + started.elapsed().as_secs_f64(),
        restart: 0,
        restart_scores: Vec::new(),
        checkpoint_error: None,
        env_steps: world.steps(),
        eval_env_steps: evaluated.steps(),
    })
}

/// The iterations of one run of episode CE (model §3), as the loop over iterations drives them.
struct CeIterations<'a, 'w, E: ?Sized> {
    world: &'a Metered<'w, E>,
    config: &'a CeConfig,
    pool: &'a rayon::ThreadPool,
    remote: Option<&'a dyn Remote>,
    /// Made at the first iteration (a resumed run that ends at once needs none).
    buffers: Option<Buffers>,
    /// The run's seconds in earlier sessions, and when this session's began.
    before: f64,
    started: Instant,
    /// Closing evaluations of `eval_episodes` each: the final one, and between restarts the
    /// run's score.
    closings: usize,
    /// The episodes the last iteration ran (fewer than N where a budget cut it).
    ran: usize,
}

impl<E: Episodes + ?Sized> Iterations for CeIterations<'_, '_, E> {
    type Kind = CeRun;
    type Record = IterationRecord;

    fn started(run: &RunState) -> bool {
        run.best.is_some()
    }

    fn resumed(&self, run: &RunState) -> Option<StopReason> {
        run.history.last().and_then(|r| stopping_rule(self.config, r, run.unsuccessful, 0.0))
    }

    fn iterate(&mut self, run: &mut RunState, _: f64) -> Result<IterationRecord> {
        let config = self.config;
        let iteration = run.history.len();
        let buffers =
            self.buffers.get_or_insert_with(|| Buffers::new(self.world, &run.policy, config, self.remote, self.pool));
        let (sampled_n, threshold, counts) =
            buffers.iterate(self.world, &run.policy, config, iteration, self.remote, self.pool)?;
        self.ran = sampled_n;
        let (rewards, elite) = (&buffers.rewards[..sampled_n], &buffers.order[..config.elite_of(sampled_n)]);
        let mean = crate::evaluate::mean(rewards.iter().copied());
        let successful = run.best.as_ref().is_none_or(|(m, _, _)| mean > *m);
        if successful {
            run.best = Some((mean, iteration, run.policy.clone()));
            run.unsuccessful = 0;
        } else {
            run.unsuccessful += 1;
        }
        let policy = &mut run.policy;
        self.pool.install(|| match &counts {
            Counts::Integer(c) => policy.refit(c, config.smoothing, config.decision_smoothing),
            Counts::Real(c) => policy.refit(c, config.smoothing, config.decision_smoothing),
        });
        let record = IterationRecord {
            iteration,
            mean,
            best: rewards.iter().copied().fold(f64::NEG_INFINITY, f64::max),
            elite_threshold: rewards[threshold],
            elite_mean: crate::evaluate::mean(elite.iter().map(|&k| rewards[k])),
            seconds: self.before + self.started.elapsed().as_secs_f64(),
            successful,
            env_steps: self.world.steps(),
        };
        run.history.push(record.clone());
        Ok(record)
    }

    fn best(&self, run: &RunState) -> Result<Hhmm> {
        Ok(run.best.as_ref().map(|b| b.2.clone()).expect("a best policy after an iteration"))
    }

    fn stop(&self, run: &RunState, record: &IterationRecord, reserve: f64) -> Option<StopReason> {
        stopping_rule(self.config, record, run.unsuccessful, reserve)
    }

    fn closing(&self, _: &IterationRecord) -> Option<(usize, usize)> {
        Some((self.ran, self.closings * self.config.eval_episodes))
    }
}

/// An iteration's episodes, their order and the elite's counting, reused from one iteration to
/// the next.
struct Buffers {
    /// Numbers of one episode's record (`horizon · record_width`).
    stride: usize,
    records: Vec<u16>,
    rewards: Vec<f64>,
    lengths: Vec<u32>,
    keys: Vec<u64>,
    order: Vec<usize>,
    /// Elite episodes counted together (integer counts).
    chunk: usize,
}

impl Buffers {
    /// The buffers of `config`'s iterations of `policy` on `world` (records kept here where the
    /// episodes are sampled here).
    fn new<E: Episodes + ?Sized>(
        world: &E,
        policy: &Hhmm,
        config: &CeConfig,
        remote: Option<&dyn Remote>,
        pool: &rayon::ThreadPool,
    ) -> Buffers {
        let n = config.samples;
        let stride = world.shape().horizon * policy.layout().record_width();
        let recorded = remote.is_none();
        Buffers {
            stride,
            records: vec![0u16; if recorded { n * stride } else { 0 }],
            rewards: vec![0.0f64; n],
            lengths: vec![0u32; if recorded { n } else { 0 }],
            keys: vec![0; n],
            order: (0..n).collect(),
            chunk: config.elite_count().div_ceil(pool.current_num_threads()).max(1),
        }
    }

    /// Samples iteration `iteration` of `policy` (cut by a budget in steps: its elite is of the
    /// episodes run), puts its elite first in `order` and counts it: the episodes run, the
    /// index of the elite's worst, the counts.
    fn iterate<E: Episodes + ?Sized>(
        &mut self,
        world: &Metered<'_, E>,
        policy: &Hhmm,
        config: &CeConfig,
        iteration: usize,
        remote: Option<&dyn Remote>,
        pool: &rayon::ThreadPool,
    ) -> Result<(usize, usize, Counts)> {
        let seed = config.seed;
        let streams = Streams { seed, purpose: Purpose::Optimise, iteration: iteration as u64 };
        let Buffers { stride, records, rewards, lengths, keys, order, chunk } = self;
        let stride = *stride;
        let m = pool.install(|| {
            let records = remote.is_none().then_some((&mut records[..], &mut lengths[..]));
            sample(world, policy, streams, rewards, records, stride, config)
        })?;
        let elite_count = config.elite_of(m);
        let threshold =
            select_elite(&rewards[..m], &mut keys[..m], &mut order[..m], elite_count, seed, iteration, pool);
        let elite = &order[..elite_count];
        let counts = if let Some(remote) = remote {
            Counts::Integer(remote.counts(policy, streams, elite)?)
        } else {
            // Each episode's record up to where it stopped (model §1): counting stops there too.
            let width = policy.layout().record_width();
            let record_of = |k: usize| &records[k * stride..k * stride + lengths[k] as usize * width];
            pool.install(|| count_elite(policy, elite, &record_of, config.memory_update, *chunk))
        };
        Ok((m, threshold, counts))
    }
}

/// Runs the iteration's episodes into `rewards` (and `records`, where kept, with the numbers of
/// one episode's record): all of them, or, under a budget in steps, in groups of whole batches
/// until the budget is spent ([`Groups`]: the first always). The episodes run: the first ones,
/// in order.
fn sample<E: Episodes + ?Sized>(
    world: &Metered<'_, E>,
    policy: &Hhmm,
    streams: Streams,
    rewards: &mut [f64],
    mut records: Option<(&mut [u16], &mut [u32])>,
    stride: usize,
    config: &CeConfig,
) -> Result<usize> {
    if config.budget.max_env_steps.is_none() {
        world.run(policy, streams, 0, Batch { values: rewards, records })?;
        return Ok(rewards.len());
    }
    let (n, horizon) = (rewards.len(), world.shape().horizon);
    let mut groups = Groups::new(n, 1, world.batch(), CUT_EPISODES, horizon);
    let mut end = 0;
    while let Some(group) = groups.next(config.budget.left(world.steps())) {
        let (start, stop) = (group.start, group.end);
        let records = records.as_mut().map(|(r, l)| (&mut r[start * stride..stop * stride], &mut l[start..stop]));
        groups.took(world.run(policy, streams, start, Batch { values: &mut rewards[start..stop], records })?);
        end = stop;
    }
    Ok(end)
}

/// Where the episodes are sampled elsewhere, what counts the elite there; refuses the
/// forward–backward update, whose counts need the records here.
fn remote_of<'a, E: Episodes + ?Sized>(world: &'a E, config: &CeConfig) -> Result<Option<&'a dyn Remote>> {
    let remote = world.remote();
    if remote.is_some() && config.memory_update == MemoryUpdate::ForwardBackward {
        return Err(Error::invalid(
            "memory_update",
            "\"forward-backward\" with episodes sampled elsewhere (expected \"sampled\": their counts are taken where \
             the episodes were sampled)",
        ));
    }
    Ok(remote)
}

/// Puts the elite (the best `elite_count` of the iteration's episodes) first in `order` and
/// returns the worst of them, on `pool`.
fn select_elite(
    rewards: &[f64],
    keys: &mut [u64],
    order: &mut [usize],
    elite_count: usize,
    seed: u64,
    iteration: usize,
    pool: &rayon::ThreadPool,
) -> usize {
    pool.install(|| {
        keys.par_iter_mut().enumerate().for_each(|(k, key)| {
            *key = stream_key(seed, Purpose::TieBreak, iteration as u64, k as u64);
        });
    });
    // A strict total order (reward, then random key, then index): the elite set is the same
    // whatever the algorithm, and selection is O(N) where a sort would be O(N log N).
    let better = |&a: &usize, &b: &usize| rewards[b].total_cmp(&rewards[a]).then(keys[a].cmp(&keys[b])).then(a.cmp(&b));
    order.iter_mut().enumerate().for_each(|(k, o)| *o = k);
    if elite_count < order.len() {
        order.select_nth_unstable_by(elite_count - 1, better);
    }
    order[..elite_count].iter().copied().max_by(better).expect("the elite is never empty")
}

/// The stopping rule that holds after iteration `record` with `unsuccessful` unsuccessful
/// iterations in a row, if any (model §3): the shared rules on the iteration's mean, the time
/// limit `reserve` seconds early (what the closing evaluations keep).
fn stopping_rule(config: &CeConfig, record: &IterationRecord, unsuccessful: usize, reserve: f64) -> Option<StopReason> {
    config.stop_rules().check(record.iteration + 1, record.mean, unsuccessful, record.seconds + reserve)
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
}
