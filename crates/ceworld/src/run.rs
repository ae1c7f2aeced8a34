//! A run of any optimiser, as every front end (the command line, the Python bindings) starts it:
//! the one place where an optimiser meets its run options, the progress line on stderr, the
//! checkpoints, what stops it and the caller's per-iteration callback, and where the defaults
//! that depend on the world are resolved (a controller search's kind of value). A front end
//! turns its arguments into a config and [`RunOptions`], then calls one function here.

use std::cell::OnceCell;
use std::path::Path;

use crate::ce::controller::{ControllerConfig, ControllerOutcome, ValueKind, Valued, optimize_controller_observed};
use serde::Serialize;
use serde_json::{Map, Value, json};

use crate::ce::random_search::RandomSearch;
use crate::ce::record::CeResult;
use crate::ce::resume::{Checkpoint, Checkpointing, Peek};
use crate::ce::stepped::{Stepped, SteppedKind, SteppedOutcome, run_stepped_observed};
use crate::ce::stopping::Observed;
use crate::control::Flow;
use crate::episodes::Episodes;
use crate::error::{Error, Result};
use crate::policy::Hhmm;
use crate::policy::file::PolicyFile;
use crate::progress::{LiveLine, Progress, Step};
use crate::qlearn::{KnownState, QLearner, TrainOutcome};
use crate::settings::{Named, Settings, apply};

/// How a run is watched, whatever the optimiser: its progress, its checkpoints and what stops
/// it.
pub struct RunOptions<'a> {
    /// Show a progress line on stderr ([`crate::progress`]).
    pub progress: bool,
    /// Save the run's whole state, and resume from it.
    pub checkpointing: Option<&'a Checkpointing>,
    /// Asked after every iteration: [`Flow::Stop`] stops the run, which returns what it has,
    /// marked interrupted (a signal, Ctrl-C).
    pub stop: &'a (dyn Fn() -> Flow + Sync),
    /// Called after every iteration, after `stop`, with the iteration's record and the best
    /// policy so far ([`Iteration`]): [`Flow::Finish`] stops the run as a stopping rule does,
    /// for [`crate::StopReason::Callback`] (every restart with it); [`Flow::Stop`] as `stop` does.
    pub callback: Option<Callback<'a>>,
}

/// A run's per-iteration callback ([`RunOptions::callback`]).
pub type Callback<'a> = &'a (dyn Fn(&Iteration<'_>) -> Flow + Sync);

/// One iteration as a run's callback sees it.
pub struct Iteration<'a> {
    /// The iteration's record by name: the fields of the optimiser's history entry (one row of
    /// its history), and `score`, what the optimiser chooses its result by, as of this
    /// iteration ([`Step::score`]: the iteration's mean for the CE method, the best value so
    /// far for the controller search). Q-learning: its progress after a chunk of updates
    /// ([`crate::qlearn::QProgress`]) and `iteration`, the chunk's number in this call (from 0).
    /// Every optimiser's has `run` too: the run among the restarts it belongs to (from 0, kept
    /// across a resume; 0 without restarts), and `step`: the iteration's number counted on
    /// across the call's runs (kept across a resume; Q-learning's chunk).
    pub record: &'a Map<String, Value>,
    /// Whether the best policy may differ from the one of the callback's last call (true at
    /// the first): a caller that keeps it asks [`Iteration::best_policy`] again only then.
    pub best_changed: bool,
    best: &'a dyn Fn() -> Result<Option<PolicyFile>>,
}

impl Iteration<'_> {
    /// The best policy so far (of the current run where there are restarts), as a file whose
    /// provenance holds the run's settings and `"policy": "best so far"`; `None` where the
    /// optimiser has no policy (Q-learning). Made when asked: a copy of its tables.
    pub fn best_policy(&self) -> Result<Option<PolicyFile>> {
        (self.best)()
    }
}

impl RunOptions<'_> {
    /// A quiet run without checkpoints or callback that nothing stops.
    pub fn quiet() -> RunOptions<'static> {
        RunOptions { progress: false, checkpointing: None, stop: &|| Flow::Continue, callback: None }
    }

    /// Runs `body` with the observer it gives its optimiser: the progress line of a run of
    /// `patience` and `restarts`, updated at every iteration, then [`RunOptions::stop`] asked and
    /// [`RunOptions::callback`] called (its best policy a file made by `to_file`).
    fn watch<S: Step + Serialize, T>(
        &self,
        patience: usize,
        restarts: usize,
        to_file: &dyn Fn(Hhmm) -> PolicyFile,
        body: impl FnOnce(&mut dyn FnMut(&Observed<'_, S>) -> Flow) -> Result<T>,
    ) -> Result<T> {
        let mut line = self.progress.then(|| Progress::new(patience, restarts, LiveLine::stderr()));
        let mut first = true;
        let outcome = body(&mut |seen| {
            if let Some(line) = &mut line {
                line.update(seen.step);
            }
            let record = || {
                let mut record = fields(seen.step);
                record.insert("score".into(), json!(seen.step.score()));
                let own = record.get("iteration").and_then(Value::as_u64).unwrap_or(0);
                (record, seen.run, seen.earlier as u64 + own)
            };
            let best_changed = std::mem::take(&mut first) || seen.step.record().successful;
            self.ask(record, best_changed, &|| (seen.best)().map(|policy| Some(to_file(policy))))
        });
        if let Some(line) = line {
            line.finish();
        }
        outcome
    }

    /// What stops the run after an iteration: [`RunOptions::stop`], then the callback, called
    /// with the iteration's `record` by name (made only where there is a callback: its fields,
    /// its run and its step, which every optimiser's record has) and its best policy.
    fn ask(
        &self,
        record: impl FnOnce() -> (Map<String, Value>, usize, u64),
        best_changed: bool,
        best: &dyn Fn() -> Result<Option<PolicyFile>>,
    ) -> Flow {
        let asked = (self.stop)();
        let called = self.callback.map_or(Flow::Continue, |callback| {
            let (mut record, run, step) = record();
            record.insert("run".into(), json!(run));
            record.insert("step".into(), json!(step));
            callback(&Iteration { record: &record, best_changed, best })
        });
        asked.and(called)
    }
}

/// A record's fields by name (none where it is not a JSON object).
fn fields<T: Serialize>(record: &T) -> Map<String, Value> {
    match serde_json::to_value(record) {
        Ok(Value::Object(map)) => map,
        _ => Map::new(),
    }
}

/// How a run's best policy so far becomes a file for its callback: on `world`, with
/// `provenance` (the run's settings) and `"policy": "best so far"`; the world's description is
/// made once.
fn best_so_far<E: Episodes + ?Sized>(
    world: &E,
    mut provenance: Map<String, Value>,
) -> impl Fn(Hhmm) -> PolicyFile + '_ {
    provenance.insert("policy".into(), json!("best so far"));
    provenance.insert("version".into(), json!(crate::VERSION));
    let description = OnceCell::new();
    move |policy| PolicyFile {
        policy,
        world: description.get_or_init(|| world.description()).clone(),
        provenance: Value::Object(provenance.clone()),
    }
}

/// The cross-entropy method (model §3) on `world` from `initial` with `config`.
pub fn optimize<E: Episodes + ?Sized>(
    world: &E,
    initial: Hhmm,
    config: &crate::CeConfig,
    options: &RunOptions<'_>,
) -> Result<CeResult> {
    let mut provenance = config.provenance();
    // SPEC §6 names the smoothing `alpha` (as the result's file does).
    provenance.insert("alpha".into(), json!(config.smoothing));
    options.watch(config.patience, config.restarts, &best_so_far(world, provenance), |observe| {
        crate::ce::optimize::optimize_observed(world, initial, config, options.checkpointing, observe)
    })
}

/// How a controller search on `world` values its controllers (`kind`, or the world's default:
/// [`Valued::of`]) and its settings: the defaults of that kind of value, then `settings`.
pub fn controller_setup(
    world: &dyn Episodes,
    kind: Option<ValueKind>,
    settings: impl FnOnce(&mut ControllerConfig) -> Result<()>,
) -> Result<(Valued<'_>, ControllerConfig)> {
    let valued = Valued::of(world, kind)?;
    let mut config = ControllerConfig::defaults_for(valued.kind());
    settings(&mut config)?;
    config.validate()?;
    Ok((valued, config))
}

/// What a controller search of a world runs (`cehmm.optimize_controller`'s `search`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Search {
    /// The cross-entropy method over whole controllers (model §8).
    Ce,
    /// The search of memories on the model of every step taken (model §10: `model-search`).
    Model,
}

impl Search {
    /// `"ce"` or `"model"`.
    pub fn as_str(self) -> &'static str {
        match self {
            Search::Ce => "ce",
            Search::Model => "model",
        }
    }

    /// The search named `name`, or an error naming both.
    pub fn parse(name: &str) -> Result<Search> {
        match name {
            "ce" => Ok(Search::Ce),
            "model" => Ok(Search::Model),
            other => Err(Error::invalid("search", format!("{other:?} (expected \"ce\" or \"model\")"))),
        }
    }

    /// The search of `world` whose controllers are valued as `kind` says: the model search on
    /// sampled values where the world's value is the sum of its steps' rewards
    /// ([`Episodes::additive`]: what it learns from), which learns from every step it takes
    /// where the CE over controllers values each candidate on episodes of its own (model §10: at
    /// 50,000 steps of the memory games of `POPGym` it is at least `RecurrentPPO`'s value, the CE
    /// over controllers at the best memoryless policy's); elsewhere (exact values, a world scored
    /// as a whole, the paper's target tracking among them) the CE over controllers.
    pub fn default_for(world: &dyn Episodes, kind: ValueKind) -> Search {
        if kind == ValueKind::Sampled && world.additive() { Search::Model } else { Search::Ce }
    }

    /// The search a controller search of `world` valued as `kind` says (or as the world's
    /// default) runs: `search`, or [`Search::default_for`]. The model search runs on sampled
    /// values of a world that gives its steps' rewards only.
    pub fn resolve(world: &dyn Episodes, kind: Option<ValueKind>, search: Option<Search>) -> Result<Search> {
        let kind = Valued::of(world, kind)?.kind();
        match search.unwrap_or(Search::default_for(world, kind)) {
            Search::Model if kind == ValueKind::Exact => {
                Err(Error::invalid("search", "\"model\" on exact values (expected \"ce\", or value=\"sampled\")"))
            }
            Search::Model if !world.additive() => Err(Error::invalid(
                "search",
                "\"model\" on a world whose value is not the (discounted) sum of its steps' rewards (expected \
                 \"ce\": the model search learns from each step's reward)",
            )),
            search => Ok(search),
        }
    }
}

/// The model search (model §10) as a controller search runs it: with `settings` by name, each
/// one given `None` ([`crate::settings::Given::Nothing`]) left at the model search's default, and
/// a setting of the CE over controllers alone refused by its name.
pub fn model_search(
    world: &dyn Episodes,
    settings: &[Named],
    options: &RunOptions<'_>,
) -> Result<(SteppedOutcome, PolicyFile)> {
    let optimiser = optimiser(crate::ce::controller::model_search::ModelSearch::NAME)?;
    let own = (optimiser.defaults)();
    let mut given = Vec::new();
    for s in settings.iter().filter(|s| s.value != crate::settings::Given::Nothing) {
        if !own.contains_key(&s.name) {
            let why =
                format!("{} (a setting of search=\"ce\", the CE over controllers, not of search=\"model\")", s.shown);
            return Err(Error::invalid(&s.name, why));
        }
        given.push(s.clone());
    }
    (optimiser.run)(world, &given, options)
}

/// The cross-entropy method over deterministic controllers (model §8) of `world`, valued as
/// `world` says, with `config` (from [`controller_setup`]).
pub fn controller(world: Valued<'_>, config: &ControllerConfig, options: &RunOptions<'_>) -> Result<ControllerOutcome> {
    let mut provenance = config.provenance();
    provenance.insert("method".into(), json!("controller-ce"));
    provenance.insert("value".into(), json!(world.kind().as_str()));
    options.watch(config.patience, config.restarts, &best_so_far(world.episodes(), provenance), |observe| {
        optimize_controller_observed(world, config, options.checkpointing, observe)
    })
}

/// Q-learning (model §5) of `learner` until `until` updates in all, checkpointed to `checkpoint`
/// every `every` seconds (and when it stops); the options' stop and callback are asked after
/// every chunk of updates (its callback has no best policy).
pub fn qlearn<W: KnownState>(
    learner: &mut QLearner<W>,
    until: u64,
    checkpoint: Option<&Path>,
    every: Option<f64>,
    options: &RunOptions<'_>,
) -> Result<TrainOutcome> {
    let mut line = options.progress.then(LiveLine::stderr);
    let mut chunk = 0usize;
    let outcome = learner.train(until, checkpoint, every, |p| {
        if let Some(line) = &mut line {
            line.update(p.line());
        }
        let record = || {
            let mut record = fields(p);
            record.insert("iteration".into(), json!(chunk));
            (record, 0, chunk as u64)
        };
        // Q-learning has no policy while it learns.
        let flow = options.ask(record, chunk == 0, &|| Ok(None));
        chunk += 1;
        flow
    });
    if let Some(line) = line {
        line.finish();
    }
    outcome
}

/// How [`Optimiser::run`] runs one: on a world, with settings by name, as the options ask; its
/// outcome and the outcome as a policy file.
pub type RunNamed = fn(&dyn Episodes, &[Named], &RunOptions<'_>) -> Result<(SteppedOutcome, PolicyFile)>;

/// An optimiser given by its iteration step ([`Stepped`]), as every front end reaches it: by
/// name, its settings by name.
pub struct Optimiser {
    /// Its name (`ceworld run NAME`, `cehmm.run(NAME, ...)`).
    pub name: &'static str,
    /// Every setting with its default, as a JSON object.
    pub defaults: fn() -> Map<String, Value>,
    /// Runs it on a world with settings by name (over the defaults), as `options` ask: its
    /// outcome and the outcome as a policy file.
    pub run: RunNamed,
    /// What a checkpoint of it says of itself ([`Checkpoint::peek`]).
    pub peek: fn(&Path) -> Result<Peek>,
}

impl Optimiser {
    /// The entry of the stepped optimiser `O`.
    pub const fn of<O: Stepped>() -> Optimiser {
        Optimiser {
            name: O::NAME,
            defaults: defaults::<O>,
            run: run_named::<O>,
            peek: Checkpoint::<SteppedKind<O>>::peek,
        }
    }
}

/// Every optimiser given by its step. Adding one: its file (config, state, [`Stepped`] impl)
/// and one line here.
pub const OPTIMISERS: &[Optimiser] =
    &[Optimiser::of::<RandomSearch>(), Optimiser::of::<crate::ce::controller::model_search::ModelSearch>()];

/// The optimiser `name`, or an error listing those there are.
pub fn optimiser(name: &str) -> Result<&'static Optimiser> {
    OPTIMISERS.iter().find(|o| o.name == name).ok_or_else(|| {
        let names: Vec<&str> = OPTIMISERS.iter().map(|o| o.name).collect();
        Error::invalid("optimiser", format!("{name:?} (expected one of {names:?})"))
    })
}

fn defaults<O: Stepped>() -> Map<String, Value> {
    match serde_json::to_value(O::Config::default()) {
        Ok(Value::Object(map)) => map,
        _ => Map::new(),
    }
}

fn run_named<O: Stepped>(
    world: &dyn Episodes,
    settings: &[Named],
    options: &RunOptions<'_>,
) -> Result<(SteppedOutcome, PolicyFile)> {
    let mut config = O::Config::default();
    apply(&mut config, settings)?;
    // `run_stepped` validates it before it starts.
    let rules = O::rules(&config);
    let mut provenance = config.provenance();
    provenance.insert("method".into(), json!(O::NAME));
    let to_file = best_so_far(world, provenance);
    let outcome = options.watch(rules.patience, 1, &to_file, |observe| {
        run_stepped_observed::<O>(world, &config, options.checkpointing, observe)
    })?;
    let file = outcome.to_file(world, O::NAME, &config);
    Ok((outcome, file))
}

#[cfg(test)]
mod tests {
    use std::sync::Mutex;

    use super::*;
    use crate::ce::stopping::StopReason;
    use crate::world::pomdp::PomdpWorld;
    use crate::{CeConfig, Checkpointing, QConfig, TargetTracking, random_policy};

    /// What a callback saw: each record, whether the best changed, and the best policy then.
    type Seen = Mutex<Vec<(Map<String, Value>, bool, Option<PolicyFile>)>>;

    /// A callback that keeps what it sees and answers `flow` at the iteration `at` (by count).
    fn keeping(seen: &Seen, at: usize, flow: Flow) -> impl Fn(&Iteration<'_>) -> Flow + Sync + '_ {
        move |it: &Iteration<'_>| {
            let mut seen = seen.lock().unwrap();
            seen.push((it.record.clone(), it.best_changed, it.best_policy().unwrap()));
            if seen.len() == at + 1 { flow } else { Flow::Continue }
        }
    }

    fn options<'a>(callback: Callback<'a>, stop: &'a (dyn Fn() -> Flow + Sync)) -> RunOptions<'a> {
        RunOptions { progress: false, checkpointing: None, stop, callback: Some(callback) }
    }

    fn ce(max_iterations: Option<usize>, restarts: usize) -> CeConfig {
        CeConfig { samples: 100, rho: 0.2, max_iterations, eval_episodes: 50, seed: 3, restarts, ..CeConfig::default() }
    }

    #[test]
    fn a_callback_that_finishes_at_iteration_k_is_max_iterations_k_and_sees_every_record() {
        let world = TargetTracking::new(1).unwrap();
        let initial = random_policy(&world, &[3], 5).unwrap();
        let whole = optimize(&world, initial.clone(), &ce(Some(3), 1), &RunOptions::quiet()).unwrap();
        let seen = Seen::default();
        let callback = keeping(&seen, 2, Flow::Finish);
        let cut = optimize(&world, initial, &ce(None, 1), &options(&callback, &|| Flow::Continue)).unwrap();
        assert_eq!((whole.stop, cut.stop), (StopReason::MaxIterations, StopReason::Callback));
        assert!(!cut.interrupted());
        assert_eq!(cut.policy, whole.policy);
        assert_eq!(cut.last_policy, whole.last_policy);
        let timeless =
            |r: &CeResult| r.history.iter().map(|h| (h.mean, h.best, h.elite_mean, h.successful)).collect::<Vec<_>>();
        assert_eq!(timeless(&cut), timeless(&whole));
        assert_eq!(cut.evaluation, whole.evaluation, "evaluated in full, as after a stopping rule");
        let seen = std::mem::take(&mut *seen.lock().unwrap());
        assert_eq!(seen.len(), 3);
        for (k, (record, changed, best)) in seen.iter().enumerate() {
            let h = &whole.history[k];
            assert_eq!(record["iteration"], json!(k));
            assert_eq!((record["mean"].as_f64(), record["score"].as_f64()), (Some(h.mean), Some(h.mean)));
            for key in ["best", "elite_threshold", "elite_mean", "seconds", "successful"] {
                assert!(record.contains_key(key), "{key} in {record:?}");
            }
            assert_eq!(*changed, k == 0 || h.successful);
            let best = best.as_ref().expect("the CE method has a best policy");
            assert_eq!(best.provenance["policy"], "best so far");
            assert_eq!(best.provenance["alpha"], json!(ce(None, 1).smoothing));
        }
        assert_eq!(seen[2].2.as_ref().unwrap().policy, whole.policy, "the best so far at the end is the result's");
    }

    #[test]
    fn a_finish_ends_every_restart_and_a_stop_wins_over_it() {
        let world = TargetTracking::new(1).unwrap();
        let initial = random_policy(&world, &[3], 5).unwrap();
        let seen = Seen::default();
        let callback = keeping(&seen, 1, Flow::Finish);
        let cut = optimize(&world, initial.clone(), &ce(Some(4), 3), &options(&callback, &|| Flow::Continue)).unwrap();
        assert_eq!(cut.stop, StopReason::Callback);
        assert_eq!((cut.history.len(), cut.restart_scores.len()), (2, 1), "no later restart starts");
        let seen = Seen::default();
        let callback = keeping(&seen, 0, Flow::Finish);
        let stopped = optimize(&world, initial, &ce(Some(4), 1), &options(&callback, &|| Flow::Stop)).unwrap();
        assert_eq!((stopped.stop, stopped.history.len()), (StopReason::Interrupted, 1));
    }

    #[test]
    fn every_record_names_its_run_and_its_step_across_runs_and_a_resume() {
        let world = TargetTracking::new(1).unwrap();
        let initial = random_policy(&world, &[3], 5).unwrap();
        let counts = |seen: &Seen| -> Vec<(u64, u64, u64)> {
            let count = |r: &Map<String, Value>, k: &str| r[k].as_u64().unwrap();
            seen.lock()
                .unwrap()
                .iter()
                .map(|(r, ..)| (count(r, "run"), count(r, "iteration"), count(r, "step")))
                .collect()
        };
        let whole = Seen::default();
        let callback = keeping(&whole, 1000, Flow::Continue);
        optimize(&world, initial.clone(), &ce(Some(2), 3), &options(&callback, &|| Flow::Continue)).unwrap();
        let expected = [(0, 0, 0), (0, 1, 1), (1, 0, 2), (1, 1, 3), (2, 0, 4), (2, 1, 5)];
        assert_eq!(counts(&whole), expected);
        // Stopped in the second run, then resumed: the records go on with the same numbers.
        let dir = std::env::temp_dir().join(format!("ceworld-run-steps-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let checkpointing =
            Checkpointing { path: dir.join("steps.ckpt"), every: 1e9, resume: true, outputs: Vec::new() };
        let seen = Seen::default();
        let callback = keeping(&seen, 2, Flow::Stop);
        let with = |callback| RunOptions {
            progress: false,
            checkpointing: Some(&checkpointing),
            stop: &|| Flow::Continue,
            callback: Some(callback),
        };
        let cut = optimize(&world, initial.clone(), &ce(Some(2), 3), &with(&callback)).unwrap();
        assert_eq!(cut.stop, StopReason::Interrupted);
        let callback = keeping(&seen, 1000, Flow::Continue);
        optimize(&world, initial, &ce(Some(2), 3), &with(&callback)).unwrap();
        assert_eq!(counts(&seen), expected);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn the_controller_search_and_a_stepped_optimiser_finish_as_their_callback_asks() {
        let file = format!("{}/../../data/pomdp/tiger.95.POMDP", env!("CARGO_MANIFEST_DIR"));
        let world = PomdpWorld::from_file(file, 20, None).unwrap();
        let settings = |c: &mut ControllerConfig| {
            *c = ControllerConfig { nodes: 3, samples: 200, model_nodes: 0, ..c.clone() };
            Ok(())
        };
        let (valued, config) = controller_setup(&world, None, settings).unwrap();
        let seen = Seen::default();
        let callback = keeping(&seen, 1, Flow::Finish);
        let cut = controller(valued, &config, &options(&callback, &|| Flow::Continue)).unwrap();
        let whole = controller(valued, &ControllerConfig { max_iterations: Some(2), ..config }, &RunOptions::quiet());
        let whole = whole.unwrap();
        assert_eq!((cut.stop, whole.stop), (StopReason::Callback, StopReason::MaxIterations));
        assert_eq!((cut.policy == whole.policy, cut.value, cut.history.len()), (true, whole.value, 2));
        let seen = std::mem::take(&mut *seen.lock().unwrap());
        let (record, _, best) = &seen[1];
        assert_eq!((record["restart"].as_u64(), record["score"].as_f64()), (Some(0), Some(cut.history[1].best_so_far)));
        assert_eq!(best.as_ref().unwrap().policy, cut.policy);
        assert_eq!(best.as_ref().unwrap().provenance["method"], "controller-ce");

        let seen = Seen::default();
        let callback = keeping(&seen, 2, Flow::Finish);
        let settings = [Named { name: "samples".into(), shown: "20".into(), value: crate::settings::Given::Int(20) }];
        let (outcome, _) =
            (optimiser("random-search").unwrap().run)(&world, &settings, &options(&callback, &|| Flow::Continue))
                .unwrap();
        assert_eq!((outcome.stop, outcome.history.len()), (StopReason::Callback, 3));
        let seen = std::mem::take(&mut *seen.lock().unwrap());
        assert_eq!(seen[2].2.as_ref().unwrap().policy, outcome.policy);
        assert_eq!(seen[2].2.as_ref().unwrap().provenance["method"], "random-search");
    }

    #[test]
    fn q_learning_finishes_after_the_chunk_its_callback_stops() {
        let mut learner = QLearner::new(crate::qlearn::tests::small_world(), QConfig::default()).unwrap();
        let seen = Seen::default();
        let callback = keeping(&seen, 0, Flow::Finish);
        let outcome =
            qlearn(&mut learner, 3 * crate::qlearn::CHUNK, None, None, &options(&callback, &|| Flow::Continue))
                .unwrap();
        assert_eq!(
            (outcome.updates, outcome.stop, outcome.interrupted),
            (crate::qlearn::CHUNK, Some(StopReason::Callback), false)
        );
        let seen = std::mem::take(&mut *seen.lock().unwrap());
        let (record, changed, best) = &seen[0];
        assert_eq!((record["iteration"].as_u64(), record["updates"].as_u64()), (Some(0), Some(crate::qlearn::CHUNK)));
        assert!(*changed && best.is_none(), "Q-learning has no policy to show");
    }
}
