//! Where the optimiser's and the evaluation's episodes come from: a [`World`] run by the engine,
//! or a world that runs outside it and is stepped in lockstep batches
//! ([`outside`]). The optimiser, the evaluation and policy files see only this; one episode of
//! a world run by the engine is [`run`].

pub mod credit;
pub mod outside;
mod place;
pub mod run;
pub mod trace;

use rayon::prelude::*;
use serde_json::Value;

use crate::control::Interrupt;
use crate::error::Result;
use crate::policy::Hhmm;
use crate::policy::controller::Controller;
use crate::rng::{EngineRng, Purpose, stream, stream_key};
use crate::world::World;
use crate::world::pomdp::PomdpWorld;
use credit::StepCredit;
use run::{run_controller, run_controller_steps, run_recorded, run_with};

/// The random streams of a set of episodes: episode `k` draws from `(seed, purpose, iteration, k)`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Streams {
    /// The run's seed.
    pub seed: u64,
    /// What the episodes are for.
    pub purpose: Purpose,
    /// The optimiser's iteration (0 outside the optimiser).
    pub iteration: u64,
}

impl Streams {
    /// The generator of episode `k`.
    pub fn episode(self, k: usize) -> EngineRng {
        stream(self.seed, self.purpose, self.iteration, k as u64)
    }

    /// A 64-bit key for index `k` of these streams (see [`stream_key`]).
    pub fn key(self, k: u64) -> u64 {
        stream_key(self.seed, self.purpose, self.iteration, k)
    }
}

/// The sizes an episode source shares with a policy, and its horizon.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Shape {
    /// Number of observations `Y`.
    pub observations: usize,
    /// Number of decisions `D`.
    pub decisions: usize,
    /// Most steps of one episode `T`.
    pub horizon: usize,
}

/// The episodes of one call to [`Episodes::run`]: where their values go and, for the
/// optimiser, their records.
pub struct Batch<'a> {
    /// The episodes' values `V`, one per episode (their number is the batch's size).
    pub values: &'a mut [f64],
    /// Where given: each episode's record (`horizon · record_width` numbers, [`run_recorded`]'s
    /// layout) and the number of steps it ran.
    pub records: Option<(&'a mut [u16], &'a mut [u32])>,
}

/// A source of episodes of world × policy.
pub trait Episodes: Sync {
    /// Observations, decisions, horizon.
    fn shape(&self) -> Shape;
    /// The world's name and parameters, as stored in policy files and checkpoints (model §6).
    fn description(&self) -> Value;
    /// Runs the episodes `first..first + batch.values.len()` under `policy`, episode `k` drawing
    /// the policy's (and, for a world run by the engine, the world's) randomness from
    /// `streams.episode(k)`, on the current rayon pool; returns the world's steps they took
    /// (the sum of their lengths: what a budget in environment steps counts).
    fn run(&self, policy: &Hhmm, streams: Streams, first: usize, batch: Batch<'_>) -> Result<u64>;
    /// Runs episodes `0..episodes` of each of `controllers` (model §8), writing the value of
    /// episode `k` of controller `c` at `values[c·episodes + k]`, on the current rayon pool.
    /// Episode `k` of every controller draws the world's randomness from `streams.episode(k)`
    /// (a controller draws none): common random numbers, so that two controllers are compared
    /// on the same episodes as far as their decisions let the world's draws agree. Returns the
    /// world's steps they took.
    fn run_controllers(
        &self,
        controllers: &[Controller],
        streams: Streams,
        episodes: usize,
        values: &mut [f64],
    ) -> Result<u64>;
    /// Runs as [`Episodes::run_controllers`] and, where an episode's value is the discounted sum
    /// of its steps' rewards, adds each step's credit to `credit` ([`credit`]) and says so;
    /// elsewhere (by default) leaves `credit` as it is. Returns the world's steps and whether
    /// `credit` was added to.
    fn run_controllers_credited(
        &self,
        controllers: &[Controller],
        streams: Streams,
        episodes: usize,
        values: &mut [f64],
        credit: &mut StepCredit,
    ) -> Result<(u64, bool)> {
        let _ = credit;
        self.run_controllers(controllers, streams, episodes, values).map(|steps| (steps, false))
    }

    /// What may stop these episodes from outside, if anything: where a stop is asked, the runs
    /// return [`crate::Error::Interrupted`] (a world outside the engine between two steps, one
    /// run by it between two calls).
    fn interrupt(&self) -> Option<&Interrupt> {
        None
    }
    /// Episodes of one slice of an evaluation that an interrupt may cut: slices that start on a
    /// multiple of it give the episodes of the whole evaluation.
    fn slice(&self) -> usize {
        SLICE
    }
    /// Episodes the world runs together (a vector environment's size): runs of episodes that
    /// start on a multiple of it give the episodes of one run; 1 (the default) where each
    /// episode is its own. What a budget in steps cuts an iteration at ([`crate::ce::budget`]).
    fn batch(&self) -> usize {
        1
    }
    /// Where the episodes are sampled elsewhere (other processes, other machines): their
    /// records stay there and the elite's counts come from [`Remote::counts`]; such a source
    /// runs its episodes without records. `None` for episodes sampled here.
    fn remote(&self) -> Option<&dyn Remote> {
        None
    }
    /// The tabular world (model §7) these episodes are of, where they are run here by the
    /// engine from one ([`World::tabular`]): what exact values need. `None` by default.
    fn tabular(&self) -> Option<&PomdpWorld> {
        None
    }
    /// Whether an episode's value is the discounted sum of its steps' rewards, so that
    /// [`Episodes::run_controllers_credited`] gives each step (model §8's credit within episodes,
    /// model §10's model of every step): a world's that gives its discount ([`World::discount`]),
    /// one written outside without a score of its own. False by default.
    fn additive(&self) -> bool {
        false
    }
}

/// Episodes sampled elsewhere: what stays there (the episodes, their records) is asked for by
/// the episodes' numbers alone (model §3, the elite's counts).
pub trait Remote: Sync {
    /// The tabular world sampled there, as the driver holds it, if it is one: its controllers
    /// then have exact values ([`Remote::exact_values`], computed there) and a model start
    /// (built here, model §8). By default none.
    fn model(&self) -> Option<&PomdpWorld> {
        None
    }

    /// The sampled counts (laid out as `policy`'s flat tables) of episodes `episodes` of
    /// `streams` under `policy`: those that their records give, bit for bit
    /// ([`crate::ce::rerun::rerun_counts`] is how a worker takes them).
    fn counts(&self, policy: &Hhmm, streams: Streams, episodes: &[usize]) -> Result<Vec<u32>>;

    /// The exact values of `controllers` (model §8, to `tolerance`), as
    /// [`crate::ce::controller::ControllerValue`] computes them where the world is: a tabular
    /// world's; by default refused.
    fn exact_values(&self, controllers: &[Controller], tolerance: f64) -> Result<Vec<f64>> {
        let _ = (controllers, tolerance);
        Err(crate::Error::invalid("value", "\"exact\" for episodes sampled elsewhere of a world that is not tabular"))
    }
}

/// An answer a backend is still working on (the Python protocol `cehmm.backend.Pending`).
pub trait Pending {
    /// Waits at most `seconds`; whether the answer is ready.
    fn wait(&self, seconds: f64) -> Result<bool>;
    /// Gives up on the answer (what still runs for it is cancelled).
    fn cancel(&self) -> Result<()>;
}

/// How long [`wait_for`] waits for a pending answer before it checks for a stop again (seconds).
pub const WAIT: f64 = 0.05;

/// Waits for `pending` in slices of [`WAIT`] seconds; a stop asked meanwhile cancels it and is
/// returned.
pub fn wait_for(pending: &impl Pending, interrupt: &Interrupt) -> Result<()> {
    loop {
        if let Err(stop) = interrupt.check() {
            pending.cancel()?;
            return Err(stop);
        }
        if pending.wait(WAIT)? {
            return Ok(());
        }
    }
}

/// Episodes a world run by the engine runs in one slice of a long evaluation: the interrupt
/// is checked between slices (≈ 0.1 s of target tracking on one core).
pub const SLICE: usize = 1 << 14;

/// The episodes of `episodes`, stopped by `interrupt` (checked before each call, and between
/// slices of [`SLICE`] episodes of an evaluation): a world run by the engine made interruptible.
pub struct Interruptible<'a, E: ?Sized> {
    episodes: &'a E,
    interrupt: Interrupt,
}

impl<'a, E: Episodes + ?Sized> Interruptible<'a, E> {
    /// `episodes`, stopped by `interrupt`.
    pub fn new(episodes: &'a E, interrupt: Interrupt) -> Self {
        Interruptible { episodes, interrupt }
    }
}

impl<E: Episodes + ?Sized> Episodes for Interruptible<'_, E> {
    fn shape(&self) -> Shape {
        self.episodes.shape()
    }

    fn additive(&self) -> bool {
        self.episodes.additive()
    }

    fn description(&self) -> Value {
        self.episodes.description()
    }

    fn run(&self, policy: &Hhmm, streams: Streams, first: usize, batch: Batch<'_>) -> Result<u64> {
        if batch.records.is_some() {
            self.interrupt.check()?;
            return self.episodes.run(policy, streams, first, batch);
        }
        let mut steps = 0;
        for (k, values) in batch.values.chunks_mut(SLICE).enumerate() {
            self.interrupt.check()?;
            steps += self.episodes.run(policy, streams, first + k * SLICE, Batch { values, records: None })?;
        }
        Ok(steps)
    }

    fn run_controllers(
        &self,
        controllers: &[Controller],
        streams: Streams,
        episodes: usize,
        values: &mut [f64],
    ) -> Result<u64> {
        self.interrupt.check()?;
        self.episodes.run_controllers(controllers, streams, episodes, values)
    }

    fn run_controllers_credited(
        &self,
        controllers: &[Controller],
        streams: Streams,
        episodes: usize,
        values: &mut [f64],
        credit: &mut StepCredit,
    ) -> Result<(u64, bool)> {
        self.interrupt.check()?;
        self.episodes.run_controllers_credited(controllers, streams, episodes, values, credit)
    }

    fn interrupt(&self) -> Option<&Interrupt> {
        Some(&self.interrupt)
    }

    fn slice(&self) -> usize {
        self.episodes.slice()
    }

    fn batch(&self) -> usize {
        self.episodes.batch()
    }

    fn remote(&self) -> Option<&dyn Remote> {
        self.episodes.remote()
    }

    fn tabular(&self) -> Option<&PomdpWorld> {
        self.episodes.tabular()
    }
}

impl<W: World> Episodes for W {
    fn shape(&self) -> Shape {
        Shape { observations: self.n_observations(), decisions: self.n_decisions(), horizon: self.horizon() }
    }

    fn additive(&self) -> bool {
        self.discount().is_some()
    }

    fn description(&self) -> Value {
        self.to_json()
    }

    fn run(&self, policy: &Hhmm, streams: Streams, first: usize, batch: Batch<'_>) -> Result<u64> {
        let rng = |i: usize| streams.episode(first + i);
        let steps = match batch.records {
            Some((records, lengths)) => {
                let stride = self.horizon() * policy.layout().record_width();
                records
                    .par_chunks_mut(stride)
                    .zip(lengths.par_iter_mut())
                    .zip(batch.values.par_iter_mut())
                    .enumerate()
                    .map(|(i, ((record, length), value))| {
                        let (v, steps) = run_recorded(self, policy, &mut rng(i), record);
                        *value = v;
                        *length = steps as u32;
                        steps as u64
                    })
                    .sum()
            }
            None => batch
                .values
                .par_iter_mut()
                .enumerate()
                .map(|(i, value)| {
                    let mut steps = 0u64;
                    *value = run_with(self, policy, &mut rng(i), |_, _, _, _, _| steps += 1);
                    steps
                })
                .sum(),
        };
        Ok(steps)
    }

    fn run_controllers(
        &self,
        controllers: &[Controller],
        streams: Streams,
        episodes: usize,
        values: &mut [f64],
    ) -> Result<u64> {
        let steps = values
            .par_iter_mut()
            .with_min_len(8)
            .enumerate()
            .map(|(i, value)| {
                let (c, k) = (&controllers[i / episodes], i % episodes);
                let (v, steps) = run_controller(self, c, k as u64, &mut streams.episode(k));
                *value = v;
                steps as u64
            })
            .sum();
        Ok(steps)
    }

    /// Where the world gives its steps' rewards ([`World::discount`]) and `credit` keeps the
    /// steps (model §10), runs as [`Episodes::run_controllers`] and keeps them; elsewhere adds
    /// no credit.
    fn run_controllers_credited(
        &self,
        controllers: &[Controller],
        streams: Streams,
        episodes: usize,
        values: &mut [f64],
        credit: &mut StepCredit,
    ) -> Result<(u64, bool)> {
        let Some(gamma) = self.discount().filter(|_| credit.traces.is_some()) else {
            return self.run_controllers(controllers, streams, episodes, values).map(|steps| (steps, false));
        };
        let runs: Vec<(f64, Vec<(usize, f64)>)> = (0..values.len())
            .into_par_iter()
            .with_min_len(8)
            .map(|i| {
                let (c, k) = (&controllers[i / episodes], i % episodes);
                run_controller_steps(self, c, k as u64, &mut streams.episode(k), gamma)
            })
            .collect();
        let (n_obs, mut steps) = (self.n_observations(), 0);
        for (i, (value, kept)) in runs.into_iter().enumerate() {
            values[i] = value;
            steps += kept.len() as u64;
            let (c, k) = (i / episodes, i % episodes);
            credit.add(c, k as u64, &controllers[c], n_obs, kept.into_iter(), gamma, value);
        }
        Ok((steps, true))
    }

    fn tabular(&self) -> Option<&PomdpWorld> {
        World::tabular(self)
    }
}

/// Checks that the policy's observation and decision counts are the world's.
pub fn check_fits<E: Episodes + ?Sized>(world: &E, policy: &Hhmm) -> Result<()> {
    let shape = world.shape();
    policy.check_shape(shape.observations, shape.decisions)
}

#[cfg(test)]
mod tests {
    use std::cell::Cell;

    use super::*;

    /// Ready after `ready` waits; counts its waits and cancels.
    struct Counted {
        ready: usize,
        waits: Cell<usize>,
        cancels: Cell<usize>,
    }

    impl Pending for Counted {
        fn wait(&self, seconds: f64) -> Result<bool> {
            assert_eq!(seconds, WAIT);
            self.waits.set(self.waits.get() + 1);
            Ok(self.waits.get() >= self.ready)
        }

        fn cancel(&self) -> Result<()> {
            self.cancels.set(self.cancels.get() + 1);
            Ok(())
        }
    }

    #[test]
    fn a_pending_answer_is_waited_for_in_slices_and_cancelled_on_a_stop() {
        let pending = Counted { ready: 3, waits: Cell::new(0), cancels: Cell::new(0) };
        wait_for(&pending, &Interrupt::default()).unwrap();
        assert_eq!((pending.waits.get(), pending.cancels.get()), (3, 0));
        let (pending, stop) = (Counted { ready: 3, waits: Cell::new(0), cancels: Cell::new(0) }, Interrupt::default());
        stop.request();
        assert!(matches!(wait_for(&pending, &stop), Err(crate::Error::Interrupted)));
        assert_eq!((pending.waits.get(), pending.cancels.get()), (0, 1));
    }
}
