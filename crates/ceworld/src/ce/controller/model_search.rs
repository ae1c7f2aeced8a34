//! Memory from every step (model §10): a controller search on sampled worlds that keeps every
//! step it takes and ranks candidate memories on the model those steps give, instead of valuing
//! each candidate on fresh episodes of its own.
//!
//! Each iteration (1) explores: `samples` controllers run `episodes` episodes each, each on
//! episodes of its own, keeping their steps (the last `memory_steps`: [`Traces`]); they are drawn
//! from the laws mixed with `explore` of the uniform law, and a `greedy` share of them, once there
//! is a best so far, is that best with its decision drawn again with probability `explore` at each
//! step ([`crate::policy::controller::Explore`]: the model weights each step by the inverse of its
//! decision's probability). (2) Searches memories on the model, with no step of the world: `rounds`
//! rounds of the cross-entropy method (model §3) over the laws of a successor table, each drawing
//! `memories` tables, replaying every kept step through each ([`AgentModel`]), planning its
//! decisions on half the kept episodes and ranking it by the plan's value on the model of the other
//! half, the best `rho` refitting the laws; and every lens of at most `lens_features` features
//! ([`Lens`]: lags of the last `window` observations and decisions, the first observation) and
//! every tally ([`Tally`]: counts of each value of a part of the observations) planned and valued
//! the same way, as one family; and, where `pairs`, the machine of the model of pairs ([`Pairs`]:
//! what each decision brings at once after each earlier decision and what followed it), which
//! decides one step ahead. (3) Confirms: the model of pairs' machine, the `confirm` best plans of
//! each family (the machine in the place of one of them), the explorer
//! drawn from the laws that did best on its own episodes, the best so far with each decision row
//! credited by the greedy explorers' steps (model §8's credit within episodes), in the first
//! iteration the uniform policy, and the best so far are valued on the iteration's selection
//! episodes, whose steps are kept as the explorers' are, beside the best so far's contenders:
//! the one of the highest gain among those that beat the best so far by more than the noise of
//! their gains, over every iteration both were valued in, replaces it ([`incumbent`]), else they
//! add to its value and the one of the highest gain not below 0 contends again, in the place of a
//! fresh plan. A stepped optimiser (`ceworld run
//! model-search`, `cehmm.run`): budgets, checkpoints, progress and backends come from the spine.

mod candidate;
mod explorers;
mod incumbent;
mod pairs;
mod tally;

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::config::Template;
use super::laws::Laws;
use super::lens::{Lens, Sizes};
use crate::ce::record::IterationRecord;
use crate::ce::stepped::{Rules, Stepped};
use crate::episodes::credit::StepCredit;
use crate::episodes::trace::Traces;
use crate::episodes::{Episodes, Streams};
use crate::error::{Error, Result};
use crate::evaluate::mean;
use crate::policy::Hhmm;
use crate::policy::controller::Controller;
use crate::rng::{EngineRng, Purpose, stream};
use crate::settings::{Setting, Settings};
use candidate::{Memory, Plan};
use explorers::{credited_best, explorer};
use incumbent::settle;
pub use incumbent::{Contender, Incumbent};
use pairs::Pairs;
use tally::Tally;

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
    /// Weight of the uniform law mixed into the laws the explorers are drawn from, and
    /// probability that a greedy explorer draws its decision again at a step.
    pub explore: f64,
    /// Share of the explorers that are the best so far drawing its decisions again at some steps.
    pub greedy: f64,
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
    /// Backups of the planning and the ranking per step of the longest kept episode (model §10:
    /// where a memory does not hold the time, the model's episodes are spread out in length).
    pub lookahead: usize,
    /// Plans of each family (tables, lenses) confirmed on the world per iteration (the best so
    /// far's contender takes the place of one).
    pub confirm: usize,
    /// Selection episodes each confirmed plan is valued on.
    pub select_episodes: usize,
    /// Standard errors of the paired difference on the selection episodes by which a plan must
    /// beat the best so far to replace it (0: any gain): the best of several noisy means is
    /// biased up, and a plan lucky on a few episodes would replace a better best.
    pub margin: f64,
    /// Steps kept for the model (the latest).
    pub memory_steps: usize,
    /// Lags the lenses look at, the current observation included (0: no lenses, and no tallies).
    pub window: usize,
    /// Features (observation and decision lags, the first observation) a lens looks at, at most.
    pub lens_features: usize,
    /// Nodes of a lens's or a tally's machine, at most.
    pub lens_nodes: usize,
    /// Whether each iteration confirms the machine of the model of pairs ([`Pairs`]) in the place
    /// of one of the families' plans (off by default: model §10, *The model of pairs*).
    #[serde(default)]
    pub pairs: bool,
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
            greedy: 0.5,
            memories: 500,
            rounds: 20,
            rho: 0.05,
            smoothing: 0.5,
            pessimism: 0.1,
            lookahead: 1,
            confirm: 3,
            select_episodes: 10,
            margin: 1.0,
            memory_steps: 200_000,
            window: 8,
            lens_features: 3,
            lens_nodes: 1024,
            pairs: false,
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
            "greedy" => self.greedy = s.real()?,
            "memories" => self.memories = s.count()?,
            "rounds" => self.rounds = s.count()?,
            "rho" => self.rho = s.real()?,
            "smoothing" => self.smoothing = s.real()?,
            "pessimism" => self.pessimism = s.real()?,
            "lookahead" => self.lookahead = s.count()?,
            "confirm" => self.confirm = s.count()?,
            "select_episodes" => self.select_episodes = s.count()?,
            "margin" => self.margin = s.real()?,
            "memory_steps" => self.memory_steps = s.count()?,
            "window" => self.window = s.count()?,
            "lens_features" => self.lens_features = s.count()?,
            "lens_nodes" => self.lens_nodes = s.count()?,
            "pairs" => self.pairs = s.flag()?,
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
    /// The best controller so far.
    pub best: Option<Incumbent>,
}

impl Stepped for ModelSearch {
    const NAME: &'static str = "model-search";
    const FORMAT: &'static str = "cehmm-model-search-checkpoint";
    type Config = ModelSearchConfig;

    fn rules(c: &ModelSearchConfig) -> Rules {
        c.rules
    }

    fn episodes(c: &ModelSearchConfig) -> usize {
        // The explorers, then those valued on the selection episodes.
        c.samples.saturating_mul(c.episodes) + selected(c).saturating_mul(c.select_episodes)
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
            ("lens_nodes", c.lens_nodes),
            ("lookahead", c.lookahead),
        ] {
            if value == 0 {
                return Err(Error::invalid(name, "0 (expected at least 1)"));
            }
        }
        if c.window > 16 {
            return Err(Error::invalid("window", format!("{} (expected at most 16 lags)", c.window)));
        }
        if c.registers > 0 {
            let d = (c.nodes as f64).powf(1.0 / c.registers as f64).round() as usize;
            if d < 2 || d.checked_pow(c.registers as u32) != Some(c.nodes) {
                let why = format!(
                    "{} (expected a power of 2 or more to the registers, {}: e.g. {}; or registers=0 for flat nodes)",
                    c.nodes,
                    c.registers,
                    (2..5usize)
                        .filter_map(|d| d.checked_pow(c.registers.min(64) as u32))
                        .map(|n| n.to_string())
                        .collect::<Vec<_>>()
                        .join(", ")
                );
                return Err(Error::invalid("nodes", why));
            }
        }
        for (name, value) in [("template_weight", c.template_weight), ("explore", c.explore), ("greedy", c.greedy)] {
            if !(0.0..1.0).contains(&value) {
                return Err(Error::invalid(name, format!("{value} (expected a number in [0, 1))")));
            }
        }
        for (name, value) in [("rho", c.rho), ("smoothing", c.smoothing)] {
            if !(value > 0.0 && value <= 1.0) {
                return Err(Error::invalid(name, format!("{value} (expected a number in (0, 1])")));
            }
        }
        if !(c.margin.is_finite() && c.margin >= 0.0) {
            return Err(Error::invalid("margin", format!("{} (expected a number >= 0)", c.margin)));
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
        left: &dyn Fn() -> Option<u64>,
    ) -> Result<IterationRecord> {
        let mut rng = stream(c.rules.seed, Purpose::Init, iteration as u64, 0);
        // The explorers and the search start as wide as the laws widened by `explore`: the data
        // have grown since the last iteration's laws were fitted on fewer steps.
        self.laws.inject(c.explore);
        let (explorers, explored, credited) = self.explore(world, c, iteration, &mut rng, left)?;
        // The explorer drawn from the laws that did best on its own episodes and the credited best
        // so far challenge the plans.
        let first_best = |b: usize, i: usize| if explored[i] > explored[b] { i } else { b };
        let drawn = explored.len().min(explorers.iter().take_while(|e| e.explore.is_none()).count());
        let best_explorer = (drawn > 0).then(|| explorers[(0..drawn).fold(0, first_best)].clone());
        // In the first iteration, the uniform policy too (memoryless and drawn at each step: where
        // every deterministic plan repeats a costly decision, it may beat them all).
        let uniform = self.best.is_none().then(|| {
            let one = Controller::moore(vec![0], vec![0; world.shape().observations]);
            explorer(&one, 1.0, world.shape().decisions, &mut rng)
        });
        let challengers: Vec<Controller> = best_explorer.into_iter().chain(credited).chain(uniform).collect();
        let shape = world.shape();
        let sizes = Sizes::of(shape, &world.description());
        let (tables, elite) = self.search(sizes, c, &mut rng);
        let lenses = self.lenses(sizes, shape.horizon, c);
        // The model of pairs' machine (within the lenses' budget of nodes), first of the plans.
        let fitted = c.pairs.then(|| Pairs::fit(shape.observations, shape.decisions, &self.traces)).flatten();
        let pairs = fitted.map(|m| m.machine(c.lens_nodes));
        let successful = self.confirm(world, c, iteration, sizes, pairs, [tables, lenses], challengers, left)?;
        let best = self.best.as_ref().map_or(f64::NEG_INFINITY, |b| b.value);
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

    fn spent(&self, c: &ModelSearchConfig, left: Option<u64>) -> bool {
        // Once there is a best so far, an iteration counts only where, after one explorer's
        // episodes (it runs one at least), its selection covers a plan and the best
        // ([`ModelSearch::confirm`]).
        self.best.is_some() && self.covered(left) < c.episodes + 2 * c.select_episodes
    }

    fn policy(&self, world: &dyn Episodes) -> Result<Hhmm> {
        let shape = world.shape();
        let best = self.best.as_ref().ok_or_else(|| Error::invalid("model-search", "no iteration has run"))?;
        best.controller.to_hhmm(shape.observations, shape.decisions)
    }
}

/// The most controllers an iteration values on its selection episodes: the plans of each family
/// (`confirm` each; the model of pairs' machine and the best so far's contender in the place of
/// one), the best explorer, the
/// credited best so far (or, in the first iteration, the uniform policy) and the best so far.
fn selected(c: &ModelSearchConfig) -> usize {
    let families = if c.window > 0 { 2 } else { 1 };
    families * c.confirm + 3
}

/// Contenders the best so far keeps: each is valued again in the place of a fresh plan.
const CONTENDERS: usize = 1;

/// The episodes of explorer `j` of an iteration: its own, drawn from no other explorer's (where
/// the explorers shared the same episodes, as the controllers valued against each other do, the
/// model would learn from as many of the world's draws as episodes an explorer runs: on
/// `MultiarmedBanditEasy`, four sets of arms an iteration).
fn explorer_streams(seed: u64, iteration: usize, j: usize) -> Streams {
    Streams { seed, purpose: Purpose::Controllers, iteration: (iteration as u64) << 32 | j as u64 }
}

impl ModelSearch {
    /// Runs the iteration's explorers, keeping their steps: the explorers, the mean values of
    /// those run (the budget may cut them) and the best so far credited by the greedy ones. They
    /// are drawn from the laws, and a `greedy` share of them is the best so far with each decision
    /// drawn again with probability `explore` at each step (whose steps the model weights by the
    /// inverse of their decisions' probabilities, model §10): each decision row of the best so
    /// far then takes the decision whose steps in that row had the highest mean value still to
    /// come in the world (model §8's credit within episodes, over the greedy explorers' steps),
    /// which needs no model.
    fn explore(
        &mut self,
        world: &dyn Episodes,
        c: &ModelSearchConfig,
        iteration: usize,
        rng: &mut EngineRng,
        left: &dyn Fn() -> Option<u64>,
    ) -> Result<(Vec<Controller>, Vec<f64>, Option<Controller>)> {
        let greedy = if self.best.is_some() { (c.greedy * c.samples as f64).round() as usize } else { 0 };
        let mut explorers: Vec<Controller> = (0..c.samples - greedy).map(|_| self.laws.draw(rng)).collect();
        let a = world.shape().decisions;
        if let Some(best) = &self.best {
            explorers.extend((0..greedy).map(|_| explorer(&best.controller, c.explore, a, rng)));
        }
        let mut means = Vec::with_capacity(c.samples);
        let first_greedy = c.samples - greedy;
        let before = self.traces.ends.len();
        // The steps the selection will take, kept for it.
        let reserve = self.selection_steps(selected(c), c.select_episodes);
        for (j, e) in explorers.iter().enumerate() {
            if !means.is_empty() && left().is_some_and(|l| l <= reserve) {
                break;
            }
            let mut values = vec![0.0; c.episodes];
            let streams = explorer_streams(c.rules.seed, iteration, j);
            self.run_kept(world, std::slice::from_ref(e), streams, c.episodes, &mut values)?;
            means.push(mean(values.iter().copied()));
        }
        // The greedy explorers' episodes, the last of those just kept.
        let first = before + means.len().min(first_greedy) * c.episodes;
        let n_obs = world.shape().observations;
        let credited = self
            .best
            .as_ref()
            .and_then(|b| credited_best(&b.controller, &self.traces, self.traces.episodes().skip(first), n_obs, a));
        self.traces.keep_last(c.memory_steps);
        Ok((explorers, means, credited))
    }

    /// Runs `controllers` as [`Episodes::run_controllers_credited`] does and keeps every step of
    /// their episodes for the model (their steps alone: no credit is counted).
    fn run_kept(
        &mut self,
        world: &dyn Episodes,
        controllers: &[Controller],
        streams: Streams,
        episodes: usize,
        values: &mut [f64],
    ) -> Result<()> {
        let mut credit = StepCredit::traced(controllers.len(), 0);
        let (_, credited) = world.run_controllers_credited(controllers, streams, episodes, values, &mut credit)?;
        let traces = credit.traces.take().filter(|_| credited).ok_or_else(|| {
            Error::invalid(
                "world",
                "a world whose value is not the (discounted) sum of its steps' rewards (expected one that \
                 gives them, as a .pomdp file's, a world in Python or Gymnasium's: model-search learns \
                 from every step)",
            )
        })?;
        if traces.ends.len() != values.len() {
            let why =
                format!("the steps of {} of {} episodes came back (expected all)", traces.ends.len(), values.len());
            return Err(Error::World(why));
        }
        self.traces.append(traces);
        Ok(())
    }

    /// The rounds of the cross-entropy method over the memory's laws on the model of the kept
    /// steps: the last round's plans, best first, and the model's values of its elite.
    fn search(&mut self, sizes: Sizes, c: &ModelSearchConfig, rng: &mut EngineRng) -> (Vec<Plan>, Vec<f64>) {
        let elite_size = ((c.rho * c.memories as f64).ceil() as usize).clamp(1, c.memories);
        let (mut plans, mut elite) = (Vec::new(), Vec::new());
        for _ in 0..c.rounds {
            let memories: Vec<Controller> = (0..c.memories).map(|_| self.laws.draw(rng)).collect();
            let traces = &self.traces;
            plans = memories.par_iter().map(|m| Memory::Table(m.next.clone()).rank(sizes, traces, c, &m.act)).collect();
            // Best first; equal values keep the order drawn.
            plans.sort_by(|p, q| q.value.total_cmp(&p.value));
            // The elite as controllers (a table's plan; lenses are not refitted).
            let chosen: Vec<Controller> =
                plans[..elite_size].iter().map(|p| p.memory.controller(p.act.clone(), sizes)).collect();
            let chosen: Vec<&Controller> = chosen.iter().collect();
            self.laws.refit(&chosen, None, c.smoothing);
            elite = plans[..elite_size].iter().map(|p| p.value).collect();
        }
        (plans, elite)
    }

    /// Every lens ([`Lens::all`]) and tally ([`Tally::all`], its counts within `horizon`) planned
    /// and valued on the model of the kept steps, best first.
    fn lenses(&self, sizes: Sizes, horizon: usize, c: &ModelSearchConfig) -> Vec<Plan> {
        if c.window == 0 {
            return Vec::new();
        }
        let lenses = Lens::all(c.window, c.lens_features, sizes, c.lens_nodes).into_iter().map(Memory::Lens);
        let tallies = Tally::all(sizes, c.lens_nodes, horizon).into_iter().map(Memory::Tally);
        let memories: Vec<Memory> = lenses.chain(tallies).collect();
        let mut plans: Vec<Plan> =
            memories.par_iter().map(|m| m.rank(sizes, &self.traces, c, &vec![0; m.states(sizes)])).collect();
        plans.sort_by(|p, q| q.value.total_cmp(&p.value));
        plans
    }

    /// The steps of `episodes` selection episodes of each of `controllers`, foreseen from the
    /// kept episodes' mean length (0 before any).
    fn selection_steps(&self, controllers: usize, episodes: usize) -> u64 {
        let kept = self.traces.ends.len().max(1);
        (controllers * episodes * self.traces.steps()).div_ceil(kept) as u64
    }

    /// The selection episodes the budget in steps `left` covers (of one controller, of the kept
    /// episodes' mean length; no end without a budget).
    fn covered(&self, left: Option<u64>) -> usize {
        let each = self.selection_steps(1, 1).max(1);
        left.map_or(usize::MAX, |l| usize::try_from(l / each).unwrap_or(usize::MAX))
    }

    /// Values `first` (planned apart), then the `confirm` best distinct plans of each family in
    /// the places left, the `challengers` (the best
    /// explorer, the credited best so far), the best so far's contenders and the best so far on
    /// the iteration's selection episodes (fresh ones, the same for all: `select_episodes`, none
    /// where the budget in steps `left` would not cover them once there is a best so far, as many
    /// as it covers before); the one of the highest gain among those that beat the best so far by
    /// `margin` over every episode both were valued on replaces it (then true), else they add to
    /// its value and the one of the highest gain not below 0 contends again ([`settle`]).
    #[allow(clippy::too_many_arguments)]
    fn confirm<const F: usize>(
        &mut self,
        world: &dyn Episodes,
        c: &ModelSearchConfig,
        iteration: usize,
        sizes: Sizes,
        first: Option<Controller>,
        families: [Vec<Plan>; F],
        challengers: Vec<Controller>,
        left: &dyn Fn() -> Option<u64>,
    ) -> Result<bool> {
        let held = self.best.as_ref().map(|b| &b.controller);
        let mut few: Vec<Controller> = first.into_iter().filter(|f| held != Some(f)).collect();
        let contenders: Vec<Controller> =
            self.best.iter().flat_map(|b| b.contenders.iter().map(|c| c.controller.clone())).collect();
        // The families take turns, `confirm` plans each at most, the contenders taking the last
        // places: an iteration values as many controllers with them as without.
        let room = (F * c.confirm).saturating_sub(contenders.len());
        let mut families = families.map(|plans| (plans.into_iter(), 0));
        while few.len() < room {
            let before = few.len();
            for (plans, taken) in &mut families {
                if *taken == c.confirm || few.len() == room {
                    continue;
                }
                // Ranked on half the steps, planned on all of them.
                let next = plans
                    .map(|p| p.memory.plan(sizes, &self.traces, c, &p.act))
                    .find(|controller| !few.contains(controller) && held != Some(controller));
                if let Some(controller) = next {
                    few.push(controller);
                    *taken += 1;
                }
            }
            if few.len() == before {
                break;
            }
        }
        // The challengers, then the best's contenders (their records go on).
        for e in challengers.into_iter().chain(contenders) {
            if !few.contains(&e) && held != Some(&e) {
                few.push(e);
            }
        }
        // Near the end of a budget in steps, the first plans it covers (all `select_episodes`
        // each: fewer would let a plan replace the best so far on a lucky one or two).
        let covered = self.covered(left());
        let m = match held {
            Some(_) if covered / c.select_episodes < 2 => return Ok(false),
            Some(_) => {
                few.truncate(covered / c.select_episodes - 1);
                c.select_episodes
            }
            None => c.select_episodes.min(covered / few.len().max(1)).max(1),
        };
        few.extend(held.cloned());
        let streams = Streams { seed: c.rules.seed, purpose: Purpose::Select, iteration: iteration as u64 };
        let mut values = vec![0.0; few.len() * m];
        // The selection episodes' steps serve the model too.
        self.run_kept(world, &few, streams, m, &mut values)?;
        self.traces.keep_last(c.memory_steps);
        Ok(settle(&mut self.best, &few, &values, m, c.margin, CONTENDERS))
    }
}
