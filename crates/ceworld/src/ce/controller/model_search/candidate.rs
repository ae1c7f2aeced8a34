//! A candidate memory of model-search (model §10) and its plan: a successor table, a lens or a
//! tally, each replayed over the kept steps, planned on their model and valued on it.

use super::super::lens::{Lens, Sizes};
use super::super::model::{AgentModel, replay};
use super::ModelSearchConfig;
use super::tally::Tally;
use crate::episodes::trace::Traces;
use crate::policy::controller::Controller;

/// A candidate memory: a successor table (its `next`), a lens or a tally.
#[derive(Clone, Debug, PartialEq)]
pub(super) enum Memory {
    Table(Vec<u32>),
    Lens(Lens),
    Tally(Tally),
}

impl Memory {
    /// Agent states.
    pub(super) fn states(&self, sizes: Sizes) -> usize {
        match self {
            Memory::Table(next) => next.len() / sizes.y,
            Memory::Lens(lens) => lens.states(sizes),
            Memory::Tally(tally) => tally.states(sizes),
        }
    }

    /// The agent state of every kept step, and how many states there are.
    pub(super) fn replay(&self, sizes: Sizes, traces: &Traces) -> (Vec<u32>, usize) {
        let states = match self {
            Memory::Table(next) => replay(next, sizes.y, traces),
            Memory::Lens(lens) => lens.replay(sizes, traces),
            Memory::Tally(tally) => tally.replay(sizes, traces),
        };
        (states, self.states(sizes))
    }

    /// The controller that decides `act[s]` in agent state `s`.
    pub(super) fn controller(&self, act: Vec<u32>, sizes: Sizes) -> Controller {
        match self {
            Memory::Table(next) => Controller::moore(act, next.clone()),
            Memory::Lens(lens) => lens.controller(&act, sizes),
            Memory::Tally(tally) => tally.controller(&act, sizes),
        }
    }

    /// Plans on the model of the kept episodes of one parity and values the plan on the model
    /// of the others (a memory of many states fits its own steps well and is valued on others);
    /// a state never reached decides as `fallback`.
    pub(super) fn rank(&self, sizes: Sizes, traces: &Traces, c: &ModelSearchConfig, fallback: &[u32]) -> Plan {
        let (states, n) = self.replay(sizes, traces);
        let [fit, held_out] = [0, 1].map(|h| AgentModel::fit(&states, n, sizes.a, traces, Some(h)));
        let backups = c.lookahead.saturating_mul(held_out.longest.max(fit.longest));
        let planned = fit.plan(traces.gamma, backups, c.pessimism, fallback);
        let value = held_out.evaluate(&planned.act, traces.gamma, backups);
        Plan { memory: self.clone(), act: planned.act, value }
    }

    /// The controller planned on the model of every kept episode.
    pub(super) fn plan(&self, sizes: Sizes, traces: &Traces, c: &ModelSearchConfig, fallback: &[u32]) -> Controller {
        let (states, n) = self.replay(sizes, traces);
        let model = AgentModel::fit(&states, n, sizes.a, traces, None);
        let backups = c.lookahead.saturating_mul(model.longest);
        self.controller(model.plan(traces.gamma, backups, c.pessimism, fallback).act, sizes)
    }
}

/// A memory with the decisions planned on half the kept episodes, and their value on the model
/// of the other half.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct Plan {
    pub(super) memory: Memory,
    /// The decision of each agent state.
    pub(super) act: Vec<u32>,
    pub(super) value: f64,
}
