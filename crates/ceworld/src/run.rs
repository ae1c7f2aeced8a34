//! A run of any optimiser, as every front end (the command line, the Python bindings) starts it:
//! the one place where an optimiser meets its run options, the progress line on stderr, the
//! checkpoints and what stops it, and where the defaults that depend on the world are resolved
//! (a controller search's kind of value). A front end turns its arguments into a config and
//! [`RunOptions`], then calls one function here.

use std::path::Path;

use crate::ce::controller::{ControllerConfig, ControllerOutcome, ValueKind, Valued, optimize_controller_with};
use serde_json::{Map, Value};

use crate::ce::random_search::RandomSearch;
use crate::ce::record::CeResult;
use crate::ce::resume::{Checkpoint, Checkpointing, Peek};
use crate::ce::stepped::{Stepped, SteppedKind, SteppedOutcome, run_stepped};
use crate::control::Flow;
use crate::episodes::Episodes;
use crate::error::{Error, Result};
use crate::policy::Hhmm;
use crate::policy::file::PolicyFile;
use crate::progress::{LiveLine, Progress, Step};
use crate::qlearn::{KnownState, QLearner, TrainOutcome};
use crate::settings::{Named, apply};

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
}

impl RunOptions<'_> {
    /// A quiet run without checkpoints that nothing stops.
    pub fn quiet() -> RunOptions<'static> {
        RunOptions { progress: false, checkpointing: None, stop: &|| Flow::Continue }
    }

    /// Runs `body` with the observer it gives its optimiser: the progress line of a run of
    /// `patience` and `restarts`, updated at every iteration, then [`RunOptions::stop`] asked.
    fn watch<S: Step, T>(
        &self,
        patience: usize,
        restarts: usize,
        body: impl FnOnce(&mut dyn FnMut(&S) -> Flow) -> Result<T>,
    ) -> Result<T> {
        let mut line = self.progress.then(|| Progress::new(patience, restarts, LiveLine::stderr()));
        let outcome = body(&mut |step| {
            if let Some(line) = &mut line {
                line.update(step);
            }
            (self.stop)()
        });
        if let Some(line) = line {
            line.finish();
        }
        outcome
    }
}

/// The cross-entropy method (model §3) on `world` from `initial` with `config`.
pub fn optimize<E: Episodes + ?Sized>(
    world: &E,
    initial: Hhmm,
    config: &crate::CeConfig,
    options: &RunOptions<'_>,
) -> Result<CeResult> {
    options.watch(config.patience, config.restarts, |observe| {
        crate::ce::optimize::optimize_with(world, initial, config, options.checkpointing, observe)
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

/// The cross-entropy method over deterministic controllers (model §8) of `world`, valued as
/// `world` says, with `config` (from [`controller_setup`]).
pub fn controller(world: Valued<'_>, config: &ControllerConfig, options: &RunOptions<'_>) -> Result<ControllerOutcome> {
    options.watch(config.patience, config.restarts, |observe| {
        optimize_controller_with(world, config, options.checkpointing, observe)
    })
}

/// Q-learning (model §5) of `learner` until `until` updates in all, checkpointed to `checkpoint`
/// every `every` seconds (and when it stops).
pub fn qlearn<W: KnownState>(
    learner: &mut QLearner<W>,
    until: u64,
    checkpoint: Option<&Path>,
    every: Option<f64>,
    options: &RunOptions<'_>,
) -> Result<TrainOutcome> {
    let mut line = options.progress.then(LiveLine::stderr);
    let outcome = learner.train(until, checkpoint, every, |p| {
        if let Some(line) = &mut line {
            line.update(p.line());
        }
        (options.stop)()
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
pub const OPTIMISERS: &[Optimiser] = &[Optimiser::of::<RandomSearch>()];

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
    let outcome =
        options.watch(rules.patience, 1, |observe| run_stepped::<O>(world, &config, options.checkpointing, observe))?;
    let file = outcome.to_file(world, O::NAME, &config);
    Ok((outcome, file))
}
