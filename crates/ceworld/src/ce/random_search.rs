//! Random search over deterministic controllers: each iteration draws `samples` controllers of
//! `nodes` nodes uniformly (every decision, every successor), values each on `episodes`
//! episodes shared by all of them (common random numbers), and keeps the best so far. A
//! baseline for the controller search of model §8, and the smallest [`Stepped`] optimiser: its
//! config, its step and one registration in [`crate::run::OPTIMISERS`] give it everything else.

use rand::RngExt;
use serde::{Deserialize, Serialize};

use crate::ce::budget::{GROUP_EPISODES, Groups};
use crate::ce::record::IterationRecord;
use crate::ce::stepped::{Rules, Stepped};
use crate::episodes::{Episodes, Streams};
use crate::error::{Error, Result};
use crate::policy::Hhmm;
use crate::policy::controller::Controller;
use crate::rng::{Purpose, stream};
use crate::settings::{Setting, Settings};

/// The settings of a random search.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RandomSearchConfig {
    /// Nodes of each controller.
    pub nodes: usize,
    /// Controllers drawn per iteration.
    pub samples: usize,
    /// Episodes each controller is valued on, per iteration.
    pub episodes: usize,
    /// Stop rules, budgets, seed, threads and final evaluation ([`Rules`]).
    #[serde(flatten)]
    pub rules: Rules,
}

impl Default for RandomSearchConfig {
    fn default() -> Self {
        RandomSearchConfig { nodes: 4, samples: 200, episodes: 100, rules: Rules::default() }
    }
}

impl Settings for RandomSearchConfig {
    fn set(&mut self, s: &Setting<'_>) -> Result<()> {
        match s.name {
            "nodes" => self.nodes = s.count()?,
            "samples" => self.samples = s.count()?,
            "episodes" => self.episodes = s.count()?,
            name if Rules::owns(name) => self.rules.set(s)?,
            other => return Err(self.unknown(other)),
        }
        Ok(())
    }
}

/// The state of a random search: the best controller so far and its value.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
pub struct RandomSearch {
    /// The best controller so far, with its value (the mean of its episodes).
    pub best: Option<(Controller, f64)>,
}

impl Stepped for RandomSearch {
    const NAME: &'static str = "random-search";
    const FORMAT: &'static str = "cehmm-random-search-checkpoint";
    type Config = RandomSearchConfig;

    fn rules(c: &RandomSearchConfig) -> Rules {
        c.rules
    }

    fn episodes(c: &RandomSearchConfig) -> usize {
        c.samples.saturating_mul(c.episodes)
    }

    fn validate(c: &RandomSearchConfig) -> Result<()> {
        for (name, value) in [("nodes", c.nodes), ("samples", c.samples), ("episodes", c.episodes)] {
            if value == 0 {
                return Err(Error::invalid(name, "0 (expected at least 1)"));
            }
        }
        c.rules.budget.validate()
    }

    fn start(world: &dyn Episodes, c: &RandomSearchConfig) -> Result<RandomSearch> {
        // The policy must fit before any work.
        let shape = world.shape();
        Controller::moore(vec![0; c.nodes], vec![0; c.nodes * shape.observations])
            .to_hhmm(shape.observations, shape.decisions)?;
        Ok(RandomSearch::default())
    }

    fn step(
        &mut self,
        world: &dyn Episodes,
        c: &RandomSearchConfig,
        iteration: usize,
        left: &dyn Fn() -> Option<u64>,
    ) -> Result<IterationRecord> {
        let shape = world.shape();
        let mut rng = stream(c.rules.seed, Purpose::Init, iteration as u64, 0);
        let controllers: Vec<Controller> = (0..c.samples)
            .map(|_| {
                Controller::moore(
                    (0..c.nodes).map(|_| rng.random_range(0..shape.decisions as u32)).collect(),
                    (0..c.nodes * shape.observations).map(|_| rng.random_range(0..c.nodes as u32)).collect(),
                )
            })
            .collect();
        let streams = Streams { seed: c.rules.seed, purpose: Purpose::Controllers, iteration: iteration as u64 };
        // In groups of whole batches of episodes, so that the budget cuts the iteration between
        // two (the first always counts): its best is of the controllers valued.
        let mut groups = Groups::new(c.samples, c.episodes, world.batch(), GROUP_EPISODES, shape.horizon);
        let mut means = Vec::with_capacity(c.samples);
        while let Some(group) = groups.next(left()) {
            let chunk = &controllers[group];
            let mut values = vec![0.0; chunk.len() * c.episodes];
            groups.took(world.run_controllers(chunk, streams, c.episodes, &mut values)?);
            means.extend(values.chunks(c.episodes).map(|v| v.iter().sum::<f64>() / c.episodes as f64));
        }
        let (k, top) =
            means.iter().enumerate().fold((0, f64::NEG_INFINITY), |b, (k, &m)| if m > b.1 { (k, m) } else { b });
        let successful = self.best.as_ref().is_none_or(|(_, v)| top > *v);
        if successful {
            self.best = Some((controllers[k].clone(), top));
        }
        let best = self.best.as_ref().map_or(top, |(_, v)| *v);
        Ok(IterationRecord {
            iteration,
            mean: means.iter().sum::<f64>() / means.len() as f64,
            best,
            elite_threshold: top,
            elite_mean: top,
            seconds: 0.0,
            successful,
            env_steps: 0,
        })
    }

    fn policy(&self, world: &dyn Episodes) -> Result<Hhmm> {
        let shape = world.shape();
        let (best, _) = self.best.as_ref().ok_or_else(|| Error::invalid("random-search", "no iteration has run"))?;
        best.to_hhmm(shape.observations, shape.decisions)
    }
}
