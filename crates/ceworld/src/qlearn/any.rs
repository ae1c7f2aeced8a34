//! Q-learning on any registered world that can run it (a [`KnownState`] world), its kind known
//! at run time: what the CLI and the Python bindings hold, so that neither names a world.
//!
//! Which worlds have a known state is read from the registry (capability `q_learning`, reached
//! through [`with_known_state!`](crate::with_known_state)): nothing here names a world but the
//! learners. Adding a world with a known state: one variant of [`AnyLearner`], its arm of
//! [`with_learner!`](crate::with_learner) and its `From` impl (worlds without one need nothing
//! here: they are refused by name).

use std::path::Path;

use serde_json::Value;

use super::{KnownState, QConfig, QLearner, Ties, WindowConfig, WindowReport, evaluate_windows, read_header};
use crate::error::{Error, Result};
use crate::policy::Hhmm;
use crate::world::World;
use crate::world::registry::AnyWorld;

/// A Q-learning run on any registered world with a known state.
pub enum AnyLearner {
    /// On the target-tracking world.
    TargetTracking(QLearner<crate::world::tracking::TargetTracking>),
}

impl From<QLearner<crate::world::tracking::TargetTracking>> for AnyLearner {
    fn from(learner: QLearner<crate::world::tracking::TargetTracking>) -> AnyLearner {
        AnyLearner::TargetTracking(learner)
    }
}

/// Runs `$body` with `$q` bound to the concrete [`QLearner`] inside an [`AnyLearner`].
#[macro_export]
macro_rules! with_learner {
    ($learner:expr, $q:ident => $body:expr) => {
        match $learner {
            $crate::qlearn::AnyLearner::TargetTracking($q) => $body,
        }
    };
}

/// The error for a world Q-learning cannot run on.
fn no_known_state(world: &AnyWorld) -> Error {
    Error::invalid(
        "world",
        format!("{} (Q-learning needs a world whose state it can index; {} has none)", world.to_json(), world.name()),
    )
}

impl AnyLearner {
    /// A fresh run with a zero table (refused when the world has no known state or the table
    /// would not fit in memory).
    pub fn new(world: AnyWorld, config: QConfig) -> Result<AnyLearner> {
        crate::with_known_state!(world, w => Ok(QLearner::new(w, config)?.into()), other => Err(no_known_state(&other)))
    }

    /// Reads a Q-table file, rebuilding its world from the header through the registry.
    pub fn load(path: impl AsRef<Path>) -> Result<AnyLearner> {
        let path = path.as_ref();
        let header = read_header(path)?;
        let world = AnyWorld::from_json(header.get("world").unwrap_or(&Value::Null)).map_err(|e| {
            Error::PolicyFormat { path: Some(path.to_path_buf()), message: format!("the header's world: {e}") }
        })?;
        crate::with_known_state!(world, w => Ok(QLearner::load(path, w)?.into()), other => Err(no_known_state(&other)))
    }

    /// Reads the run saved in `path` to continue it, checking that it was made in `world` with
    /// `config` (a resumed run keeps its settings).
    pub fn resume(path: impl AsRef<Path>, world: &AnyWorld, config: &QConfig) -> Result<AnyLearner> {
        let path = path.as_ref();
        let learner = AnyLearner::load(path)?;
        if &learner.world() != world {
            return Err(Error::Mismatch(format!(
                "the checkpoint {} was made in the world {}, not {}",
                path.display(),
                learner.world().to_json(),
                world.to_json()
            )));
        }
        let made_with = crate::with_learner!(&learner, q => q.config().clone());
        if &made_with != config {
            return Err(Error::invalid(
                "resume",
                format!("the checkpoint was made with {made_with:?}, not {config:?}: a resumed run keeps its settings"),
            ));
        }
        Ok(learner)
    }

    /// The run's world, as a registered world.
    pub fn world(&self) -> AnyWorld {
        crate::with_learner!(self, q => AnyWorld::from(q.world().clone()))
    }

    /// `Q(state, ·)`; a state past the table is refused, naming its size.
    pub fn row(&self, state: usize) -> Result<Vec<f32>> {
        crate::with_learner!(self, q => {
            let t = q.table();
            if state >= t.n_states() {
                return Err(Error::invalid("state", format!("{state} (expected < {})", t.n_states())));
            }
            Ok(t.row(state).to_vec())
        })
    }

    /// The known state (the table's row) of the world state `state` (as the world describes
    /// it) seen through observation `y`.
    pub fn state_index(&self, state: &[i64], y: usize) -> Result<usize> {
        crate::with_learner!(self, q => {
            let world = q.world();
            if y >= world.n_observations() {
                return Err(Error::invalid("y", format!("{y} (expected < {})", world.n_observations())));
            }
            let state = world.restore(state).map_err(|e| Error::invalid("state", e.to_string()))?;
            Ok(world.known_state(&state, y))
        })
    }

    /// The greedy policy of the table (ties broken by `ties`, or as in learning) evaluated on
    /// windows of `world`, which must be of the learner's kind and size.
    pub fn evaluate_windows(
        &self,
        world: &AnyWorld,
        ties: Option<Ties>,
        config: &WindowConfig,
        seed: u64,
    ) -> Result<WindowReport> {
        crate::with_learner!(self, q => greedy_windows(q, world, ties, config, seed))
    }
}

/// The greedy policy of `learner`'s table evaluated on windows of `world`, which must be of the
/// learner's kind (see [`AnyLearner::evaluate_windows`]).
fn greedy_windows<W: KnownState + Clone + 'static>(
    learner: &QLearner<W>,
    world: &AnyWorld,
    ties: Option<Ties>,
    config: &WindowConfig,
    seed: u64,
) -> Result<WindowReport>
where
    AnyWorld: From<W>,
{
    let Some(w) = world.downcast_ref::<W>() else {
        return Err(Error::Mismatch(format!(
            "the Q table was learnt in a {} world, not {}",
            AnyWorld::from(learner.world().clone()).name(),
            world.name()
        )));
    };
    let greedy = super::Greedy { table: learner.table(), ties: ties.unwrap_or(learner.config().ties) };
    evaluate_windows(w, &greedy, config, seed)
}

/// An HHMM policy evaluated on windows of a continuing run of any registered world that can run
/// as one ([`super::ContinuingWorld`]).
pub fn evaluate_policy_windows(
    world: &AnyWorld,
    policy: &Hhmm,
    config: &WindowConfig,
    seed: u64,
) -> Result<WindowReport> {
    crate::with_known_state!(world, w => evaluate_windows(w, policy, config, seed), other => Err(Error::invalid(
        "world",
        format!("{} (the {} world cannot run as a continuing task)", other.to_json(), other.name()),
    )))
}
