//! A policy run one observation at a time by an outside loop (a Gymnasium loop, a robot): the
//! same top-down sampling as an episode of the engine (model §2), its memory and random stream
//! kept between calls.

use crate::error::{Error, Result};
use crate::policy::Hhmm;
use crate::rng::{EngineRng, Purpose, stream};

/// A policy acting in an outside loop.
#[derive(Clone, Debug)]
pub struct Agent {
    policy: Hhmm,
    memory: Vec<u16>,
    first: bool,
    seed: u64,
    episode: u64,
    rng: EngineRng,
}

impl Agent {
    /// An agent of `policy` whose draws come from `seed` (episode `k` after `k` resets has its
    /// own stream, so a run is reproducible episode by episode).
    pub fn new(policy: Hhmm, seed: u64) -> Agent {
        let memory = vec![0; policy.levels().len()];
        Agent { policy, memory, first: true, seed, episode: 0, rng: stream(seed, Purpose::Agent, 0, 0) }
    }

    /// Starts a new episode: the next observation is the first (`t = 1`).
    pub fn reset(&mut self) {
        self.episode += 1;
        self.memory.fill(0);
        self.first = true;
        self.rng = stream(self.seed, Purpose::Agent, 0, self.episode);
    }

    /// The decision for `observation` (`0..Y`), moving the memory on.
    pub fn act(&mut self, observation: usize) -> Result<usize> {
        let n_obs = self.policy.layout().n_obs;
        if observation >= n_obs {
            return Err(Error::invalid("observation", format!("{observation} (expected 0..{n_obs})")));
        }
        let d = self.policy.step(observation, &mut self.memory, self.first, &mut self.rng);
        self.first = false;
        Ok(d)
    }

    /// The memory `m_1[t], …, m_Λ[t]` after the last decision, bottom first.
    pub fn memory(&self) -> &[u16] {
        &self.memory
    }

    /// The policy.
    pub fn policy(&self) -> &Hhmm {
        &self.policy
    }
}
