//! An optimiser given by its iteration step alone ([`Stepped`]): the loops around it (over its
//! runs, [`crate::ce::runs`], and its iterations, [`crate::ce::iterations`]), its stop rules, its
//! history, its checkpoints (resumed bit for bit), its budgets, its thread pool and the
//! evaluation of its result come from the spine, the same for every such optimiser (this module
//! adapts a step to the two loops). What it samples, it samples through [`Episodes`], so that it
//! runs on any world, here or on a backend elsewhere.

use std::marker::PhantomData;

use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};
use serde_json::json;

use crate::ce::budget::{Budget, Metered};
use crate::ce::iterations::{Ended, Iterations, Watch, iterate_run};
use crate::ce::record::{Ending, IterationRecord};
use crate::ce::resume::{Checkpointing, Clock, Resumable, Saver};
use crate::ce::runs::{Runs, over_runs};
use crate::ce::stopping::{Observed, StopReason, StopRules};
use crate::control::{Flow, thread_pool};
use crate::episodes::Episodes;
use crate::error::Result;
use crate::evaluate::{Evaluation, final_evaluation};
use crate::policy::Hhmm;
use crate::policy::file::PolicyFile;
use crate::settings::{Setting, Settings};

/// The settings every stepped optimiser has: its stop rules, budgets, seed, threads and final
/// evaluation, flattened into its config (so that their names, flags and checkpoint keys are the
/// config's own) and read there by [`Rules::set`].
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Rules {
    /// Stop once the best value so far (an iteration record's `best`) reaches this.
    #[serde(default)]
    pub target: Option<f64>,
    /// Stop after this many iterations in a row without success.
    pub patience: usize,
    /// Stop after this many iterations.
    pub max_iterations: Option<usize>,
    /// The budgets in seconds and in the world's steps ([`Budget`]).
    #[serde(flatten)]
    pub budget: Budget,
    /// Seed of every random stream (the evaluation's too).
    pub seed: u64,
    /// Worker threads (default: one per core).
    pub threads: Option<usize>,
    /// Fresh episodes the result is evaluated on.
    pub eval_episodes: usize,
}

impl Default for Rules {
    fn default() -> Self {
        Rules {
            target: None,
            patience: 20,
            max_iterations: None,
            budget: Budget::default(),
            seed: 0,
            threads: None,
            eval_episodes: 10_000,
        }
    }
}

impl Rules {
    /// Whether `name` is one of these settings.
    pub fn owns(name: &str) -> bool {
        ["target", "patience", "max_iterations", "seed", "threads", "eval_episodes"].contains(&name)
            || Budget::NAMES.contains(&name)
    }

    /// Sets `s`, one of these settings ([`Rules::owns`]).
    pub fn set(&mut self, s: &Setting<'_>) -> Result<()> {
        match s.name {
            "target" => self.target = s.optional_real()?,
            "patience" => self.patience = s.count()?,
            "max_iterations" => self.max_iterations = s.optional_count()?,
            "seed" => self.seed = s.seed()?,
            "threads" => self.threads = s.optional_count()?,
            "eval_episodes" => self.eval_episodes = s.count()?,
            _ => self.budget.set(s)?,
        }
        Ok(())
    }
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
    /// About how many episodes an iteration runs: the final evaluation's time is foreseen from
    /// them, and kept at the end of the time limit.
    fn episodes(config: &Self::Config) -> usize;
    /// Refuses settings out of their domain, naming them.
    fn validate(config: &Self::Config) -> Result<()>;
    /// The state before the first iteration.
    fn start(world: &dyn Episodes, config: &Self::Config) -> Result<Self>;
    /// Iteration `iteration` (from 0), its record's `seconds` and `env_steps` left to the spine;
    /// an iteration is successful when it finds a better result. `left` gives the steps of the
    /// world the budget in steps leaves (`None` without one): an optimiser that can cut its
    /// iteration asks it between its batches of episodes (after the first). The world counts its
    /// steps: an iteration cut by an interrupt is dropped, its steps with it.
    fn step(
        &mut self,
        world: &dyn Episodes,
        config: &Self::Config,
        iteration: usize,
        left: &dyn Fn() -> Option<u64>,
    ) -> Result<IterationRecord>;
    /// The best policy so far.
    fn policy(&self, world: &dyn Episodes) -> Result<Hhmm>;
    /// Whether the steps of the world the budget leaves (`left`, as [`Stepped::step`]'s) are too
    /// few for an iteration to do anything that counts: the run then stops as at the end of its
    /// budget, instead of iterating on them. Never, unless an optimiser says so.
    fn spent(&self, _config: &Self::Config, _left: Option<u64>) -> bool {
        false
    }
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
    /// Why it stopped, once it has (the run's checkpoints in progress keep a placeholder).
    #[serde(default = "interrupted")]
    pub stop: StopReason,
}

/// The stop reason a checkpoint of version 1 reads for a run in progress.
fn interrupted() -> StopReason {
    StopReason::Interrupted
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
    /// How the run ended: what the result says beside its policy, history and evaluation, by the
    /// names the bindings hand on.
    pub fn ending(&self) -> Ending {
        Ending {
            stop_reason: self.stop,
            seconds: self.seconds,
            env_steps: self.env_steps,
            eval_env_steps: self.eval_env_steps,
        }
    }

    /// The result as a policy file (model §6): the policy, the world, and the provenance (the
    /// settings of `config`, the method `name`, how the run went).
    pub fn to_file<C: Settings>(&self, world: &dyn Episodes, name: &str, config: &C) -> PolicyFile {
        let mut map = config.provenance();
        for (key, value) in [
            ("method", json!(name)),
            ("evaluation_mean", json!(self.evaluation.mean)),
            ("evaluation_std_error", json!(self.evaluation.std_error)),
            ("evaluation_episodes", json!(self.evaluation.episodes)),
        ] {
            map.insert(key.into(), value);
        }
        self.ending().provenance(self.history.len(), &mut map);
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
    if let Some(t) = rules.target.filter(|t| !t.is_finite()) {
        return Err(crate::error::Error::invalid("target", format!("{t} (expected a finite number)")));
    }
    let pool = thread_pool(rules.threads)?;
    let mut saver = Saver::<SteppedKind<O>>::new(world, config, checkpointing, None)?;
    // Learning's episodes, their steps counted on from the sessions before.
    let metered = Metered::new(world, saver.state.env_steps);
    let mut runs = SteppedRuns::<O, _> { world: &metered, config, rules, pool: &pool, observe: &mut observe };
    let chosen = over_runs(&mut runs, 1, &mut saver)?;
    let stop = chosen.stop(&saver.state.finished, |r| r.stop);
    let (runs, best) = chosen.all(&saver.state.finished, |_| 0.0);
    let run = runs[best];
    let policy = run.state.policy(world)?;
    // Inside the time limit: what is left of it (an interrupt does not cut it: the run's
    // iterations are over).
    let left = rules.budget.time_limit.map(|t| t - saver.seconds());
    let (episodes, seed) = (rules.eval_episodes, rules.seed);
    // The final evaluation's steps are counted apart.
    let evaluated = Metered::new(world, 0);
    let (evaluation, _) = pool.install(|| final_evaluation(&evaluated, &policy, episodes, seed, false, left))?;
    Ok(SteppedOutcome {
        policy,
        history: run.history.clone(),
        stop,
        evaluation,
        seconds: saver.seconds(),
        checkpoint_error: saver.failed.take(),
        env_steps: metered.steps(),
        eval_env_steps: evaluated.steps(),
    })
}

/// The run of a stepped optimiser, as the loop over runs drives it.
struct SteppedRuns<'a, 'w, O: Stepped, F> {
    world: &'a Metered<'w, dyn Episodes + 'w>,
    config: &'a O::Config,
    rules: Rules,
    pool: &'a rayon::ThreadPool,
    observe: &'a mut F,
}

impl<O: Stepped, F: FnMut(&Observed<'_, IterationRecord>) -> Flow> Runs for SteppedRuns<'_, '_, O, F> {
    type Kind = SteppedKind<O>;

    fn run(
        &mut self,
        restart: usize,
        resume: Option<SteppedRun<O>>,
        saver: &mut Saver<'_, SteppedKind<O>>,
    ) -> Result<SteppedRun<O>> {
        let run = if let Some(run) = resume {
            run
        } else {
            let state = self.pool.install(|| O::start(self.world, self.config))?;
            SteppedRun { state, history: Vec::new(), since: 0, stop: StopReason::Interrupted }
        };
        let (rules, world) = (&self.rules, self.world);
        let watch = Watch {
            run: restart,
            earlier: 0,
            budget: &rules.budget,
            meter: world,
            interrupt: world.interrupt(),
            reserve: 0.0,
        };
        let mut it =
            SteppedIterations::<O> { world, config: self.config, rules, pool: self.pool, clock: saver.clock() };
        let Ended { mut run, stop, .. } = iterate_run(&mut it, run, saver, self.observe, &watch)?;
        run.stop = stop;
        Ok(run)
    }

    fn stop(run: &SteppedRun<O>) -> StopReason {
        run.stop
    }

    fn spent(&self, _: &Saver<'_, SteppedKind<O>>) -> Option<StopReason> {
        None
    }

    fn aborted(&self) -> bool {
        self.world.interrupt().is_some_and(crate::control::Interrupt::aborted)
    }

    fn steps(&self) -> u64 {
        self.world.steps()
    }
}

/// The iterations of a stepped optimiser, as the loop over iterations drives them.
struct SteppedIterations<'a, 'w, O: Stepped> {
    world: &'a Metered<'w, dyn Episodes + 'w>,
    config: &'a O::Config,
    rules: &'a Rules,
    pool: &'a rayon::ThreadPool,
    clock: Clock,
}

impl<O: Stepped> Iterations for SteppedIterations<'_, '_, O> {
    type Kind = SteppedKind<O>;
    type Record = IterationRecord;

    fn started(_: &SteppedRun<O>) -> bool {
        // A stepped optimiser's state is whole from its start.
        true
    }

    fn resumed(&self, run: &SteppedRun<O>) -> Option<StopReason> {
        let last = run.history.last()?;
        self.stop(run, last, 0.0)
    }

    fn iterate(&mut self, run: &mut SteppedRun<O>, _: f64) -> Result<IterationRecord> {
        let iteration = run.history.len();
        // The iteration runs on a copy: one cut is dropped, the state is the one before it.
        let mut next = run.state.clone();
        let budget = self.rules.budget;
        let left = || budget.left(self.world.steps());
        let world: &dyn Episodes = self.world;
        let mut record = self.pool.install(|| next.step(world, self.config, iteration, &left))?;
        record.iteration = iteration;
        record.seconds = self.clock.seconds();
        record.env_steps = self.world.steps();
        run.state = next;
        run.since = if record.successful { 0 } else { run.since + 1 };
        run.history.push(record.clone());
        Ok(record)
    }

    fn best(&self, run: &SteppedRun<O>) -> Result<Hhmm> {
        run.state.policy(self.world)
    }

    fn stop(&self, run: &SteppedRun<O>, record: &IterationRecord, reserve: f64) -> Option<StopReason> {
        let Rules { target, patience, max_iterations, budget, .. } = *self.rules;
        // The target is of the best so far, as the controller search's.
        let rules = StopRules { target, patience, max_iterations, time_limit: budget.time_limit };
        let spent = run.state.spent(self.config, budget.left(self.world.steps())).then_some(StopReason::MaxEnvSteps);
        rules.check(run.history.len(), record.best, run.since, record.seconds + reserve).or(spent)
    }

    fn closing(&self, _: &IterationRecord) -> Option<(usize, usize)> {
        Some((O::episodes(self.config), self.rules.eval_episodes))
    }
}
