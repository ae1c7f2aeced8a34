//! The stopping rules every optimiser shares (model §3, §8): a target reached, patience run out,
//! the most iterations, the time limit; checked in that order after each iteration.

use serde::{Deserialize, Serialize};

use crate::control::Flow;
use crate::error::Result;
use crate::policy::Hhmm;

/// Why an optimisation stopped.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum StopReason {
    /// `patience` unsuccessful iterations in a row (converged).
    Patience,
    /// `max_iterations` reached.
    MaxIterations,
    /// `time_limit` reached.
    TimeLimit,
    /// `max_env_steps` of the world taken by learning ([`crate::ce::budget::Budget`]).
    MaxEnvSteps,
    /// An iteration's mean reached `target`.
    Target,
    /// The caller asked to stop (Ctrl-C).
    Interrupted,
    /// The caller's per-iteration callback asked to stop ([`crate::control::Flow::Finish`]).
    Callback,
}

impl StopReason {
    /// The snake-case name (`"patience"`, `"interrupted"`, ...).
    pub fn as_str(self) -> &'static str {
        match self {
            StopReason::Patience => "patience",
            StopReason::MaxIterations => "max_iterations",
            StopReason::TimeLimit => "time_limit",
            StopReason::MaxEnvSteps => "max_env_steps",
            StopReason::Target => "target",
            StopReason::Interrupted => "interrupted",
            StopReason::Callback => "callback",
        }
    }

    /// Why an observer's answer stops the run, if it does: [`StopReason::Interrupted`] for
    /// [`Flow::Stop`], [`StopReason::Callback`] for [`Flow::Finish`].
    pub fn asked(flow: Flow) -> Option<StopReason> {
        match flow {
            Flow::Continue => None,
            Flow::Stop => Some(StopReason::Interrupted),
            Flow::Finish => Some(StopReason::Callback),
        }
    }

    /// Whether the caller stopped the run (Ctrl-C, a callback) rather than a stopping rule: the
    /// run's state stays in its checkpoint, to be continued, and no later restart starts.
    pub fn halted(self) -> bool {
        matches!(self, StopReason::Interrupted | StopReason::Callback)
    }
}

/// One iteration as an optimiser shows it to its observer, which may stop the run
/// ([`StopReason::asked`]): its record (`step`) and, on demand, the best policy so far (made only
/// when asked: a copy of its tables).
pub struct Observed<'a, S> {
    /// The iteration's record (the optimiser's history entry).
    pub step: &'a S,
    /// The best policy so far (of the current run, where there are restarts).
    pub best: &'a dyn Fn() -> Result<Hhmm>,
    /// The run it belongs to among the restarts (from 0; 0 without restarts).
    pub run: usize,
    /// The iterations of the call's runs before this one (kept across a resume): the
    /// iteration's number counted on across the runs is this plus its own.
    pub earlier: usize,
}

/// When an optimisation stops.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StopRules {
    /// Stop once the optimiser's value (an iteration's mean for the CE method, the best so far
    /// for the controller search) reaches this.
    pub target: Option<f64>,
    /// Stop after this many iterations in a row without progress.
    pub patience: usize,
    /// Stop after this many iterations.
    pub max_iterations: Option<usize>,
    /// Stop after this many seconds.
    pub time_limit: Option<f64>,
}

impl StopRules {
    /// The rule that holds after `iterations` iterations whose value is `value`, with
    /// `unsuccessful` iterations in a row without progress, `seconds` into the run, if any.
    pub fn check(&self, iterations: usize, value: f64, unsuccessful: usize, seconds: f64) -> Option<StopReason> {
        if self.target.is_some_and(|t| value >= t) {
            Some(StopReason::Target)
        } else if unsuccessful >= self.patience {
            Some(StopReason::Patience)
        } else if self.max_iterations.is_some_and(|m| iterations >= m) {
            Some(StopReason::MaxIterations)
        } else if self.time_limit.is_some_and(|t| seconds >= t) {
            Some(StopReason::TimeLimit)
        } else {
            None
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stop_reasons_have_snake_case_names() {
        let names: Vec<_> = [
            StopReason::Patience,
            StopReason::MaxIterations,
            StopReason::TimeLimit,
            StopReason::MaxEnvSteps,
            StopReason::Target,
            StopReason::Interrupted,
            StopReason::Callback,
        ]
        .iter()
        .map(|s| s.as_str())
        .collect();
        assert_eq!(
            names,
            ["patience", "max_iterations", "time_limit", "max_env_steps", "target", "interrupted", "callback"]
        );
        for (reason, name) in [(StopReason::Callback, "\"callback\""), (StopReason::Interrupted, "\"interrupted\"")] {
            assert_eq!(serde_json::to_string(&reason).unwrap(), name);
        }
        assert!(StopReason::Callback.halted() && StopReason::Interrupted.halted() && !StopReason::Target.halted());
        assert_eq!(StopReason::asked(Flow::Continue), None);
        assert_eq!(StopReason::asked(Flow::Stop), Some(StopReason::Interrupted));
        assert_eq!(StopReason::asked(Flow::Finish), Some(StopReason::Callback));
    }

    #[test]
    fn rules_hold_at_their_bounds_in_order() {
        let rules = StopRules { target: Some(10.0), patience: 3, max_iterations: Some(5), time_limit: Some(2.0) };
        assert_eq!(rules.check(1, 9.9, 2, 1.9), None);
        assert_eq!(rules.check(1, 10.0, 3, 2.0), Some(StopReason::Target));
        assert_eq!(rules.check(5, 9.0, 3, 2.0), Some(StopReason::Patience));
        assert_eq!(rules.check(5, 9.0, 2, 2.0), Some(StopReason::MaxIterations));
        assert_eq!(rules.check(4, 9.0, 2, 2.0), Some(StopReason::TimeLimit));
        let none = StopRules { target: None, patience: 1, max_iterations: None, time_limit: None };
        assert_eq!(none.check(1_000_000, f64::INFINITY, 0, 1e9), None);
    }
}
