//! Cross-entropy over deterministic controllers (model §8).
//!
//! The paper's CE (model §3) samples *episodes* and counts the decisions and memory of the
//! elite. The CE method can also run in the space of machines, as Rubinstein states it for
//! combinatorial problems (and as DICE does for decentralised POMDPs: Oliehoek, Kooi & Vlassis,
//! 2008): draw `N` deterministic `n`-node controllers ([`Controller`]) from independent
//! categorical laws ([`laws`]: one per node for its decision, one per node and observation for
//! its successor), value each ([`value`]: exactly on a tabular world, from `K` episodes on
//! common random numbers on any world), keep the best `⌈ρN⌉`, refit the laws to the elite's
//! frequencies (smoothed by α), repeat. On sampled values the best so far is chosen on fixed
//! selection episodes and the controller returned is valued on fresh ones.

mod bounds;
mod chain;
pub mod checkpoint;
pub mod config;
mod improve;
mod laws;
pub mod lens;
mod memory;
pub mod model;
pub mod model_search;
mod outcome;
mod selection;
mod stage;
pub mod value;

use rayon::prelude::*;

use crate::ce::budget::{Groups, Metered};
use crate::ce::record::IterationRecord;
use crate::ce::stopping::{Observed, StopReason};
use crate::control::{Flow, Interrupt, thread_pool};
use crate::episodes::{Episodes, Remote};
use crate::error::Result;
use crate::evaluate::mean;
pub use crate::policy::controller::Controller;
use crate::rng::{Purpose, restart_seed, stream};
use bounds::check_policy_fits;
pub use chain::Scratch;
pub use config::{
    ControllerConfig, Credit, Decisions, MAX_ITERATION_EPISODES, MAX_RESTARTS, MAX_SAMPLES, Memory, Template, ValueKind,
};
pub use improve::improve;
use laws::Laws;
use memory::ALTERNATE_SHARES;
pub use outcome::{ControllerIteration, ControllerOutcome, ControllerSummary, Start};
use selection::{Scores, Valuation, kept_values};
use value::Seen;
pub use value::{ControllerValue, Valued};

use crate::ce::iterations::{Ended, Iterations, Watch, iterate_run};
use crate::ce::resume::{Checkpointing, Clock, Saver};
use crate::ce::runs::{Runs, over_runs};
use checkpoint::{ControllerSearch, FinishedSearch, Known, SearchSettings, SearchState};
use stage::model_start;

/// Searches deterministic `config.nodes`-node controllers of `world` by the cross-entropy method
/// (module docs), `config.restarts` times; `observe` sees every iteration of every run and may
/// stop the search. On exact values the best controller of all the runs is returned (the choice
/// has no selection bias); on sampled values the best on the selection episodes, valued on
/// fresh ones.
pub fn optimize_controller(
    world: Valued<'_>,
    config: &ControllerConfig,
    observe: impl FnMut(&ControllerIteration) -> Flow,
) -> Result<ControllerOutcome> {
    optimize_controller_with(world, config, None, observe)
}

/// [`optimize_controller`], saving the whole state to `checkpointing.path` every
/// `checkpointing.every` seconds and whenever it stops, and, with `checkpointing.resume`,
/// continuing from that file when it exists: the result is then the one an uninterrupted search
/// gives, bit for bit (the seconds and a time limit aside).
pub fn optimize_controller_with(
    world: Valued<'_>,
    config: &ControllerConfig,
    checkpointing: Option<&Checkpointing>,
    mut observe: impl FnMut(&ControllerIteration) -> Flow,
) -> Result<ControllerOutcome> {
    optimize_controller_observed(world, config, checkpointing, |seen| observe(seen.step))
}

/// [`optimize_controller_with`], its observer shown the best controller so far (of the current
/// run) on demand too ([`Observed`]). An observer's [`Flow::Finish`] ends every run: the result
/// is the best so far, stopped for [`StopReason::Callback`], and a resume continues the run it cut.
pub fn optimize_controller_observed(
    world: Valued<'_>,
    config: &ControllerConfig,
    checkpointing: Option<&Checkpointing>,
    mut observe: impl FnMut(&Observed<'_, ControllerIteration>) -> Flow,
) -> Result<ControllerOutcome> {
    config.validate()?;
    if world.kind() != ValueKind::Sampled {
        config.budget.check_sampled("exact values")?;
    }
    let shape = world.episodes().shape();
    let (n_actions, y1) = (shape.decisions, shape.observations);
    let built = match world {
        Valued::Exact(w) => model_start(w, config),
        Valued::ExactElsewhere(_, remote) => remote.model().and_then(|w| model_start(w, config)),
        Valued::Sampled(_) => None,
    };
    let start_facts = built.as_ref().map(|(_, facts)| *facts);
    let start = built.and_then(|(controller, facts)| facts.kept.then_some(controller));
    // The policy must fit before the search (its size known once the model start is).
    check_policy_fits(start.as_ref(), config, y1, n_actions)?;
    if let Valued::Sampled(_) = world {
        let bytes = (config.samples * config.episodes + config.select_episodes * config.candidates) as u64 * 8;
        crate::memory::check_memory("the values of one iteration", bytes, crate::memory::available_memory())?;
    }
    let settings = SearchSettings { config: config.clone(), value: world.kind() };
    let mut saver = Saver::<ControllerSearch>::new(world.episodes(), &settings, checkpointing, None)?;
    let memory = config.memory_of(saver.state.restart);
    let staged = start.is_none() && memory.staged;
    let nodes = start.as_ref().map_or(memory.nodes, Controller::nodes);
    if let Some(run) = &saver.state.run
        && ((run.laws.nodes() != nodes + run.growths && !(staged && run.laws.nodes() == 1))
            || run.laws.shape() != (n_actions, y1))
    {
        return Err(crate::error::Error::CheckpointMismatch("the checkpoint's laws do not fit this search".into()));
    }
    let pool = thread_pool(config.threads)?;
    // Learning's episodes, their steps counted on from the sessions before.
    let metered = Metered::new(world.episodes(), saver.state.env_steps);
    let values = match world {
        Valued::Exact(w) => Values::Exact(ControllerValue::new(w, config.tolerance)),
        Valued::Sampled(_) => Values::Sampled(&metered),
        Valued::ExactElsewhere(w, remote) => Values::ExactElsewhere(w, remote),
    };
    let most = start.as_ref().map_or(config.most_nodes(), |s| s.nodes() + config.growths);
    let seen = Seen::new(most, y1);
    let episodes = std::sync::atomic::AtomicU64::new(0);
    let reserve = std::sync::atomic::AtomicU64::new(0);
    let (scores, bar) = kept_values(&saver.state)?;
    let meter = &metered;
    let search = Search { config, values, meter, seen, scores, bar, episodes, reserve, start, y1, n_actions, pool };
    let mut runs = SearchRuns { search: &search, observe: &mut observe };
    let chosen = over_runs(&mut runs, config.runs(), &mut saver)?;
    let (runs, best) = chosen.all(&saver.state.finished, |r| r.value);
    let stop = chosen.stop(&saver.state.finished, |r| r.stop);
    let mut outcome = ControllerOutcome::of_runs(&runs, best, stop, world.kind(), (y1, n_actions))?;
    outcome.env_steps = metered.steps();
    outcome.start = start_facts;
    if let Valued::Sampled(w) = world {
        // The final evaluation's steps are counted apart.
        let evaluated = Metered::new(w, 0);
        search.evaluate(&evaluated, &mut outcome, config.budget.time_limit.map(|t| t - saver.seconds()))?;
        outcome.eval_env_steps = evaluated.steps();
    }
    outcome.seconds = saver.seconds();
    outcome.checkpoint_error = saver.failed.take();
    Ok(outcome)
}

/// The iterations of one run of a controller search, as the loop over iterations drives them.
struct SearchIterations<'a, 's> {
    search: &'a Search<'s>,
    seed: u64,
    restart: usize,
    /// Where the run ends by its share of the time limit (alternating memories), in seconds.
    share: Option<f64>,
    rules: crate::ce::stopping::StopRules,
    clock: Clock,
    /// What cut the last iteration, if anything.
    cut: Option<StopReason>,
}

impl Iterations for SearchIterations<'_, '_> {
    type Kind = ControllerSearch;
    type Record = ControllerIteration;

    fn started(run: &SearchState) -> bool {
        run.best.is_some()
    }

    fn resumed(&self, run: &SearchState) -> Option<StopReason> {
        let r = run.history.last()?;
        self.rules.check(run.history.len(), r.best_so_far, run.since_progress, r.record.seconds)
    }

    fn iterate(&mut self, state: &mut SearchState, reserve: f64) -> Result<ControllerIteration> {
        let search = self.search;
        let iteration = state.history.len();
        // The time limit as an instant, so that the exact values can check it as they go.
        let limit = search.config.budget.time_limit.map(|t| t - reserve);
        let end = self.share.map_or(limit, |s| Some(limit.map_or(s, |l| s.min(l))));
        let deadline = end.map(|t| {
            std::time::Instant::now() + std::time::Duration::from_secs_f64((t - self.clock.seconds()).max(0.0))
        });
        let over_time = || deadline.is_some_and(|d| std::time::Instant::now() >= d);
        let drawn = search.value(&state.laws, self.seed, iteration, &over_time, state.best.is_some())?;
        self.cut = drawn.cut;
        search.stage_bar(state, drawn.groups.as_ref())?;
        let record = search.learn(state, &drawn, self.restart, self.clock.seconds());
        state.history.push(record.clone());
        Ok(record)
    }

    fn best(&self, state: &SearchState) -> Result<crate::policy::Hhmm> {
        self.search.best_policy(state)
    }

    fn stop(&self, state: &SearchState, record: &ControllerIteration, reserve: f64) -> Option<StopReason> {
        let seconds = record.record.seconds;
        let over_share = self.share.is_some_and(|t| seconds >= t);
        // An iteration cut valued fewer controllers than drawn, by the time limit or the budget in
        // steps.
        let (value, since) = (record.best_so_far, state.since_progress);
        self.rules
            .check(state.history.len(), value, since, seconds + reserve)
            .or(self.cut)
            .or(over_share.then_some(StopReason::TimeLimit))
    }

    fn closing(&self, record: &ControllerIteration) -> Option<(usize, usize)> {
        let sampled = matches!(self.search.values, Values::Sampled(_));
        sampled.then_some((record.episodes as usize, self.search.config.eval_episodes))
    }

    fn snapshot(&self, state: &SearchState) -> SearchState {
        SearchState { known: self.search.known(), ..state.clone() }
    }
}

/// The runs of a controller search, as the loop over runs drives them.
struct SearchRuns<'a, 's, O> {
    search: &'a Search<'s>,
    observe: &'a mut O,
}

impl<O: FnMut(&Observed<'_, ControllerIteration>) -> Flow> Runs for SearchRuns<'_, '_, O> {
    type Kind = ControllerSearch;
    const CONTINUED: bool = false;

    fn run(
        &mut self,
        restart: usize,
        resume: Option<SearchState>,
        saver: &mut Saver<'_, ControllerSearch>,
    ) -> Result<FinishedSearch> {
        // The later runs skip the memoryless stage: an earlier run found its policy.
        let stage = saver.state.finished.iter().find_map(|r| r.memoryless.clone());
        let seed = restart_seed(self.search.config.seed, restart);
        let run = self.search.run(seed, restart, resume, stage, saver, self.observe)?;
        if !run.stop.halted() {
            // The last run over holds the scores (for a resume before the next run's first save).
            if let Some(last) = saver.state.finished.last_mut() {
                last.known = Known::default();
            }
        }
        Ok(run)
    }

    fn stop(run: &FinishedSearch) -> StopReason {
        run.stop
    }

    /// A later run starts only while the final evaluation still fits in the time left.
    fn spent(&self, saver: &Saver<'_, ControllerSearch>) -> Option<StopReason> {
        let search = self.search;
        search.config.budget.exhausted(saver.seconds() + search.reserve(), search.meter.steps())
    }

    /// Runs until the time limit end with the target too. Past the time limit no run starts: a
    /// run stopped by its share of the limit is followed by the next.
    fn last(&self, run: &FinishedSearch) -> bool {
        self.search.config.restarts == 0 && run.stop == StopReason::Target
    }

    fn aborted(&self) -> bool {
        self.search.interrupt().is_some_and(Interrupt::aborted)
    }

    fn steps(&self) -> u64 {
        self.search.meter.steps()
    }
}

/// How a search values its controllers.
enum Values<'a> {
    Exact(ControllerValue<'a>),
    Sampled(&'a dyn Episodes),
    ExactElsewhere(&'a dyn Episodes, &'a dyn Remote),
}

/// What every run of a search shares.
struct Search<'a> {
    config: &'a ControllerConfig,
    values: Values<'a>,
    /// The world's steps learning took (sampled values).
    meter: &'a Metered<'a, dyn Episodes + 'a>,
    /// Exact values already computed.
    seen: Seen,
    /// Scores on the selection episodes already computed (kept by checkpoints).
    scores: Scores,
    /// What a memoryless stage's best must beat ([`Search::bar`]) and the gain that counts in
    /// it ([`Search::stage_noise`]), once computed.
    bar: std::sync::OnceLock<(f64, f64)>,
    /// The world's episodes run since the last record.
    episodes: std::sync::atomic::AtomicU64,
    /// The seconds kept for the final evaluation at the end of the time limit, as the last
    /// iteration's episodes ran ([`closing_reserve`]; the bits of an `f64`).
    reserve: std::sync::atomic::AtomicU64,
    /// The controller built from the model, if any: the runs have its nodes, their laws start
    /// around it, and it is the first controller of the first iteration.
    start: Option<Controller>,
    y1: usize,
    n_actions: usize,
    pool: rayon::ThreadPool,
}

impl Search<'_> {
    /// What may stop the search's episodes from outside.
    fn interrupt(&self) -> Option<&Interrupt> {
        match &self.values {
            Values::Sampled(world) | Values::ExactElsewhere(world, _) => world.interrupt(),
            Values::Exact(_) => None,
        }
    }

    /// The iteration's controllers, drawn from `laws`, with their values: exact (the controllers
    /// not yet evaluated when the time limit passes are left out, the first always counts), or
    /// the mean of `K` episodes on the iteration's common streams (those left out when the time
    /// limit passes or the budget in steps is spent, the first group always counts).
    fn draw_and_value(
        &self,
        laws: &Laws,
        seed: u64,
        iteration: usize,
        over_time: &(dyn Fn() -> bool + Sync),
    ) -> Result<Valuation> {
        let samples = self.config.samples;
        let draw = |k: usize| match &self.start {
            Some(start) if iteration == 0 && k == 0 => start.clone(),
            _ => laws.draw(&mut stream(seed, Purpose::Optimise, iteration as u64, k as u64)),
        };
        self.pool.install(|| match &self.values {
            Values::Exact(exact) => {
                let drawn: Vec<Option<Scored>> = (0..samples)
                    .into_par_iter()
                    .map_init(Scratch::default, |scratch, k| {
                        if k > 0 && over_time() {
                            return None;
                        }
                        let c = draw(k);
                        Some((self.seen.value(&c, || exact.value(&c, scratch)), c))
                    })
                    .collect();
                let cut = drawn.iter().any(Option::is_none).then_some(StopReason::TimeLimit);
                Ok(Valuation { drawn, credit: None, groups: None, cut })
            }
            Values::ExactElsewhere(_, remote) => {
                // One batch: the time limit is checked between iterations only.
                let controllers: Vec<Controller> = (0..samples).into_par_iter().map(draw).collect();
                let values = remote.exact_values(&controllers, self.config.tolerance)?;
                let drawn = values.into_iter().zip(controllers).map(Some).collect();
                Ok(Valuation { drawn, credit: None, groups: None, cut: None })
            }
            Values::Sampled(world) => {
                let controllers: Vec<Controller> = (0..samples).into_par_iter().map(draw).collect();
                self.sampled_values(*world, &controllers, laws, seed, iteration, over_time)
            }
        })
    }

    /// Counts `episodes` of the world run for the next record.
    fn ran(&self, episodes: usize) {
        self.episodes.fetch_add(episodes as u64, std::sync::atomic::Ordering::Relaxed);
    }

    /// An escape from a run whose patience ran out, if any is left: an entropy injection, else
    /// a growth around `best`; (injected, grown).
    fn escape(&self, laws: &mut Laws, best: &Controller, injections: &mut usize, growths: &mut usize) -> (bool, bool) {
        let config = self.config;
        if *injections < config.injections {
            laws.inject(config.injection);
            *injections += 1;
            (true, false)
        } else if *growths < config.growths && !laws.factored() {
            *laws = Laws::grown(best, self.n_actions, self.y1, config.injection);
            *growths += 1;
            (false, true)
        } else {
            (false, false)
        }
    }

    /// The state of run `restart` before it starts: the first laws (after the memoryless stage
    /// `stage` of an earlier run, if any).
    fn fresh(&self, restart: usize, stage: Option<(f64, Controller)>) -> Result<SearchState> {
        let c = self.config;
        let m = c.memory_of(restart);
        Ok(SearchState {
            laws: match (&self.start, &stage) {
                (Some(start), _) => Laws::around(start, self.n_actions, self.y1, c.template_weight),
                (None, Some((value, best))) if m.staged => self.after_stage(restart, *value, best)?,
                (None, None) if m.staged => Laws::uniform(1, self.n_actions, self.y1, true),
                (None, _) => {
                    Laws::start(m.nodes, self.n_actions, self.y1, m.mealy, m.registers, m.template, m.template_weight)
                }
            },
            best: None,
            history: Vec::new(),
            since_progress: 0,
            best_threshold: None,
            injections: 0,
            growths: 0,
            memoryless: stage,
            known: Known::default(),
        })
    }

    /// One run with `seed`, from its first laws or from the saved state `resume`.
    fn run(
        &self,
        seed: u64,
        restart: usize,
        resume: Option<SearchState>,
        stage: Option<(f64, Controller)>,
        saver: &mut Saver<'_, ControllerSearch>,
        observe: &mut impl FnMut(&Observed<'_, ControllerIteration>) -> Flow,
    ) -> Result<FinishedSearch> {
        let config = self.config;
        let state = match resume {
            Some(state) => state,
            None => self.fresh(restart, stage)?,
        };
        // Alternating memories: in the first round, each run but the last ends by its share of
        // the time limit, so that the others have the rest.
        let shared = config.memory == Memory::Alternate && restart + 1 < config.runs();
        let share = ALTERNATE_SHARES.get(restart).zip(config.budget.time_limit.filter(|_| shared)).map(|(s, t)| s * t);
        // The iterations of the runs before this one (for the callback's count).
        let earlier: usize = saver.state.finished.iter().map(|r| r.history.len()).sum();
        let mut it = SearchIterations {
            search: self,
            seed,
            restart,
            share,
            rules: config.stop_rules(),
            clock: saver.clock(),
            cut: None,
        };
        let (budget, meter, interrupt, reserve) = (&config.budget, self.meter, self.interrupt(), self.reserve());
        let watch = Watch { run: restart, earlier, budget, meter, interrupt, reserve };
        let Ended { run: state, stop, reserve } = iterate_run(&mut it, state, saver, observe, &watch)?;
        self.reserve.store(reserve.to_bits(), std::sync::atomic::Ordering::Relaxed);
        let (value, controller, best_iteration) = state.best.expect("a best controller after an iteration");
        let memoryless = state.memoryless;
        let (history, known) = (state.history, self.known());
        Ok(FinishedSearch { value, controller, best_iteration, history, stop, memoryless, known })
    }

    /// The iteration's controllers drawn from `laws` and valued, best first, with the candidate
    /// for the best so far.
    fn value(
        &self,
        laws: &Laws,
        seed: u64,
        iteration: usize,
        over_time: &(dyn Fn() -> bool + Sync),
        has_best: bool,
    ) -> Result<Draws> {
        let Valuation { drawn, credit, groups, cut } = self.draw_and_value(laws, seed, iteration, over_time)?;
        let drawn: Vec<(f64, Controller)> = drawn.into_iter().flatten().collect();
        let mut order: Vec<usize> = (0..drawn.len()).collect();
        // Highest value first; equal values keep their draw order (deterministic).
        order.sort_by(|&i, &j| drawn[j].0.total_cmp(&drawn[i].0).then(i.cmp(&j)));
        let candidate = self.candidate(&drawn, &order, groups.as_ref(), has_best)?;
        // Each decision row's best decision by the credit of its steps, where there is one.
        let best =
            credit.map(|credit| credit.best(drawn.iter().map(|(_, c)| c.decisions()).enumerate(), self.n_actions));
        Ok(Draws { iteration, drawn, cut, groups, order, candidate, best })
    }

    /// Learns from an iteration's controllers: the best so far, progress, the laws refitted to
    /// the elite, an escape where patience ran out; the iteration's record.
    fn learn(&self, state: &mut SearchState, drawn: &Draws, restart: usize, seconds: f64) -> ControllerIteration {
        let config = self.config;
        let Draws { iteration, drawn, cut, order, candidate, best, .. } = drawn;
        let elite_size = config.elite_count().min(drawn.len());
        let top = order[0];
        let threshold = drawn[order[elite_size - 1]].0;
        let mut best_threshold = state.best_threshold.unwrap_or(f64::NEG_INFINITY);
        // Progress is a better controller or a higher elite threshold (Rubinstein's γ_t): a
        // lucky early draw must not stop a search whose laws are still climbing.
        let mut progress = threshold > best_threshold + config.tolerance;
        best_threshold = best_threshold.max(threshold);
        if let Some((value, k)) = *candidate
            && state.best.as_ref().is_none_or(|(b, _, _)| value > *b + config.tolerance)
        {
            state.best = Some((value, drawn[k].1.clone(), *iteration));
            progress = true;
        }
        state.since_progress = if progress { 0 } else { state.since_progress + 1 };
        // Iterations in a row whose best so far was within `noise` of the best (none if this
        // one gained more), read from the history where a memoryless stage asks.
        let since_better = |state: &SearchState, noise: f64| {
            let best = state.best.as_ref().map_or(f64::NAN, |b| b.0);
            if state.history.last().is_none_or(|r| best > r.best_so_far + noise) {
                0
            } else {
                state.history.iter().rev().take_while(|r| r.best_so_far >= best - noise).count()
            }
        };
        // Ties at the threshold are left out when some controllers beat it: a plateau of equal
        // values (e.g. tiger's "always listen") would otherwise fill the elite and hold the laws
        // there.
        let above = order[..elite_size].iter().take_while(|&&i| drawn[i].0 > threshold).count();
        let kept = if above > 0 { above } else { elite_size };
        if cut.is_none() {
            // A cut iteration's elite would favour whichever controllers came first.
            let elite: Vec<&Controller> = order[..kept].iter().map(|&i| &drawn[i].1).collect();
            state.laws.refit(&elite, best.as_deref(), config.smoothing);
        }
        // Patience run out with escapes left: mix in the uniform law, or else grow a node around
        // the best controller, and go on.
        // The memoryless stage over: the laws widen to `nodes` nodes around its best. On sampled
        // values a memoryless policy better by noise alone turns up again and again, so the
        // stage lasts three times its patience at most.
        let memory = config.memory_of(restart);
        let widened = state.laws.nodes() == 1
            && memory.nodes > 1
            && self.start.is_none()
            && memory.staged
            && (iteration + 1 >= 3 * config.memoryless_patience
                || since_better(state, self.stage_noise().expect("the bar computed")) >= config.memoryless_patience);
        if widened {
            let (value, best, _) = state.best.as_ref().expect("a best controller after an iteration");
            // The bar is known in the stage.
            state.laws = self.after_stage(restart, *value, best).expect("the bar computed");
            state.memoryless = Some((*value, best.clone()));
        }
        let (injected, grown) = if !widened && state.since_progress >= config.patience {
            let from = state.best.as_ref().map(|b| &b.1).expect("a best controller after an iteration");
            self.escape(&mut state.laws, from, &mut state.injections, &mut state.growths)
        } else {
            (false, false)
        };
        if injected || grown || widened {
            state.since_progress = 0;
            best_threshold = f64::NEG_INFINITY;
        }
        state.best_threshold = (best_threshold > f64::NEG_INFINITY).then_some(best_threshold);
        ControllerIteration {
            restart,
            record: IterationRecord {
                iteration: *iteration,
                mean: mean(drawn.iter().map(|d| d.0)),
                best: drawn[top].0,
                elite_threshold: threshold,
                elite_mean: mean(order[..kept].iter().map(|&i| drawn[i].0)),
                seconds,
                successful: progress,
                env_steps: self.meter.steps(),
            },
            best_so_far: state.best.as_ref().map_or(f64::NAN, |b| b.0),
            concentration: state.laws.concentration(),
            evaluated: drawn.len(),
            episodes: self.episodes.swap(0, std::sync::atomic::Ordering::Relaxed),
            injected,
            grown,
            widened,
        }
    }
}

/// A controller with its value.
type Scored = (f64, Controller);

/// One iteration's controllers with their values, and the candidate for the best so far.
struct Draws {
    iteration: usize,
    /// The controllers valued, in draw order.
    drawn: Vec<(f64, Controller)>,
    /// What left some out, if anything: the time limit or the budget in steps.
    cut: Option<StopReason>,
    /// The groups the controllers were valued in (sampled values).
    groups: Option<Groups>,
    /// Indices into `drawn`, highest value first.
    order: Vec<usize>,
    /// (value, index in `drawn`); none where the budget in steps left no steps to select.
    candidate: Option<(f64, usize)>,
    /// Each decision row's best decision by the credit of its steps (sampled values with
    /// [`Credit::Steps`] on a world whose value sums its steps' rewards).
    best: Option<Vec<Option<u32>>>,
}
