//! Memory from every step (model §10): a controller search on sampled worlds that keeps every
//! step it takes and ranks candidate memories on the model those steps give, instead of valuing
//! each candidate on fresh episodes of its own.
//!
//! Each iteration (1) explores: draws `samples` controllers from the laws mixed with `explore`
//! of the uniform law and runs each `episodes` episodes, keeping their steps (the last
//! `memory_steps`: [`Traces`]); (2) searches memories on the model, with no step of the world:
//! `rounds` rounds of the cross-entropy method (model §3) over the memory's laws, each drawing
//! `memories` memories, replaying every kept step through each ([`AgentModel`]), planning its
//! decisions and ranking it by the model's value, the best `rho` refitting the laws; (3) confirms:
//! the `confirm` best plans of the last round are valued on the `select_episodes` selection
//! episodes of the world (shared by every iteration), and the best of them replaces the best so
//! far where it scores higher. A stepped optimiser (`ceworld run model-search`, `cehmm.run`):
//! budgets, checkpoints, progress and backends come from the spine.

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::config::Template;
use super::laws::Laws;
use super::model::{AgentModel, Plan};
use crate::ce::record::IterationRecord;
use crate::ce::stepped::{Rules, Stepped};
use crate::episodes::credit::StepCredit;
use crate::episodes::trace::Traces;
use crate::episodes::{Episodes, Streams};
use crate::error::{Error, Result};
use crate::evaluate::mean;
use crate::policy::Hhmm;
use crate::policy::controller::Controller;
use crate::rng::{Purpose, stream};
use crate::settings::{Setting, Settings};

/// The settings of the search of memories on the model of every step.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ModelSearchConfig {
    /// Nodes of the memory (`register_size ^ registers` where `registers > 0`).
    pub nodes: usize,
    /// Registers holding the memory (0: `nodes` flat nodes; model §8).
    pub registers: usize,
    /// The memory's template: `uniform`, `hold`, `clock`, `mixed` or `window`.
    pub template: Template,
    /// The template's weight in the first laws, `0 <= w < 1`.
    pub template_weight: f64,
    /// Controllers run per iteration to explore.
    pub samples: usize,
    /// Episodes of each.
    pub episodes: usize,
    /// Weight of the uniform law mixed into the laws the explorers are drawn from.
    pub explore: f64,
    /// Memories ranked on the model per round.
    pub memories: usize,
    /// Rounds of the cross-entropy method on the model per iteration.
    pub rounds: usize,
    /// Elite fraction of each round.
    pub rho: f64,
    /// Smoothing of the refits.
    pub smoothing: f64,
    /// Weight of the doubt on a (node, decision) seen rarely ([`AgentModel::plan`]).
    pub pessimism: f64,
    /// Plans confirmed on the world per iteration.
    pub confirm: usize,
    /// Selection episodes each confirmed plan is valued on.
    pub select_episodes: usize,
    /// Steps kept for the model (the latest).
    pub memory_steps: usize,
    /// Stop rules, budgets, seed, threads and final evaluation ([`Rules`]).
    #[serde(flatten)]
    pub rules: Rules,
}

impl Default for ModelSearchConfig {
    fn default() -> Self {
        ModelSearchConfig {
            nodes: 16,
            registers: 2,
            template: Template::Uniform,
            template_weight: 0.5,
            samples: 16,
            episodes: 4,
            explore: 0.3,
            memories: 500,
            rounds: 20,
            rho: 0.05,
            smoothing: 0.5,
            pessimism: 0.1,
            confirm: 2,
            select_episodes: 20,
            memory_steps: 200_000,
            rules: Rules::default(),
        }
    }
}

impl Settings for ModelSearchConfig {
    fn set(&mut self, s: &Setting<'_>) -> Result<()> {
        match s.name {
            "nodes" => self.nodes = s.count()?,
            "registers" => self.registers = s.count()?,
            "template" => self.template = s.choice(Template::parse)?,
            "template_weight" => self.template_weight = s.real()?,
            "samples" => self.samples = s.count()?,
            "episodes" => self.episodes = s.count()?,
            "explore" => self.explore = s.real()?,
            "memories" => self.memories = s.count()?,
            "rounds" => self.rounds = s.count()?,
            "rho" => self.rho = s.real()?,
            "smoothing" => self.smoothing = s.real()?,
            "pessimism" => self.pessimism = s.real()?,
            "confirm" => self.confirm = s.count()?,
            "select_episodes" => self.select_episodes = s.count()?,
            "memory_steps" => self.memory_steps = s.count()?,
            name if Rules::owns(name) => self.rules.set(s)?,
            other => return Err(self.unknown(other)),
        }
        Ok(())
    }
}

/// The state of the search: the laws, the kept steps, the best controller so far.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct ModelSearch {
    /// The laws the memories (and the explorers) are drawn from.
    pub laws: Laws,
    /// The latest steps taken (with the world's discount).
    pub traces: Traces,
    /// The best controller so far, with its score on the selection episodes.
    pub best: Option<(Controller, f64)>,
}

impl Stepped for ModelSearch {
    const NAME: &'static str = "model-search";
    const FORMAT: &'static str = "cehmm-model-search-checkpoint";
    type Config = ModelSearchConfig;

    fn rules(c: &ModelSearchConfig) -> Rules {
        c.rules
    }

    fn episodes(c: &ModelSearchConfig) -> usize {
        c.samples.saturating_mul(c.episodes) + c.confirm.saturating_mul(c.select_episodes)
    }

    fn validate(c: &ModelSearchConfig) -> Result<()> {
        for (name, value) in [
            ("nodes", c.nodes),
            ("samples", c.samples),
            ("episodes", c.episodes),
            ("memories", c.memories),
            ("rounds", c.rounds),
            ("confirm", c.confirm),
            ("select_episodes", c.select_episodes),
            ("memory_steps", c.memory_steps),
        ] {
            if value == 0 {
                return Err(Error::invalid(name, "0 (expected at least 1)"));
            }
        }
        if c.registers > 0 {
            let d = (c.nodes as f64).powf(1.0 / c.registers as f64).round() as usize;
            if d < 2 || d.checked_pow(c.registers as u32) != Some(c.nodes) {
                let why = format!("{} (expected a power of 2 or more to the registers, {})", c.nodes, c.registers);
                return Err(Error::invalid("nodes", why));
            }
        }
        for (name, value) in [("template_weight", c.template_weight), ("explore", c.explore)] {
            if !(0.0..1.0).contains(&value) {
                return Err(Error::invalid(name, format!("{value} (expected a number in [0, 1))")));
            }
        }
        for (name, value) in [("rho", c.rho), ("smoothing", c.smoothing)] {
            if !(value > 0.0 && value <= 1.0) {
                return Err(Error::invalid(name, format!("{value} (expected a number in (0, 1])")));
            }
        }
        if !(c.pessimism.is_finite() && c.pessimism >= 0.0) {
            return Err(Error::invalid("pessimism", format!("{} (expected a number >= 0)", c.pessimism)));
        }
        c.rules.budget.validate()
    }

    fn start(world: &dyn Episodes, c: &ModelSearchConfig) -> Result<ModelSearch> {
        let shape = world.shape();
        // The policy must fit before any work.
        Controller::moore(vec![0; c.nodes], vec![0; c.nodes * shape.observations])
            .to_hhmm(shape.observations, shape.decisions)?;
        let laws = Laws::start(
            c.nodes,
            shape.decisions,
            shape.observations,
            false,
            c.registers,
            c.template,
            c.template_weight,
        );
        Ok(ModelSearch { laws, traces: Traces::default(), best: None })
    }

    fn step(
        &mut self,
        world: &dyn Episodes,
        c: &ModelSearchConfig,
        iteration: usize,
        spent: &dyn Fn() -> bool,
    ) -> Result<IterationRecord> {
        let mut rng = stream(c.rules.seed, Purpose::Init, iteration as u64, 0);
        // The explorers and the search start as wide as the laws widened by `explore`: the data
        // have grown since the last iteration's laws were fitted on fewer steps.
        self.laws.inject(c.explore);
        let explored = self.explore(world, c, iteration, &mut rng, spent)?;
        let (plans, elite) = self.search(world, c, &mut rng);
        let successful = if self.best.is_none() || !spent() { self.confirm(world, c, &plans)? } else { false };
        let best = self.best.as_ref().map_or(f64::NEG_INFINITY, |(_, v)| *v);
        Ok(IterationRecord {
            iteration,
            mean: mean(explored.iter().copied()),
            best,
            elite_threshold: elite.iter().copied().fold(f64::INFINITY, f64::min),
            elite_mean: mean(elite.iter().copied()),
            seconds: 0.0,
            successful,
            env_steps: 0,
        })
    }

    fn policy(&self, world: &dyn Episodes) -> Result<Hhmm> {
        let shape = world.shape();
        let (best, _) = self.best.as_ref().ok_or_else(|| Error::invalid("model-search", "no iteration has run"))?;
        best.to_hhmm(shape.observations, shape.decisions)
    }
}

impl ModelSearch {
    /// Runs the iteration's explorers, keeping their steps; their mean values.
    fn explore(
        &mut self,
        world: &dyn Episodes,
        c: &ModelSearchConfig,
        iteration: usize,
        rng: &mut crate::rng::EngineRng,
        spent: &dyn Fn() -> bool,
    ) -> Result<Vec<f64>> {
        let explorers: Vec<Controller> = (0..c.samples).map(|_| self.laws.draw(rng)).collect();
        let streams = Streams { seed: c.rules.seed, purpose: Purpose::Controllers, iteration: iteration as u64 };
        let group = super::group_size(world.batch(), c.episodes);
        let rows = StepCredit::rows_of(&explorers[0]);
        let mut means = Vec::with_capacity(c.samples);
        for chunk in explorers.chunks(group) {
            if !means.is_empty() && spent() {
                break;
            }
            let mut values = vec![0.0; chunk.len() * c.episodes];
            let mut credit = StepCredit::traced(chunk.len(), rows);
            let (_, credited) = world.run_controllers_credited(chunk, streams, c.episodes, &mut values, &mut credit)?;
            let traces = credit.traces.take().filter(|_| credited).ok_or_else(|| {
                Error::invalid(
                    "world",
                    "a world whose value is not the (discounted) sum of its steps' rewards, or one run by the \
                     engine (expected a world in Python or Gymnasium's, which gives its steps' rewards: \
                     model-search learns from every step)",
                )
            })?;
            if traces.ends.len() != values.len() {
                let why =
                    "sampled by a backend's workers (expected episodes run here: their steps do not come back yet)";
                return Err(Error::invalid("world", why));
            }
            self.traces.append(traces);
            means.extend(values.chunks(c.episodes).map(|v| mean(v.iter().copied())));
        }
        self.traces.keep_last(c.memory_steps);
        Ok(means)
    }

    /// The rounds of the cross-entropy method over the memory's laws on the model of the kept
    /// steps: the last round's plans, best first, and the model's values of its elite.
    fn search(
        &mut self,
        world: &dyn Episodes,
        c: &ModelSearchConfig,
        rng: &mut crate::rng::EngineRng,
    ) -> (Vec<Plan>, Vec<f64>) {
        let shape = world.shape();
        let (y1, a, gamma) = (shape.observations, shape.decisions, self.traces.gamma);
        let elite_size = ((c.rho * c.memories as f64).ceil() as usize).clamp(1, c.memories);
        let (mut plans, mut elite) = (Vec::new(), Vec::new());
        for _ in 0..c.rounds {
            let memories: Vec<Controller> = (0..c.memories).map(|_| self.laws.draw(rng)).collect();
            let traces = &self.traces;
            plans = memories
                .par_iter()
                .map(|m| {
                    let model = AgentModel::fit(&m.next, y1, a, traces);
                    model.plan(&m.next, gamma, model.longest, c.pessimism, &m.act)
                })
                .collect();
            // Best first; equal values keep the order drawn.
            plans.sort_by(|p, q| q.value.total_cmp(&p.value));
            let chosen: Vec<&Controller> = plans[..elite_size].iter().map(|p| &p.controller).collect();
            self.laws.refit(&chosen, None, c.smoothing);
            elite = plans[..elite_size].iter().map(|p| p.value).collect();
        }
        (plans, elite)
    }

    /// Values the best distinct plans on the selection episodes; whether one beat the best so far.
    fn confirm(&mut self, world: &dyn Episodes, c: &ModelSearchConfig, plans: &[Plan]) -> Result<bool> {
        let mut few: Vec<Controller> = Vec::new();
        for p in plans {
            if few.len() == c.confirm {
                break;
            }
            if !few.contains(&p.controller) {
                few.push(p.controller.clone());
            }
        }
        let streams = Streams { seed: c.rules.seed, purpose: Purpose::Select, iteration: 0 };
        let m = c.select_episodes;
        let mut values = vec![0.0; few.len() * m];
        world.run_controllers(&few, streams, m, &mut values)?;
        let scores: Vec<f64> = values.chunks(m).map(|v| mean(v.iter().copied())).collect();
        let k = (0..few.len()).fold(0, |b, i| if scores[i] > scores[b] { i } else { b });
        let better = self.best.as_ref().is_none_or(|(_, v)| scores[k] > *v);
        if better {
            self.best = Some((few[k].clone(), scores[k]));
        }
        Ok(better)
    }
}
