//! The memoryless stage (model §8): where a search's memory starts once the best memoryless
//! policy is known.

use super::improve::improve;
use super::laws::Laws;
use super::{Controller, ControllerConfig, ControllerValue, Scratch, Search, Start, Values};
use crate::ce::budget::Groups;
use crate::episodes::Streams;
use crate::error::Result;
use crate::evaluate::Evaluation;
use crate::pointbased::{Budget, PointBased};
use crate::policy::Hhmm;
use crate::rng::Purpose;
use crate::world::pomdp::PomdpWorld;

use super::checkpoint::SearchState;

impl Search<'_> {
    /// The best controller of the run so far as a policy (after its first iteration).
    pub(super) fn best_policy(&self, state: &SearchState) -> Result<Hhmm> {
        let (_, best, _) = state.best.as_ref().expect("a best controller after an iteration");
        best.to_hhmm(self.y1, self.n_actions)
    }

    /// In a memoryless stage, computes what its best policy must beat ([`Search::bar`]), so
    /// that the iteration that ends the stage has it: on sampled values, on the selection
    /// episodes the budget in steps leaves, as the iteration's `groups` foresee them (all of
    /// them without one, one at least).
    pub(super) fn stage_bar(&self, state: &SearchState, groups: Option<&Groups>) -> Result<()> {
        if !self.staged(&state.laws) || self.bar.get().is_some() {
            return Ok(());
        }
        let m = self.config.select_episodes;
        self.bar_and_noise_on(groups.map_or(m, |g| g.covered(self.left(), self.n_actions, m))).map(|_| ())
    }

    /// Whether an iteration of `laws` is in a memoryless stage.
    fn staged(&self, laws: &Laws) -> bool {
        laws.nodes() == 1 && self.start.is_none() && self.config.memoryless_patience > 0
    }

    /// The episodes of the world an iteration of `laws` runs for the stage's bar: the selection
    /// episodes of every blind policy the first time, none after.
    pub(super) fn bar_episodes(&self, laws: &Laws) -> usize {
        let first = self.staged(laws) && self.bar.get().is_none();
        if first { self.n_actions * self.config.select_episodes } else { 0 }
    }

    /// What the best memoryless policy must beat to start the memory around it: every blind
    /// policy ("always `a`") on exact values by the tolerance, on sampled ones by three standard
    /// errors of its mean on the selection episodes (the best memoryless score is the most of
    /// many, biased up). The same for every run of the search, computed once.
    fn bar(&self) -> Result<f64> {
        self.bar_and_noise().map(|(bar, _)| bar)
    }

    /// The gain of the stage's best that counts as one (the stage ends after
    /// `memoryless_patience` iterations without it): 0 on exact values (the tolerance decides),
    /// on sampled ones the largest standard error of a blind policy's mean on the selection
    /// episodes, so that a memoryless policy better by noise alone does not hold the stage.
    pub(super) fn stage_noise(&self) -> Result<f64> {
        self.bar_and_noise().map(|(_, noise)| noise)
    }

    fn bar_and_noise(&self) -> Result<(f64, f64)> {
        self.bar_and_noise_on(self.config.select_episodes)
    }

    /// The bar and the noise, on `m` selection episodes where sampled and not yet computed.
    fn bar_and_noise_on(&self, m: usize) -> Result<(f64, f64)> {
        if let Some(&known) = self.bar.get() {
            return Ok(known);
        }
        let y1 = self.y1;
        let blind: Vec<Controller> =
            (0..self.n_actions as u32).map(|a| Controller::mealy(vec![a; y1], vec![0; y1], y1)).collect();
        let tolerance = self.config.tolerance;
        let bars: Vec<(f64, f64)> = match &self.values {
            Values::Exact(exact) => {
                let mut scratch = Scratch::default();
                blind.iter().map(|c| (exact.value(c, &mut scratch) + tolerance, 0.0)).collect()
            }
            Values::ExactElsewhere(_, remote) => {
                remote.exact_values(&blind, tolerance)?.into_iter().map(|v| (v + tolerance, 0.0)).collect()
            }
            Values::Sampled(world) => {
                let mut values = vec![0.0; blind.len() * m];
                let streams = Streams { seed: self.config.seed, purpose: Purpose::Select, iteration: 0 };
                self.pool.install(|| world.run_controllers(&blind, streams, m, &mut values))?;
                self.ran(values.len());
                let bar = |e: Evaluation| {
                    let se = if e.std_error.is_finite() { e.std_error } else { 0.0 };
                    (e.mean + 3.0 * se, se)
                };
                values.chunks(m).map(Evaluation::from_rewards).map(bar).collect()
            }
        };
        let known =
            bars.into_iter().fold((f64::NEG_INFINITY, 0.0_f64), |(b, n), (bar, noise)| (b.max(bar), n.max(noise)));
        Ok(*self.bar.get_or_init(|| known))
    }

    /// The memory of run `restart` after the memoryless stage: around its best policy `best`
    /// (of `value`) where that beats every blind policy, else from the template.
    pub(super) fn after_stage(&self, restart: usize, value: f64, best: &Controller) -> Result<Laws> {
        let m = self.config.memory_of(restart);
        let a = self.n_actions;
        Ok(if value > self.bar()? {
            Laws::widened(best, m.nodes, a, m.registers, m.template, m.template_weight)
        } else {
            Laws::start(m.nodes, a, self.y1, m.mealy, m.registers, m.template, m.template_weight)
        })
    }
}

/// The model start (`model_nodes`, discounted worlds): the controller built from `world`'s
/// model, improved node by node ([`improve`]), and its exact value, kept where that beats every
/// blind policy's ("always `a`").
pub(super) fn model_start(world: &PomdpWorld, config: &ControllerConfig) -> Option<(Controller, Start)> {
    if config.model_nodes == 0 || world.tables().gamma >= 1.0 {
        return None;
    }
    let budget = Budget::within(config.budget.time_limit);
    let solved = PointBased::solve(world, budget, config.seed);
    let built = solved.controller(world, config.model_nodes, config.seed);
    let values = ControllerValue::new(world, config.tolerance);
    let mut scratch = Scratch::default();
    let y1 = world.tables().n_observations() + 1;
    let blind = (0..world.tables().n_actions() as u32)
        .map(|a| values.value(&Controller::moore(vec![a], vec![0; y1]), &mut scratch))
        .fold(f64::NEG_INFINITY, f64::max);
    let built_value = values.value(&built, &mut scratch);
    let (improved, value) = improve(world, &built, config.tolerance, budget.work);
    let start =
        Start { built: built_value, value, nodes: improved.nodes(), blind, kept: value > blind + config.tolerance };
    Some((improved, start))
}
