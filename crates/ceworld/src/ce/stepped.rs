//! An optimiser given by its iteration step alone ([`Stepped`]): the loop around it, its stop
//! rules, its history, its checkpoints (resumed bit for bit), its thread pool and the
//! evaluation of its result are this module's, the same for every such optimiser. What it
//! samples, it samples through [`Episodes`], so that it runs on any world, here or on a backend
//! elsewhere.

use std::marker::PhantomData;

use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};
use serde_json::json;

use crate::ce::budget::{Budget, Metered};
use crate::ce::record::IterationRecord;
use crate::ce::resume::{Checkpointing, Resumable, Saver};
use crate::ce::stopping::{Observed, StopReason};
use crate::control::{Flow, thread_pool};
use crate::episodes::Episodes;
use crate::error::{Error, Result};
use crate::evaluate::{Evaluation, closing_reserve, final_evaluation};
use crate::policy::Hhmm;
use crate::policy::file::PolicyFile;
use crate::settings::Settings;

/// The stop rules and the run settings every stepped optimiser has, read from its config.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rules {
    /// Stop after this many iterations in a row without success.
    pub patience: usize,
    /// Stop after this many iterations.
    pub max_iterations: Option<usize>,
    /// The budgets in seconds and in the world's steps ([`Budget`]).
    pub budget: Budget,
    /// Seed of every random stream (the evaluation's too).
    pub seed: u64,
    /// Worker threads (default: one per core).
    pub threads: Option<usize>,
    /// Fresh episodes the result is evaluated on.
    pub eval_episodes: usize,
    /// About how many episodes an iteration runs: the final evaluation's time is foreseen from
    /// them, and kept at the end of the time limit.
    pub episodes: usize,
}

/// An optimiser as its state between two iterations and its iteration step. Registering it in
/// [`crate::run::OPTIMISERS`] gives it the command line (`ceworld run NAME`), Python
/// (`cehmm.run(NAME, ...)`), the progress line, checkpoints, the history and the backends.
pub trait Stepped: Clone + Serialize + DeserializeOwned + Send + Sync {
    /// Its name (in the registry, on the command line, in Python, in policy files).
    const NAME: &'static str;
    /// The `"format"` of its checkpoint files.
    const FORMAT: &'static str;
    /// Its settings.
    type Config: Settings + Default + Clone + Serialize + DeserializeOwned + Send + Sync;

    /// The stop rules and run settings of `config`.
    fn rules(config: &Self::Config) -> Rules;
    /// Refuses settings out of their domain, naming them.
    fn validate(config: &Self::Config) -> Result<()>;
    /// The state before the first iteration.
    fn start(world: &dyn Episodes, config: &Self::Config) -> Result<Self>;
    /// Iteration `iteration` (from 0), its record's `seconds` and `env_steps` left to the spine;
    /// an iteration is successful when it finds a better result. `spent` says whether a budget
    /// is spent: an optimiser that can cut its iteration asks it between its batches of
    /// episodes (after the first). The world counts its steps: an iteration cut by an interrupt
    /// is dropped, its steps with it.
    fn step(
        &mut self,
        world: &dyn Episodes,
        config: &Self::Config,
        iteration: usize,
        spent: &dyn Fn() -> bool,
    ) -> Result<IterationRecord>;
    /// The best policy so far.
    fn policy(&self, world: &dyn Episodes) -> Result<Hhmm>;
}

/// A stepped run between two iterations, as checkpoints keep it.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(bound = "")]
pub struct SteppedRun<O: Stepped> {
    /// The optimiser's state.
    pub state: O,
    /// One record per iteration so far.
    pub history: Vec<IterationRecord>,
    /// Iterations since the last successful one.
    pub since: usize,
}

/// The checkpoints of the stepped optimiser `O`.
pub struct SteppedKind<O>(PhantomData<O>);

impl<O: Stepped> Resumable for SteppedKind<O> {
    const FORMAT: &'static str = O::FORMAT;
    const VERSION: u64 = 1;
    const OLDEST: u64 = 1;
    type Config = O::Config;
    type Run = SteppedRun<O>;
    type Finished = SteppedRun<O>;

    fn restarts(_: &O::Config) -> usize {
        1
    }

    fn check_run(_: &O::Config, run: &SteppedRun<O>) -> Option<String> {
        let numbered = run.history.iter().enumerate().all(|(k, r)| r.iteration == k);
        let since = run.history.iter().rev().take_while(|r| !r.successful).count();
        (!numbered || since != run.since).then(|| "its history does not match its counters".into())
    }

    fn check_finished(config: &O::Config, finished: &SteppedRun<O>) -> Option<String> {
        Self::check_run(config, finished)
    }

    fn non_finite(run: Option<&SteppedRun<O>>, finished: &[SteppedRun<O>]) -> Option<String> {
        run.into_iter().chain(finished).flat_map(|r| &r.history).find_map(IterationRecord::non_finite)
    }
}

/// What a stepped run gives.
#[derive(Clone, Debug)]
pub struct SteppedOutcome {
    /// The best policy found.
    pub policy: Hhmm,
    /// One record per iteration.
    pub history: Vec<IterationRecord>,
    /// Why it stopped.
    pub stop: StopReason,
    /// The best policy on fresh episodes.
    pub evaluation: Evaluation,
    /// Wall seconds, every session together, the evaluation included.
    pub seconds: f64,
    /// Why the last checkpoint could not be written, if it could not.
    pub checkpoint_error: Option<String>,
    /// The world's steps learning took, every session together.
    pub env_steps: u64,
    /// The world's steps of `evaluation`, counted apart.
    pub eval_env_steps: u64,
}

impl SteppedOutcome {
    /// The result as a policy file (model §6): the policy, the world, and the provenance (the
    /// settings of `config`, the method `name`, how the run went).
    pub fn to_file<C: Settings>(&self, world: &dyn Episodes, name: &str, config: &C) -> PolicyFile {
        let mut map = config.provenance();
        for (key, value) in [
            ("method", json!(name)),
            ("iterations", json!(self.history.len())),
            ("stop", json!(self.stop.as_str())),
            ("interrupted", json!(self.stop == StopReason::Interrupted)),
            ("env_steps", json!(self.env_steps)),
            ("evaluation_mean", json!(self.evaluation.mean)),
            ("evaluation_std_error", json!(self.evaluation.std_error)),
            ("evaluation_episodes", json!(self.evaluation.episodes)),
            ("version", json!(crate::VERSION)),
        ] {
            map.insert(key.into(), value);
        }
        PolicyFile { policy: self.policy.clone(), world: world.description(), provenance: map.into() }
    }
}

/// Runs the stepped optimiser `O` on `world` with `config` until a stop rule or `observe` stops
/// it, checkpointed as `checkpointing` asks (a resumed run continues bit for bit).
pub fn run_stepped<O: Stepped>(
    world: &dyn Episodes,
    config: &O::Config,
    checkpointing: Option<&Checkpointing>,
    mut observe: impl FnMut(&IterationRecord) -> Flow,
) -> Result<SteppedOutcome> {
    run_stepped_observed::<O>(world, config, checkpointing, |seen| observe(seen.step))
}

/// [`run_stepped`], its observer shown the best policy so far on demand too ([`Observed`]).
pub fn run_stepped_observed<O: Stepped>(
    world: &dyn Episodes,
    config: &O::Config,
    checkpointing: Option<&Checkpointing>,
    mut observe: impl FnMut(&Observed<'_, IterationRecord>) -> Flow,
) -> Result<SteppedOutcome> {
    O::validate(config)?;
    let rules = O::rules(config);
    crate::evaluate::check_episodes(rules.eval_episodes)?;
    let pool = thread_pool(rules.threads)?;
    let mut saver = Saver::<SteppedKind<O>>::new(world, config, checkpointing, None)?;
    // Learning's episodes, their steps counted on from the sessions before.
    let (metered, evaluated) = (Metered::new(world, saver.state.env_steps), world);
    let world: &dyn Episodes = &metered;
    let spent = || rules.budget.spent(metered.steps());
    let mut run = match saver.state.run.take() {
        Some(run) => run,
        None => SteppedRun { state: pool.install(|| O::start(world, config))?, history: Vec::new(), since: 0 },
    };
    // What the final evaluation keeps of the time limit, as the last iteration's episodes ran.
    let mut reserve = 0.0;
    let stop = loop {
        let iteration = run.history.len();
        let rule = if run.since >= rules.patience && iteration > 0 {
            Some(StopReason::Patience)
        } else if rules.max_iterations.is_some_and(|m| iteration >= m) {
            Some(StopReason::MaxIterations)
        } else if rules.budget.time_limit.is_some_and(|limit| saver.seconds() + reserve >= limit) {
            Some(StopReason::TimeLimit)
        } else {
            spent().then_some(StopReason::MaxEnvSteps)
        };
        // The stop rules are read afresh on resume (they may differ between sessions).
        if let Some(stop) = rule {
            break stop;
        }
        let mut next = run.state.clone();
        let (started, steps_before) = (std::time::Instant::now(), metered.steps());
        let mut record = match pool.install(|| next.step(world, config, iteration, &spent)) {
            Ok(record) => record,
            // An iteration a stop cut is dropped, its steps with it: the state is the one before it.
            Err(Error::Interrupted) if world.interrupt().is_some_and(crate::control::Interrupt::stopping) => {
                metered.reset(steps_before);
                break StopReason::Interrupted;
            }
            Err(e) => return Err(e),
        };
        record.iteration = iteration;
        let per_episode = started.elapsed().as_secs_f64() / rules.episodes.max(1) as f64;
        reserve = closing_reserve(rules.budget.time_limit, per_episode, rules.eval_episodes);
        record.seconds = saver.seconds();
        record.env_steps = metered.steps();
        saver.state.env_steps = record.env_steps;
        run.state = next;
        run.since = if record.successful { 0 } else { run.since + 1 };
        run.history.push(record.clone());
        saver.save_run(false, || run.clone());
        let best = || run.state.policy(world);
        if let Some(stop) = StopReason::asked(observe(&Observed { step: &record, best: &best, run: 0, earlier: 0 })) {
            break stop;
        }
    };
    saver.save_run(true, || run.clone());
    let policy = run.state.policy(world)?;
    // Inside the time limit: what is left of it (an interrupt does not cut it: the run's
    // iterations are over).
    let left = rules.budget.time_limit.map(|t| t - saver.seconds());
    let (episodes, seed) = (rules.eval_episodes, rules.seed);
    // The final evaluation's steps are counted apart.
    let evaluated = Metered::new(evaluated, 0);
    let (evaluation, _) = pool.install(|| final_evaluation(&evaluated, &policy, episodes, seed, false, left))?;
    Ok(SteppedOutcome {
        policy,
        history: run.history,
        stop,
        evaluation,
        seconds: saver.seconds(),
        checkpoint_error: saver.failed.take(),
        env_steps: metered.steps(),
        eval_env_steps: evaluated.steps(),
    })
}
