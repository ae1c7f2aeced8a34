//! The settings of the cross-entropy method (model §3) and their checks.

use serde::{Deserialize, Serialize};

use crate::ce::budget::Budget;
use crate::control::check_threads;
use crate::error::{Error, Result};
use crate::evaluate::MAX_EPISODES;
use crate::settings::{Setting, Settings};

/// The settings of one optimisation; `Default` gives the paper's (N = 1000, ρ = 0.5, α = 1,
/// weak criterion). The one home of each setting: its doc is the CLI's help (`ceworld optimize
/// --help`), its name the Python keyword ([`Settings::set`]) and the checkpoint's and policy
/// file's key.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "cli", derive(clap::Args))]
pub struct CeConfig {
    /// Episodes drawn per iteration, N.
    #[cfg_attr(feature = "cli", arg(long, default_value_t = CeConfig::default().samples))]
    pub samples: usize,
    /// Selective rate rho in (0, 1): the best ceil(rho*N) episodes refit the tables.
    #[cfg_attr(feature = "cli", arg(long, default_value_t = CeConfig::default().rho))]
    pub rho: f64,
    /// Smoothing alpha in (0, 1]: h := alpha*new + (1 - alpha)*h; 1 is the paper's basic CE.
    #[cfg_attr(feature = "cli", arg(long, default_value_t = CeConfig::default().smoothing))]
    pub smoothing: f64,
    /// The smoothing of the decision table h0 alone, in (0, 1] (default: the smoothing). A
    /// smaller value lets the memory tables take shape before the decisions settle: on tabular
    /// worlds whose optimum needs memory, the decisions otherwise lock onto the best memoryless
    /// policy within a few iterations (model §3).
    #[cfg_attr(feature = "cli", arg(long))]
    pub decision_smoothing: Option<f64>,
    /// Stop after this many consecutive unsuccessful iterations (the paper's weak criterion is
    /// 100, its strong criterion 500).
    #[cfg_attr(feature = "cli", arg(long, default_value_t = CeConfig::default().patience))]
    pub patience: usize,
    /// Stop after this many iterations.
    #[cfg_attr(feature = "cli", arg(long))]
    pub max_iterations: Option<usize>,
    /// The budgets in seconds and in the world's steps ([`Budget`]); with restarts, the runs
    /// share them (each run's score between runs included).
    #[serde(flatten)]
    #[cfg_attr(feature = "cli", command(flatten))]
    pub budget: Budget,
    /// Stop as soon as an iteration's mean reward reaches this value.
    #[cfg_attr(feature = "cli", arg(long))]
    pub target: Option<f64>,
    /// Seed of every random stream: the same seed and settings give the same policy, whatever
    /// the thread count.
    #[cfg_attr(feature = "cli", arg(long, default_value_t = CeConfig::default().seed))]
    pub seed: u64,
    /// Worker threads (default: one per core). Results do not depend on it.
    #[cfg_attr(feature = "cli", arg(long))]
    pub threads: Option<usize>,
    /// Fresh episodes used to evaluate the returned policy.
    #[cfg_attr(feature = "cli", arg(long, default_value_t = CeConfig::default().eval_episodes))]
    pub eval_episodes: usize,
    /// How the elite's memory is counted: "sampled" (the paper: the memory states that were
    /// drawn) or "forward-backward" (their posterior expectation given the episode's
    /// observations and decisions; at most 2 levels).
    #[cfg_attr(feature = "cli", arg(long, default_value = MemoryUpdate::Sampled.as_str(), value_name = "sampled|forward-backward"))]
    pub memory_update: MemoryUpdate,
    /// Independent runs (the first with the seed, the others with seeds derived from it); the
    /// one whose policy scores best on eval-episodes selection episodes is returned, evaluated
    /// on other, fresh episodes. The time limit is shared by all the runs.
    #[cfg_attr(feature = "cli", arg(long, default_value_t = CeConfig::default().restarts))]
    pub restarts: usize,
}

impl Settings for CeConfig {
    fn set(&mut self, s: &Setting<'_>) -> Result<()> {
        match s.name {
            "samples" => self.samples = s.count()?,
            "rho" => self.rho = s.real()?,
            "smoothing" => self.smoothing = s.real()?,
            "decision_smoothing" => self.decision_smoothing = s.optional_real()?,
            "patience" => self.patience = s.count()?,
            "max_iterations" => self.max_iterations = s.optional_count()?,
            name if Budget::NAMES.contains(&name) => self.budget.set(s)?,
            "target" => self.target = s.optional_real()?,
            "seed" => self.seed = s.seed()?,
            "threads" => self.threads = s.optional_count()?,
            "eval_episodes" => self.eval_episodes = s.count()?,
            "memory_update" => self.memory_update = s.choice(str::parse)?,
            "restarts" => self.restarts = s.count()?,
            other => return Err(self.unknown(other)),
        }
        Ok(())
    }
}

/// How the CE update counts the memory of the elite episodes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum MemoryUpdate {
    /// Count the memory states that were sampled (model §3, the paper).
    #[default]
    Sampled,
    /// Count their posterior expectation given the episode's observations and decisions
    /// (forward–backward, one EM step on the elite); levels `Λ <= 2` only.
    ForwardBackward,
}

impl MemoryUpdate {
    /// Every kind.
    pub const ALL: [MemoryUpdate; 2] = [MemoryUpdate::Sampled, MemoryUpdate::ForwardBackward];

    /// `"sampled"` or `"forward-backward"`.
    pub const fn as_str(self) -> &'static str {
        match self {
            MemoryUpdate::Sampled => "sampled",
            MemoryUpdate::ForwardBackward => "forward-backward",
        }
    }
}

impl std::str::FromStr for MemoryUpdate {
    type Err = Error;
    fn from_str(s: &str) -> Result<Self> {
        match s {
            "sampled" => Ok(MemoryUpdate::Sampled),
            "forward-backward" => Ok(MemoryUpdate::ForwardBackward),
            other => Err(Error::invalid(
                "memory_update",
                format!("{other:?} (expected \"sampled\" or \"forward-backward\")"),
            )),
        }
    }
}

impl Default for CeConfig {
    fn default() -> Self {
        CeConfig {
            samples: 1000,
            rho: 0.5,
            smoothing: 1.0,
            decision_smoothing: None,
            patience: 100,
            max_iterations: None,
            budget: Budget::default(),
            target: None,
            seed: 0,
            threads: None,
            eval_episodes: 10_000,
            memory_update: MemoryUpdate::Sampled,
            restarts: 1,
        }
    }
}

/// The memory sizes used when none are given: `[16, 16]`, an input/output HMM of the paper's
/// table.
pub const DEFAULT_LEVELS: [usize; 2] = [16, 16];

/// The paper's weak convergence criterion: 100 unsuccessful iterations in a row.
pub const WEAK_PATIENCE: usize = 100;
/// The paper's strong convergence criterion: 500 unsuccessful iterations in a row.
pub const STRONG_PATIENCE: usize = 500;

impl CeConfig {
    /// The stopping rules (model §3).
    pub fn stop_rules(&self) -> crate::ce::stopping::StopRules {
        crate::ce::stopping::StopRules {
            target: self.target,
            patience: self.patience,
            max_iterations: self.max_iterations,
            time_limit: self.budget.time_limit,
        }
    }

    /// Number of elite episodes, `ceil(ρN)`.
    pub fn elite_count(&self) -> usize {
        self.elite_of(self.samples)
    }

    /// Number of elite episodes of an iteration of `n` episodes (one cut by a budget in steps
    /// has fewer than N), `ceil(ρn)`.
    pub fn elite_of(&self, n: usize) -> usize {
        ((self.rho * n as f64).ceil() as usize).clamp(1, n.max(1))
    }

    /// Checks every setting, naming the bad one.
    pub fn validate(&self) -> Result<()> {
        if self.samples == 0 {
            return Err(Error::invalid("samples", "0 (expected at least 1 episode per iteration)"));
        }
        if !(self.rho > 0.0 && self.rho < 1.0) {
            return Err(Error::invalid("rho", format!("{} (expected 0 < rho < 1)", self.rho)));
        }
        if !(self.smoothing > 0.0 && self.smoothing <= 1.0) {
            return Err(Error::invalid("smoothing", format!("{} (expected 0 < smoothing <= 1)", self.smoothing)));
        }
        if let Some(d) = self.decision_smoothing
            && !(d > 0.0 && d <= 1.0)
        {
            return Err(Error::invalid("decision_smoothing", format!("{d} (expected 0 < decision_smoothing <= 1)")));
        }
        if self.patience == 0 {
            return Err(Error::invalid("patience", "0 (expected at least 1 iteration)"));
        }
        if self.max_iterations == Some(0) {
            return Err(Error::invalid("max_iterations", "0 (expected at least 1, or none)"));
        }
        self.budget.validate()?;
        if let Some(t) = self.target {
            if t.is_nan() {
                return Err(Error::invalid("target", "NaN (expected a reward)"));
            }
        }
        if let Some(n) = self.threads {
            check_threads(n)?;
        }
        if self.restarts == 0 {
            return Err(Error::invalid("restarts", "0 (expected at least 1 run)"));
        }
        if self.eval_episodes == 0 || self.eval_episodes > MAX_EPISODES {
            return Err(Error::invalid(
                "eval_episodes",
                format!("{} (expected 1..={MAX_EPISODES})", self.eval_episodes),
            ));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn memory_update_names_round_trip_and_unknown_names_are_refused() {
        for m in [MemoryUpdate::Sampled, MemoryUpdate::ForwardBackward] {
            assert_eq!(m.as_str().parse::<MemoryUpdate>().unwrap(), m);
        }
        assert_eq!(MemoryUpdate::ForwardBackward.as_str(), "forward-backward");
        let e = "viterbi".parse::<MemoryUpdate>().unwrap_err().to_string();
        assert!(e.contains("memory_update") && e.contains("viterbi"), "{e}");
    }

    #[test]
    fn settings_are_checked_at_their_bounds() {
        let ok = |c: CeConfig| c.validate().is_ok();
        let base = CeConfig::default();
        for t in [0.0, -1.0, f64::NAN] {
            assert!(!ok(CeConfig { budget: Budget::seconds(t), ..base.clone() }), "time_limit {t}");
        }
        assert!(ok(CeConfig { budget: Budget::seconds(1e-9), ..base.clone() }));
        assert!(!ok(CeConfig { eval_episodes: 0, ..base.clone() }));
        assert!(ok(CeConfig { eval_episodes: MAX_EPISODES, ..base.clone() }));
        assert!(!ok(CeConfig { eval_episodes: MAX_EPISODES + 1, ..base.clone() }));
        assert!(ok(CeConfig { threads: Some(crate::control::MAX_THREADS), ..base.clone() }));
        assert!(!ok(CeConfig { threads: Some(crate::control::MAX_THREADS + 1), ..base.clone() }));
        assert!(!ok(CeConfig { threads: Some(0), ..base.clone() }));
        for rho in [0.0, 1.0, f64::NAN] {
            assert!(!ok(CeConfig { rho, ..base.clone() }), "rho {rho}");
        }
        assert!(ok(CeConfig { rho: 0.999, ..base.clone() }));
        assert!(!ok(CeConfig { smoothing: 0.0, ..base.clone() }));
        assert!(!ok(CeConfig { decision_smoothing: Some(0.0), ..base.clone() }));
        assert!(!ok(CeConfig { decision_smoothing: Some(1.5), ..base.clone() }));
        assert!(!ok(CeConfig { decision_smoothing: Some(f64::NAN), ..base.clone() }));
        assert!(ok(CeConfig { decision_smoothing: Some(1.0), ..base.clone() }));
        assert!(ok(CeConfig { smoothing: 1.0, ..base.clone() }));
        assert!(!ok(CeConfig { samples: 0, ..base.clone() }));
        assert!(!ok(CeConfig { patience: 0, ..base.clone() }));
        assert!(!ok(CeConfig { max_iterations: Some(0), ..base.clone() }));
        assert!(!ok(CeConfig { restarts: 0, ..base.clone() }));
        assert!(!ok(CeConfig { target: Some(f64::NAN), ..base }));
    }
}
