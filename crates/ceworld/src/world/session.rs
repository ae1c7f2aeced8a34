//! A world run one step at a time by an outside caller (a Gymnasium environment, an outside
//! agent): the same `reset`, `observe`, `step` as an episode of the engine (model §1), with the
//! step's reward read as the change of the episode's reward so far.

use std::fmt;

use crate::error::{Error, Result};
use crate::rng::{EngineRng, Purpose, stream};
use crate::world::World;
use crate::world::registry::AnyWorld;

/// One world's episode in progress.
#[derive(Clone, Debug)]
pub struct Stepper<W: World> {
    world: W,
    state: W::State,
    rng: EngineRng,
    t: usize,
    observation: usize,
    reward: f64,
}

impl<W: World + Clone> Stepper<W> {
    fn start(world: &W, seed: u64, episode: u64) -> Stepper<W> {
        let mut rng = stream(seed, Purpose::Session, 0, episode);
        let state = world.reset(&mut rng);
        let observation = world.observe(&state, &mut rng);
        let reward = world.reward(&state);
        Stepper { world: world.clone(), state, rng, t: 1, observation, reward }
    }

    fn step(&mut self, decision: usize) -> Result<(usize, f64, bool)> {
        let d = self.world.n_decisions();
        if decision >= d {
            return Err(Error::invalid("decision", format!("{decision} (expected 0..{d})")));
        }
        if self.over() {
            return Err(Error::invalid("step", "after the last step (reset the episode first)"));
        }
        self.world.step(&mut self.state, decision, &mut self.rng);
        self.t += 1;
        let reward = self.world.reward(&self.state);
        let gained = reward - self.reward;
        self.reward = reward;
        self.observation = self.world.observe(&self.state, &mut self.rng);
        Ok((self.observation, gained, self.over()))
    }

    /// Past the horizon, or ended by the world ([`World::done`]).
    fn over(&self) -> bool {
        self.t > self.world.horizon() || self.world.done(&self.state)
    }

    fn describe(&self) -> Vec<i64> {
        let mut out = Vec::new();
        self.world.describe(&self.state, &mut out);
        out
    }
}

/// A [`Stepper`] of any world, its type erased: what [`Session`] holds.
trait Episode: fmt::Debug + Send + Sync {
    fn observation(&self) -> usize;
    fn t(&self) -> usize;
    fn reward(&self) -> f64;
    fn step(&mut self, decision: usize) -> Result<(usize, f64, bool)>;
    fn describe(&self) -> Vec<i64>;
    fn boxed_clone(&self) -> Box<dyn Episode>;
}

impl<W> Episode for Stepper<W>
where
    W: World + Clone + fmt::Debug + Send + 'static,
    W::State: fmt::Debug + Sync + 'static,
{
    fn observation(&self) -> usize {
        self.observation
    }

    fn t(&self) -> usize {
        self.t
    }

    fn reward(&self) -> f64 {
        self.reward
    }

    fn step(&mut self, decision: usize) -> Result<(usize, f64, bool)> {
        Stepper::step(self, decision)
    }

    fn describe(&self) -> Vec<i64> {
        Stepper::describe(self)
    }

    fn boxed_clone(&self) -> Box<dyn Episode> {
        Box::new(self.clone())
    }
}

/// An episode of any registered world, stepped from outside.
#[derive(Debug)]
pub struct Session {
    episode: Box<dyn Episode>,
}

impl Clone for Session {
    fn clone(&self) -> Session {
        Session { episode: self.episode.boxed_clone() }
    }
}

impl Session {
    /// Episode `episode` of `world`, drawn from `seed` (the same pair gives the same episode for
    /// the same decisions); its first observation is ready.
    pub fn start(world: &AnyWorld, seed: u64, episode: u64) -> Session {
        let episode = crate::with_world!(world, w => Box::new(Stepper::start(w, seed, episode)) as Box<dyn Episode>);
        Session { episode }
    }

    /// The current observation `y_t`.
    pub fn observation(&self) -> usize {
        self.episode.observation()
    }

    /// The step `t` the next decision is for (`horizon + 1` once the episode is over).
    pub fn t(&self) -> usize {
        self.episode.t()
    }

    /// The episode's reward so far.
    pub fn reward(&self) -> f64 {
        self.episode.reward()
    }

    /// Takes `decision` at step `t`: the next observation, the reward it gained, and whether the
    /// episode is over (after `horizon` steps, or where the world ended it).
    pub fn step(&mut self, decision: usize) -> Result<(usize, f64, bool)> {
        self.episode.step(decision)
    }

    /// The state as numbers (the world's `state_labels`).
    pub fn describe(&self) -> Vec<i64> {
        self.episode.describe()
    }
}
