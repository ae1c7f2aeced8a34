//! Worlds that run outside the engine (written in Python, Gymnasium environments), stepped in
//! lockstep batches: the world's code is called once per time step for a whole batch of
//! episodes, the policy's side stays in the engine (parallel, one random stream per episode),
//! and an episode may end before the horizon (model §1).
//!
//! Batches are aligned on the episode index: batch `c` holds the episodes
//! `c·B .. (c+1)·B` of a stream (`B` = [`BatchWorld::max_batch`]) and the world's own seed for
//! it is drawn from (seed, purpose, iteration, c), so that a slice of an evaluation that starts
//! and ends on multiples of `B` gives the episodes of the whole evaluation.

use std::sync::Mutex;

use rayon::prelude::*;
use serde_json::Value;

use crate::control::Interrupt;
use crate::episodes::check_fits;
use crate::episodes::credit::StepCredit;
use crate::episodes::place::{Place, label};
use crate::episodes::run::Rollout;
use crate::episodes::{Batch, Episodes, Shape, Streams};
use crate::error::{Error, Result};
use crate::policy::Hhmm;
use crate::policy::controller::{Controller, Walk};
use crate::rng::{EngineRng, Purpose, stream_key};

/// The `"name"` of a world outside the engine in policy files and checkpoints: the engine
/// records it but cannot rebuild it.
pub const NAME: &str = crate::world::registry::OUTSIDE;

/// The longest episode of a world outside the engine (as the engine's own worlds).
pub const MAX_HORIZON: usize = 1_000_000;

/// Where one step of a batch writes what the world returned.
pub struct StepOut<'a> {
    /// The next observation of each episode.
    pub observations: &'a mut [i64],
    /// The reward of the step.
    pub rewards: &'a mut [f64],
    /// Whether the episode ended with this step.
    pub done: &'a mut [bool],
}

/// One finished episode, as the world's score sees it.
pub struct Recorded<'a> {
    /// Its record: `[y, d, m_1, ..., m_Λ]` per step.
    pub record: &'a [u16],
    /// Numbers per step of `record`.
    pub width: usize,
    /// The reward of each step.
    pub rewards: &'a [f64],
}

impl Recorded<'_> {
    /// The observations `y_1..y_n`.
    pub fn observations(&self) -> impl Iterator<Item = usize> + Clone + '_ {
        self.record.chunks_exact(self.width).map(|s| usize::from(s[0]))
    }

    /// The decisions `d_1..d_n`.
    pub fn decisions(&self) -> impl Iterator<Item = usize> + '_ {
        self.record.chunks_exact(self.width).map(|s| usize::from(s[1]))
    }
}

/// `r_1 + γ r_2 + γ² r_3 + ...`, summed in step order.
pub fn discounted(rewards: &[f64], gamma: f64) -> f64 {
    let (mut total, mut factor) = (0.0, 1.0);
    for r in rewards {
        total += factor * r;
        factor *= gamma;
    }
    total
}

/// What policy files record of a world written outside the engine: what its author gave
/// (`given`), with its name and shape.
pub fn describe(given: serde_json::Map<String, Value>, shape: Shape) -> Value {
    let mut map = given;
    map.insert("name".into(), Value::from(NAME));
    for (key, value) in
        [("observations", shape.observations), ("decisions", shape.decisions), ("horizon", shape.horizon)]
    {
        map.insert(key.into(), Value::from(value));
    }
    Value::Object(map)
}

/// A world that steps a batch of episodes at once, in lockstep.
pub trait BatchWorld: Send {
    /// Observations, decisions, most steps per episode.
    fn shape(&self) -> Shape;
    /// `{"name": "outside", ...}`: what policy files and checkpoints record of it.
    fn description(&self) -> Value;
    /// The most episodes one batch may hold (1: one episode at a time).
    fn max_batch(&self) -> usize;
    /// Starts `observations.len()` episodes, the world's randomness drawn from `seed`, writing
    /// their first observations.
    fn reset(&mut self, seed: u64, observations: &mut [i64]) -> Result<()>;
    /// Steps every episode of the batch with its decision (0 for the episodes that have ended,
    /// whose outputs are ignored).
    fn step(&mut self, decisions: &[i64], out: StepOut<'_>) -> Result<()>;
    /// Runs `f`, which steps one batch of episodes, on the current thread: a world whose calls
    /// cost much to enter from a fresh thread (Python's) prepares the thread once here.
    fn on_thread<R: Send>(f: impl FnOnce() -> R + Send) -> R
    where
        Self: Sized,
    {
        f()
    }
    /// The discount of the default [`BatchWorld::score`] (1: none).
    fn discount(&self) -> f64 {
        1.0
    }
    /// Whether [`BatchWorld::score`] is the default one, the discounted sum of the steps'
    /// rewards: what credit within episodes needs ([`crate::episodes::credit`]).
    fn additive(&self) -> bool {
        true
    }
    /// The value `V` of a finished episode: by default the sum of its rewards, discounted by
    /// [`BatchWorld::discount`] (`r_1 + γ r_2 + γ² r_3 + ...`).
    fn score(&mut self, episode: &Recorded<'_>) -> Result<f64> {
        Ok(discounted(episode.rewards, self.discount()))
    }
}

/// A [`BatchWorld`] as a source of the optimiser's episodes.
pub struct Lockstep<B> {
    world: Mutex<B>,
    shape: Shape,
    description: Value,
    batch: usize,
    interrupt: Option<Interrupt>,
}

impl<B: BatchWorld> Lockstep<B> {
    /// The world, its shape checked (at least one observation, decision and step; observations
    /// and decisions fit the engine's records), and its discount (`0..=1`).
    pub fn new(world: B) -> Result<Lockstep<B>> {
        let shape = world.shape();
        let description = world.description();
        for (name, value) in [("observations", shape.observations), ("decisions", shape.decisions)] {
            if value == 0 || value > usize::from(u16::MAX) {
                return Err(Error::invalid(
                    format!("{} {name}", label(&description)),
                    format!("{value} (expected 1..={})", u16::MAX),
                ));
            }
        }
        if shape.horizon == 0 || shape.horizon > MAX_HORIZON {
            return Err(Error::invalid(
                format!("{} horizon", label(&description)),
                format!("{} (expected 1..={MAX_HORIZON} steps)", shape.horizon),
            ));
        }
        let discount = world.discount();
        if !(0.0..=1.0).contains(&discount) {
            return Err(Error::invalid("discount", format!("{discount} (expected 0 <= discount <= 1)")));
        }
        let batch = world.max_batch();
        if batch == 0 {
            return Err(Error::invalid(format!("{} batch size", label(&description)), "0 (expected at least 1)"));
        }
        Ok(Lockstep { world: Mutex::new(world), shape, description, batch, interrupt: None })
    }

    /// The world, its runs stopped between two steps where `interrupt` asks.
    #[must_use]
    pub fn interruptible(self, interrupt: Interrupt) -> Lockstep<B> {
        Lockstep { interrupt: Some(interrupt), ..self }
    }

    /// [`crate::Error::Interrupted`] where the interrupt asks the work to stop.
    fn check_interrupt(&self) -> Result<()> {
        self.interrupt.as_ref().map_or(Ok(()), Interrupt::check)
    }

    /// The world back (after a run, to read what it kept).
    pub fn into_inner(self) -> B {
        self.world.into_inner().unwrap_or_else(std::sync::PoisonError::into_inner)
    }

    /// Runs the episodes `first..first + values.len()` of one batch, the world drawing from
    /// `world_seed` and `deciders` choosing each episode's decisions.
    fn run_batch<D: Deciders>(
        &self,
        world: &mut B,
        deciders: &D,
        world_seed: u64,
        first: usize,
        out: BatchOut<'_>,
    ) -> Result<u64> {
        let BatchOut { values, records, lengths, step_rewards } = out;
        let Shape { observations: n_obs, horizon, .. } = self.shape;
        let width = deciders.width();
        let stride = horizon * width;
        let n = values.len();
        let place = |k: usize, t: usize| Place {
            world: label(&self.description),
            streams: deciders.streams(),
            episodes: (first, first + n),
            episode: k,
            per_controller: deciders.per_controller(),
            step: t,
        };
        let mut slots: Vec<D::Slot> = (0..n).map(|i| deciders.slot(first + i)).collect();
        let mut observations = vec![0i64; n];
        let mut decisions = vec![0i64; n];
        let mut rewards = vec![0.0f64; n];
        let mut done = vec![false; n];
        let mut alive = vec![true; n];
        lengths.fill(0);
        // Every observation of a running episode is checked, the one that comes with its end too
        // (unused, but a value out of range is the world's bug): `call` is 0 for reset, t for step t.
        let check_observations = |observations: &[i64], alive: &[bool], call: usize| -> Result<()> {
            for (i, &y) in observations.iter().enumerate() {
                if alive[i] && !(0..n_obs as i64).contains(&y) {
                    return Err(place(first + i, call).error(&format!("observation {y} (expected 0..{n_obs})")));
                }
            }
            Ok(())
        };
        self.check_interrupt()?;
        world.reset(world_seed, &mut observations).map_err(|e| place(first, 0).wrap(&e))?;
        check_observations(&observations, &alive, 0)?;
        for t in 0..horizon {
            self.check_interrupt()?;
            records
                .par_chunks_mut(stride)
                .zip(slots.par_iter_mut())
                .zip(decisions.par_iter_mut())
                .zip(observations.par_iter())
                .zip(alive.par_iter())
                .with_min_len(64)
                .for_each(|((((record, slot), decision), &y), &alive)| {
                    if !alive {
                        *decision = 0;
                        return;
                    }
                    let row = &mut record[t * width..(t + 1) * width];
                    deciders.decide(slot, y as usize, t == 0, row);
                    *decision = i64::from(row[1]);
                });
            let out = StepOut { observations: &mut observations, rewards: &mut rewards, done: &mut done };
            world.step(&decisions, out).map_err(|e| place(first, t + 1).wrap(&e))?;
            check_observations(&observations, &alive, t + 1)?;
            for i in 0..n {
                if !alive[i] {
                    continue;
                }
                if !rewards[i].is_finite() {
                    return Err(
                        place(first + i, t + 1).error(&format!("reward {} (expected a finite number)", rewards[i]))
                    );
                }
                step_rewards[i * horizon + t] = rewards[i];
                lengths[i] = (t + 1) as u32;
                alive[i] = !done[i];
            }
            if !alive.iter().any(|&a| a) {
                break;
            }
        }
        for (i, value) in values.iter_mut().enumerate() {
            let steps = lengths[i] as usize;
            let episode = Recorded {
                record: &records[i * stride..i * stride + steps * width],
                width,
                rewards: &step_rewards[i * horizon..i * horizon + steps],
            };
            let v = world.score(&episode).map_err(|e| place(first + i, steps).error(&format!("score: {e}")))?;
            if !v.is_finite() {
                return Err(place(first + i, steps).error(&format!("score {v} (expected a finite number)")));
            }
            *value = v;
        }
        Ok(lengths.iter().map(|&l| u64::from(l)).sum())
    }

    /// The world's own seed for batch `chunk` of `streams`, apart from every stream of the policy.
    fn world_seed(streams: Streams, chunk: u64) -> u64 {
        stream_key(streams.key(chunk), Purpose::Outside, 0, 0) >> 1
    }

    /// Refuses a batch of `m` episodes whose own buffers (step rewards, and `scratch` bytes per
    /// episode of records the caller does not keep) the memory cannot hold.
    fn check_batch(&self, m: usize, scratch: u64) -> Result<()> {
        let bytes = m as u64 * (8 * self.shape.horizon as u64 + scratch);
        let what = format!("a batch of {m} episodes of {} steps", self.shape.horizon);
        crate::memory::check_memory(&what, bytes, crate::memory::available_memory())
    }

    /// The world, locked for one run.
    fn lock(&self) -> std::sync::MutexGuard<'_, B> {
        self.world.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
    }
}

/// Where a batch writes its episodes: values, records (`horizon · width` numbers each), the
/// steps each ran and their rewards (`horizon` each).
struct BatchOut<'a> {
    values: &'a mut [f64],
    records: &'a mut [u16],
    lengths: &'a mut [u32],
    step_rewards: &'a mut [f64],
}

/// What chooses the decisions of each episode of a batch: a policy (its own random stream per
/// episode) or controllers (none).
trait Deciders: Sync {
    /// The state of one episode's decider.
    type Slot: Send;
    /// Numbers per step of a record: `[y, d, ...]`.
    fn width(&self) -> usize;
    /// The streams the episodes belong to (for messages).
    fn streams(&self) -> Streams;
    /// Episodes per controller, where the episodes are those of controllers (for messages).
    fn per_controller(&self) -> Option<usize> {
        None
    }
    /// The decider of episode `k`, before its first step.
    fn slot(&self, k: usize) -> Self::Slot;
    /// Writes the step's row `[y, d, ...]` after observation `y`.
    fn decide(&self, slot: &mut Self::Slot, y: usize, first: bool, row: &mut [u16]);
}

/// A policy's draws: episode `k`'s from `streams.episode(k)`; rows `[y, d, m_1, ..., m_Λ]`.
struct PolicyDeciders<'a> {
    policy: &'a Hhmm,
    streams: Streams,
}

impl Deciders for PolicyDeciders<'_> {
    type Slot = (EngineRng, Vec<u16>);

    fn width(&self) -> usize {
        self.policy.layout().record_width()
    }

    fn streams(&self) -> Streams {
        self.streams
    }

    fn slot(&self, k: usize) -> Self::Slot {
        (self.streams.episode(k), vec![0; self.policy.levels().len()])
    }

    fn decide(&self, (rng, memory): &mut Self::Slot, y: usize, first: bool, row: &mut [u16]) {
        let d = self.policy.step(y, memory, first, rng);
        row[0] = y as u16;
        row[1] = d as u16;
        row[2..].copy_from_slice(memory);
    }
}

/// Controllers: episode `c·episodes + k` is episode `k` of controller `c`; rows `[y, d, node]`.
struct ControllerDeciders<'a> {
    controllers: &'a [Controller],
    episodes: usize,
    n_obs: usize,
    streams: Streams,
}

impl<'a> Deciders for ControllerDeciders<'a> {
    type Slot = Walk<'a>;

    fn width(&self) -> usize {
        3
    }

    fn streams(&self) -> Streams {
        self.streams
    }

    fn per_controller(&self) -> Option<usize> {
        Some(self.episodes)
    }

    fn slot(&self, k: usize) -> Self::Slot {
        self.controllers[k / self.episodes].walk(self.n_obs, (k % self.episodes) as u64)
    }

    fn decide(&self, walk: &mut Self::Slot, y: usize, _first: bool, row: &mut [u16]) {
        let (d, _) = walk.step(y);
        row[0] = y as u16;
        row[1] = d as u16;
        row[2] = walk.node() as u16;
    }
}

impl<B: BatchWorld> Episodes for Lockstep<B> {
    fn shape(&self) -> Shape {
        self.shape
    }

    fn additive(&self) -> bool {
        self.lock().additive()
    }

    fn description(&self) -> Value {
        self.description.clone()
    }

    fn interrupt(&self) -> Option<&Interrupt> {
        self.interrupt.as_ref()
    }

    /// A batch: slices of whole batches give the episodes of the whole evaluation.
    fn slice(&self) -> usize {
        self.batch
    }

    fn batch(&self) -> usize {
        self.batch
    }

    fn run(&self, policy: &Hhmm, streams: Streams, first: usize, batch: Batch<'_>) -> Result<u64> {
        let mut world = self.lock();
        let deciders = PolicyDeciders { policy, streams };
        let stride = self.shape.horizon * deciders.width();
        let n = batch.values.len();
        // A batch's own buffers (step rewards, records when the caller keeps none), checked
        // before they are allocated.
        let m = n.min(self.batch);
        self.check_batch(m, if batch.records.is_some() { 0 } else { 2 * stride as u64 })?;
        // Without the caller's records, each batch reuses buffers of one batch.
        let (mut own_records, mut own_lengths);
        let (records, lengths, kept) = if let Some((records, lengths)) = batch.records {
            (records, lengths, true)
        } else {
            (own_records, own_lengths) = (vec![0u16; m * stride], vec![0u32; m]);
            (&mut own_records[..], &mut own_lengths[..], false)
        };
        let mut step_rewards = vec![0.0f64; m * self.shape.horizon];
        let (mut start, mut steps) = (0, 0);
        while start < n {
            let k = first + start;
            let chunk = k / self.batch;
            let end = n.min((chunk + 1) * self.batch - first);
            let (records, lengths) = if kept {
                (&mut records[start * stride..end * stride], &mut lengths[start..end])
            } else {
                (&mut records[..(end - start) * stride], &mut lengths[..end - start])
            };
            let step_rewards = &mut step_rewards[..(end - start) * self.shape.horizon];
            let out = BatchOut { values: &mut batch.values[start..end], records, lengths, step_rewards };
            let (world, seed) = (&mut *world, Self::world_seed(streams, chunk as u64));
            steps += B::on_thread(|| self.run_batch(world, &deciders, seed, k, out))?;
            start = end;
        }
        Ok(steps)
    }

    /// Batches hold whole controllers where `episodes` fits in one (as many as fit, every batch
    /// reset with the same seed), else slices of `B` episodes of one controller (slice `j`
    /// reset with seed `j`): episode `k` of every controller is then drawn from the same seed,
    /// at the same place in its batch where the batch holds one controller. So a world of the
    /// episode protocol (`B = 1`) gives every controller exactly the same episodes; a batched
    /// world whose episodes depend on their place in the batch gives the same episodes to
    /// the controllers at the same place of their batches.
    fn run_controllers(
        &self,
        controllers: &[Controller],
        streams: Streams,
        episodes: usize,
        values: &mut [f64],
    ) -> Result<u64> {
        self.controllers(controllers, streams, episodes, values, None).map(|(steps, _)| steps)
    }

    fn run_controllers_credited(
        &self,
        controllers: &[Controller],
        streams: Streams,
        episodes: usize,
        values: &mut [f64],
        credit: &mut StepCredit,
    ) -> Result<(u64, bool)> {
        self.controllers(controllers, streams, episodes, values, Some(credit))
    }
}

impl<B: BatchWorld> Lockstep<B> {
    /// [`Episodes::run_controllers`], adding each step's credit to `credit` where one is given
    /// and the world's value is the discounted sum of its rewards (then true); the world's
    /// steps and whether credit was added.
    fn controllers(
        &self,
        controllers: &[Controller],
        streams: Streams,
        episodes: usize,
        values: &mut [f64],
        mut credit: Option<&mut StepCredit>,
    ) -> Result<(u64, bool)> {
        let mut world = self.lock();
        let (n_obs, horizon) = (self.shape.observations, self.shape.horizon);
        if !world.additive() {
            credit = None;
        }
        let gamma = world.discount();
        let deciders = ControllerDeciders { controllers, episodes, n_obs, streams };
        let stride = horizon * deciders.width();
        let per_batch = if episodes <= self.batch { episodes * (self.batch / episodes) } else { self.batch };
        let m = per_batch.min(values.len());
        self.check_batch(m, 2 * stride as u64 + 4)?;
        let (mut records, mut lengths) = (vec![0u16; m * stride], vec![0u32; m]);
        let mut step_rewards = vec![0.0f64; m * horizon];
        let (mut start, mut steps) = (0, 0);
        while start < values.len() {
            let (chunk, end) = if episodes <= self.batch {
                (0, values.len().min(start + per_batch))
            } else {
                let (c, k) = (start / episodes, start % episodes);
                ((k / self.batch) as u64, c * episodes + episodes.min(k + self.batch))
            };
            let out = BatchOut {
                values: &mut values[start..end],
                records: &mut records[..(end - start) * stride],
                lengths: &mut lengths[..end - start],
                step_rewards: &mut step_rewards[..(end - start) * horizon],
            };
            let (world, seed) = (&mut *world, Self::world_seed(streams, chunk));
            steps += B::on_thread(|| self.run_batch(world, &deciders, seed, start, out))?;
            if let Some(credit) = credit.as_deref_mut() {
                for i in 0..end - start {
                    let (c, steps) = ((start + i) / episodes, lengths[i] as usize);
                    let episode = Recorded {
                        record: &records[i * stride..i * stride + steps * deciders.width()],
                        width: deciders.width(),
                        rewards: &step_rewards[i * horizon..i * horizon + steps],
                    };
                    let steps = episode.observations().zip(episode.rewards.iter().copied());
                    credit.add(
                        c,
                        ((start + i) % episodes) as u64,
                        &controllers[c],
                        n_obs,
                        steps,
                        gamma,
                        values[start + i],
                    );
                }
            }
            start = end;
        }
        Ok((steps, credit.is_some()))
    }
}

/// Episode `episode` of an evaluation with `seed`, run alone and recorded (for a world that
/// runs one episode at a time, the very episode of the evaluation; for a batched world, the
/// policy's draws are that episode's and the world's are those of a batch of one). The hidden
/// state is the world's own business: `x` is empty.
pub fn rollout<B: BatchWorld>(world: &Lockstep<B>, policy: &Hhmm, seed: u64, episode: u64) -> Result<Rollout> {
    check_fits(world, policy)?;
    let mut guard = world.lock();
    let width = policy.layout().record_width();
    let mut record = vec![0u16; world.shape.horizon * width];
    let (mut value, mut length) = ([0.0], [0u32]);
    let streams = Streams { seed, purpose: Purpose::Evaluate, iteration: 0 };
    let (k, chunk) = (episode as usize, episode / world.batch as u64);
    let guard = &mut *guard;
    let deciders = PolicyDeciders { policy, streams };
    let mut step_rewards = vec![0.0; world.shape.horizon];
    let out =
        BatchOut { values: &mut value, records: &mut record, lengths: &mut length, step_rewards: &mut step_rewards };
    let seed = Lockstep::<B>::world_seed(streams, chunk);
    B::on_thread(|| world.run_batch(guard, &deciders, seed, k, out))?;
    record.truncate(length[0] as usize * width);
    let column = |c: usize| record.chunks_exact(width).map(|s| i64::from(s[c])).collect();
    Ok(Rollout {
        x_labels: Vec::new(),
        x: Vec::new(),
        y: column(0),
        d: column(1),
        memory: record.chunks_exact(width).flat_map(|s| s[2..].iter().map(|&m| i64::from(m))).collect(),
        levels: policy.levels().len(),
        reward: value[0],
    })
}
