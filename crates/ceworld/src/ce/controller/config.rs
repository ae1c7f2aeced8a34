//! The settings of a controller search (model §8): how values are known, the memory the laws
//! start from, and every number of the search.

use serde::{Deserialize, Serialize};

pub use crate::ce::budget::Budget;
use crate::error::{Error, Result};
use crate::settings::{Given, Setting, Settings};

use super::memory::{CLOCK_NODES, CLOCK_WEIGHT};
pub use super::memory::{Memory, RunMemory, Template};

/// Most controllers of one iteration.
pub const MAX_SAMPLES: usize = 10_000_000;
/// Most runs of one search.
pub const MAX_RESTARTS: usize = 10_000;
/// Most episodes of one iteration of a search on sampled values (`samples · episodes`).
pub const MAX_ITERATION_EPISODES: usize = 100_000_000;

/// How each controller's value is known.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ValueKind {
    /// Computed exactly (a tabular world only).
    Exact,
    /// Estimated from sampled episodes, on common random numbers (any world).
    Sampled,
}

impl ValueKind {
    /// `"exact"` or `"sampled"`.
    pub fn as_str(self) -> &'static str {
        match self {
            ValueKind::Exact => "exact",
            ValueKind::Sampled => "sampled",
        }
    }

    /// The kind named `name`, or an error listing both.
    pub fn parse(name: &str) -> Result<ValueKind> {
        match name {
            "exact" => Ok(ValueKind::Exact),
            "sampled" => Ok(ValueKind::Sampled),
            other => Err(Error::invalid("value", format!("{other:?} (expected \"exact\" or \"sampled\")"))),
        }
    }
}

/// What a controller's decision reads (model §8).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Decisions {
    /// The node alone (a Moore machine): the node after the observation decides.
    Moore,
    /// The node and the observation (a Mealy machine): the node before the observation decides
    /// on it, so that one node is a memoryless policy.
    Mealy,
}

impl Decisions {
    /// `"moore"` or `"mealy"`.
    pub fn as_str(self) -> &'static str {
        match self {
            Decisions::Moore => "moore",
            Decisions::Mealy => "mealy",
        }
    }

    /// The kind named `name`, or an error listing both.
    pub fn parse(name: &str) -> Result<Decisions> {
        match name {
            "moore" => Ok(Decisions::Moore),
            "mealy" => Ok(Decisions::Mealy),
            other => Err(Error::invalid("decisions", format!("{other:?} (expected \"moore\" or \"mealy\")"))),
        }
    }
}

/// What refits the decision laws of a search on sampled values (model §8).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Credit {
    /// Each step of every controller's episodes, on a world outside the engine whose value is
    /// the discounted sum of its steps' rewards: a decision row's law moves onto the decision
    /// whose steps had the highest mean value still to come ([`crate::episodes::credit`]);
    /// elsewhere the elite.
    Steps,
    /// The elite controllers' decisions, as the successor laws.
    Elite,
}

impl Credit {
    /// The credit named `name`, or an error listing both.
    pub fn parse(name: &str) -> Result<Credit> {
        match name {
            "steps" => Ok(Credit::Steps),
            "elite" => Ok(Credit::Elite),
            other => Err(Error::invalid("credit", format!("{other:?} (expected \"steps\" or \"elite\")"))),
        }
    }
}

/// The settings of a controller search; `Default` gives settings that suit the small files of
/// `data/pomdp/` (model §8), [`ControllerConfig::defaults_for`] those of each kind of value. The
/// one home of each setting: its doc is the CLI's help (`ceworld controller --help`), its name
/// the Python keyword ([`Settings::set`]) and the checkpoint's and policy file's key. The
/// settings whose default depends on the kind of value (`samples`, `rho`, `smoothing`,
/// `template`, `decisions`, `memoryless_patience`, `memory`) are the CLI's own options.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "cli", derive(clap::Args))]
pub struct ControllerConfig {
    /// Nodes of the controller, n (where no model start is kept: see `model_nodes`).
    #[cfg_attr(feature = "cli", arg(long, default_value_t = ControllerConfig::default().nodes))]
    pub nodes: usize,
    /// Controllers drawn per iteration, N.
    #[cfg_attr(feature = "cli", arg(skip = ControllerConfig::default().samples))]
    pub samples: usize,
    /// Selective rate ρ in (0, 1): the best `ceil(ρN)` controllers refit the laws.
    #[cfg_attr(feature = "cli", arg(skip = ControllerConfig::default().rho))]
    pub rho: f64,
    /// Smoothing alpha in (0, 1]: p := alpha*(elite frequency) + (1 - alpha)*p.
    #[cfg_attr(feature = "cli", arg(skip = ControllerConfig::default().smoothing))]
    pub smoothing: f64,
    /// Stop after this many iterations in a row without progress: neither a better controller
    /// nor a higher elite threshold.
    #[cfg_attr(feature = "cli", arg(long, default_value_t = ControllerConfig::default().patience))]
    pub patience: usize,
    /// Stop after this many iterations.
    #[cfg_attr(feature = "cli", arg(long))]
    pub max_iterations: Option<usize>,
    /// Stop once the best value so far reaches this.
    #[cfg_attr(feature = "cli", arg(long))]
    pub target: Option<f64>,
    /// The budgets in seconds and in the world's steps ([`Budget`]; a budget in steps on
    /// sampled values only). The runs share them; with `memory="alternate"`, each run of the
    /// first round but the last ends at its share of the time limit (`memory::ALTERNATE_SHARES`).
    #[serde(flatten)]
    #[cfg_attr(feature = "cli", command(flatten))]
    pub budget: Budget,
    /// Absolute tolerance of each controller's infinite-horizon value (discount below 1), and
    /// the least gain that counts as progress.
    #[cfg_attr(feature = "cli", arg(long, default_value_t = ControllerConfig::default().tolerance))]
    pub tolerance: f64,
    /// Seed of every random stream: the same seed and settings give the same controller,
    /// whatever the thread count.
    #[cfg_attr(feature = "cli", arg(long, default_value_t = ControllerConfig::default().seed))]
    pub seed: u64,
    /// Worker threads (default: one per core). Results do not depend on it.
    #[cfg_attr(feature = "cli", arg(long))]
    pub threads: Option<usize>,
    /// Independent runs (the first with the seed, the others with seeds derived from it); the
    /// best controller of all is returned. The time limit is shared by all the runs. 0: runs
    /// follow one another until the time limit or the target (one run without a time limit).
    #[cfg_attr(feature = "cli", arg(long, default_value_t = ControllerConfig::default().restarts))]
    pub restarts: usize,
    /// Sampled values: episodes per controller and iteration, K, the same K world streams for
    /// every controller of an iteration (new ones each iteration).
    #[cfg_attr(feature = "cli", arg(long, default_value_t = ControllerConfig::default().episodes))]
    pub episodes: usize,
    /// Sampled values: the iteration's best `candidates` controllers (by their K-episode
    /// value) are scored again on the selection episodes, and the best so far is the best on
    /// those (so that a lucky K-episode value cannot be kept).
    #[cfg_attr(feature = "cli", arg(long, default_value_t = ControllerConfig::default().candidates))]
    pub candidates: usize,
    /// Sampled values: the selection episodes (the same for every iteration and run).
    #[cfg_attr(feature = "cli", arg(long, default_value_t = ControllerConfig::default().select_episodes))]
    pub select_episodes: usize,
    /// Sampled values: fresh episodes that give the value reported for the controller returned
    /// (episodes it was not chosen on).
    #[cfg_attr(feature = "cli", arg(long, default_value_t = ControllerConfig::default().eval_episodes))]
    pub eval_episodes: usize,
    /// Escapes from a converged run: when patience runs out, mix this weight of the uniform law
    /// into every law and go on, at most `injections` times (Omidshafiei et al. 2017).
    #[cfg_attr(feature = "cli", arg(long, default_value_t = ControllerConfig::default().injection))]
    pub injection: f64,
    /// The most entropy injections of one run (0: a run stops when patience runs out).
    #[cfg_attr(feature = "cli", arg(long, default_value_t = ControllerConfig::default().injections))]
    pub injections: usize,
    /// Escapes by growth: when patience runs out and no injection is left, at most this many
    /// times, the laws start again around the best controller of the run with one node more
    /// (the new node a copy of the node it enters most, `injection` of the uniform law mixed
    /// in), and the run goes on; the controller returned may have up to `nodes + growths` nodes.
    #[cfg_attr(feature = "cli", arg(long, default_value_t = ControllerConfig::default().growths))]
    pub growths: usize,
    /// Discounted tabular worlds (a `.pomdp` file, valued here or on a backend): the most nodes
    /// of the controller built from the world's model (point-based values over beliefs met on the way, made into a controller:
    /// model §8). Where it beats every blind policy it is kept: the search then has its nodes
    /// (instead of `nodes`), the laws start around it (its choices at `template_weight`) and
    /// the first iteration values it, so that the search returns nothing worse. 0: no model
    /// start.
    #[cfg_attr(feature = "cli", arg(long, default_value_t = ControllerConfig::default().model_nodes))]
    #[serde(default)]
    pub model_nodes: usize,
    /// The memory the laws start from (where there is no model start).
    #[cfg_attr(feature = "cli", arg(skip = ControllerConfig::default().template))]
    pub template: Template,
    /// The weight of the template in the first successor laws (of the model start's choices in
    /// every first law), in [0, 1).
    #[cfg_attr(feature = "cli", arg(long, default_value_t = ControllerConfig::default().template_weight))]
    pub template_weight: f64,
    /// What a decision reads: the node (`moore`) or the node and the observation (`mealy`).
    #[cfg_attr(feature = "cli", arg(skip = ControllerConfig::default().decisions))]
    #[serde(default = "moore")]
    pub decisions: Decisions,
    /// A memoryless stage first (Mealy decisions, no model start kept): the laws start with one
    /// node (a memoryless policy) and widen to `nodes` nodes around the best one after this
    /// many iterations without a better controller (three times as many in all at most); 0: no
    /// memoryless stage.
    #[cfg_attr(feature = "cli", arg(skip = ControllerConfig::default().memoryless_patience))]
    #[serde(default)]
    pub memoryless_patience: usize,
    /// The memory's layout (where no model start is kept): `nodes` (flat nodes), `registers`
    /// (factored: `registers` registers of `register_size` values, Mealy decisions) or
    /// `alternate` (runs take turns between the two).
    #[cfg_attr(feature = "cli", arg(skip = ControllerConfig::default().memory))]
    #[serde(default = "flat")]
    pub memory: Memory,
    /// Registers of a factored memory: register `i` moves on the observation and register
    /// `i − 1` (cyclically), so that the laws grow as `registers·register_size³` rather than
    /// `nodes²`; with the `window` template they start as a shift register of the last
    /// `registers` observations.
    #[cfg_attr(feature = "cli", arg(long, default_value_t = ControllerConfig::default().registers))]
    #[serde(default = "default_registers")]
    pub registers: usize,
    /// Values of each register of a factored memory (the first register's `window` template
    /// copies the observation modulo this).
    #[cfg_attr(feature = "cli", arg(long, default_value_t = ControllerConfig::default().register_size))]
    #[serde(default = "default_register_size")]
    pub register_size: usize,
    /// What refits the decision laws on sampled values: `steps` (credit within episodes: each
    /// decision row moves onto the decision whose steps had the most value still to come, over
    /// every controller's episodes, on a world outside the engine (Python, Gymnasium) whose value
    /// is the sum of its steps' rewards; on every other world the elite) or `elite` (the elite
    /// controllers' decisions).
    #[cfg_attr(feature = "cli", arg(long, value_parser = |t: &str| Credit::parse(t).map_err(|e| e.to_string()), default_value = "steps", value_name = "steps|elite"))]
    #[serde(default = "elite")]
    pub credit: Credit,
}

/// The decisions of a checkpoint written before they could be chosen.
fn moore() -> Decisions {
    Decisions::Moore
}

/// The credit of a checkpoint written before it could be chosen.
fn elite() -> Credit {
    Credit::Elite
}

/// The memory of a checkpoint written before it could be chosen.
fn flat() -> Memory {
    Memory::Nodes
}

/// The registers of a checkpoint written before they could be chosen: the default.
fn default_registers() -> usize {
    ControllerConfig::default().registers
}

/// The register size of a checkpoint written before it could be chosen: the default.
fn default_register_size() -> usize {
    ControllerConfig::default().register_size
}

impl Settings for ControllerConfig {
    fn set(&mut self, s: &Setting<'_>) -> Result<()> {
        // `None` leaves a setting whose default depends on the kind of value at that default.
        if s.value == Given::Nothing
            && matches!(
                s.name,
                "samples" | "rho" | "smoothing" | "template" | "decisions" | "memoryless_patience" | "memory"
            )
        {
            return Ok(());
        }
        match s.name {
            "nodes" => self.nodes = s.count()?,
            "samples" => self.samples = s.count()?,
            "rho" => self.rho = s.real()?,
            "smoothing" => self.smoothing = s.real()?,
            "patience" => self.patience = s.count()?,
            "max_iterations" => self.max_iterations = s.optional_count()?,
            "target" => self.target = s.optional_real()?,
            name if Budget::NAMES.contains(&name) => self.budget.set(s)?,
            "tolerance" => self.tolerance = s.real()?,
            "seed" => self.seed = s.seed()?,
            "threads" => self.threads = s.optional_count()?,
            "restarts" => self.restarts = s.count()?,
            "episodes" => self.episodes = s.count()?,
            "candidates" => self.candidates = s.count()?,
            "select_episodes" => self.select_episodes = s.count()?,
            "eval_episodes" => self.eval_episodes = s.count()?,
            "injection" => self.injection = s.real()?,
            "injections" => self.injections = s.count()?,
            "growths" => self.growths = s.count()?,
            "model_nodes" => self.model_nodes = s.count()?,
            "template" => self.template = s.choice(Template::parse)?,
            "template_weight" => self.template_weight = s.real()?,
            "decisions" => self.decisions = s.choice(Decisions::parse)?,
            "memoryless_patience" => self.memoryless_patience = s.count()?,
            "memory" => self.memory = s.choice(Memory::parse)?,
            "registers" => self.registers = s.count()?,
            "register_size" => self.register_size = s.count()?,
            "credit" => self.credit = s.choice(Credit::parse)?,
            other => return Err(self.unknown(other)),
        }
        Ok(())
    }
}

impl Default for ControllerConfig {
    fn default() -> Self {
        ControllerConfig {
            nodes: 8,
            samples: 2000,
            rho: 0.02,
            smoothing: 0.1,
            patience: 50,
            max_iterations: None,
            target: None,
            budget: Budget::default(),
            tolerance: 1e-6,
            seed: 0,
            threads: None,
            restarts: 0,
            episodes: 20,
            candidates: 4,
            select_episodes: 200,
            eval_episodes: 10_000,
            injection: 0.2,
            injections: 0,
            growths: 0,
            model_nodes: 64,
            template: Template::Uniform,
            template_weight: 0.5,
            decisions: Decisions::Moore,
            memoryless_patience: 0,
            memory: Memory::Nodes,
            registers: 3,
            register_size: 4,
            credit: Credit::Steps,
        }
    }
}

impl ControllerConfig {
    /// The defaults of a search on `kind` values: [`Default`]'s on exact values; on sampled ones
    /// `N = 200`, `ρ = 0.05`, `α = 0.25` and the `mixed` template (with `K = 20` and 200
    /// selection episodes, the defaults of every search, used by sampled ones alone), Mealy decisions
    /// after a memoryless stage, so that the memory only adds to the best memoryless policy,
    /// and runs that alternate between flat nodes and a shift register: chosen by measurement
    /// (model §8).
    pub fn defaults_for(kind: ValueKind) -> ControllerConfig {
        match kind {
            ValueKind::Exact => ControllerConfig::default(),
            ValueKind::Sampled => ControllerConfig {
                samples: 200,
                rho: 0.05,
                smoothing: 0.25,
                template: Template::Mixed,
                decisions: Decisions::Mealy,
                memoryless_patience: 10,
                memory: Memory::Alternate,
                ..ControllerConfig::default()
            },
        }
    }

    /// The most runs: `restarts`, or for 0 as many as the time limit allows (one without one).
    pub fn runs(&self) -> usize {
        match (self.restarts, self.budget.time_limit) {
            (0, Some(_)) => MAX_RESTARTS,
            (0, None) => 1,
            (n, _) => n,
        }
    }

    /// The memory of run `restart` (where no model start is kept).
    pub fn memory_of(&self, restart: usize) -> RunMemory {
        let flat = RunMemory {
            nodes: self.nodes,
            registers: 0,
            template: self.template,
            template_weight: self.template_weight,
            mealy: self.decisions == Decisions::Mealy,
            staged: false,
        };
        let factored = RunMemory {
            nodes: self.register_nodes().unwrap_or(usize::MAX),
            registers: self.registers,
            mealy: true,
            ..flat
        };
        let clock = RunMemory {
            nodes: CLOCK_NODES,
            template: Template::Clock,
            template_weight: CLOCK_WEIGHT,
            mealy: false,
            ..flat
        };
        let m = match (self.memory, restart % 3) {
            (Memory::Nodes, _) | (Memory::Alternate, 0) => flat,
            (Memory::Registers, _) => factored,
            (Memory::Alternate, 1) => RunMemory { template: Template::Window, ..factored },
            (Memory::Clock | Memory::Alternate, _) => clock,
        };
        RunMemory { staged: self.memoryless_patience > 0 && m.mealy, ..m }
    }

    /// The nodes of a factored memory: `register_size^registers` (`None` past `usize`).
    fn register_nodes(&self) -> Option<usize> {
        u32::try_from(self.registers).ok().and_then(|r| self.register_size.checked_pow(r))
    }

    /// The stopping rules (model §8); the time limit covers every run together.
    pub fn stop_rules(&self) -> crate::ce::stopping::StopRules {
        crate::ce::stopping::StopRules {
            target: self.target,
            patience: self.patience,
            max_iterations: self.max_iterations,
            time_limit: self.budget.time_limit,
        }
    }

    /// Number of elite controllers, `ceil(ρN)`.
    pub fn elite_count(&self) -> usize {
        ((self.rho * self.samples as f64).ceil() as usize).clamp(1, self.samples)
    }

    /// Refuses settings out of range, naming the value and what was expected.
    pub fn validate(&self) -> Result<()> {
        if self.nodes == 0 || self.nodes > crate::policy::MAX_LEVEL_SIZE {
            return Err(Error::invalid(
                "nodes",
                format!("{} (expected 1..={})", self.nodes, crate::policy::MAX_LEVEL_SIZE),
            ));
        }
        if self.growths > crate::policy::MAX_LEVEL_SIZE - self.nodes {
            return Err(Error::invalid(
                "growths",
                format!("{} (expected nodes + growths <= {})", self.growths, crate::policy::MAX_LEVEL_SIZE),
            ));
        }
        if self.model_nodes > crate::policy::MAX_LEVEL_SIZE - self.growths {
            return Err(Error::invalid(
                "model_nodes",
                format!("{} (expected model_nodes + growths <= {})", self.model_nodes, crate::policy::MAX_LEVEL_SIZE),
            ));
        }
        if self.samples == 0 || self.samples > MAX_SAMPLES {
            return Err(Error::invalid("samples", format!("{} (expected 1..={MAX_SAMPLES})", self.samples)));
        }
        if !(self.rho > 0.0 && self.rho < 1.0) {
            return Err(Error::invalid("rho", format!("{} (expected 0 < rho < 1)", self.rho)));
        }
        if !(self.smoothing > 0.0 && self.smoothing <= 1.0) {
            return Err(Error::invalid("smoothing", format!("{} (expected 0 < smoothing <= 1)", self.smoothing)));
        }
        if self.patience == 0 {
            return Err(Error::invalid("patience", "0 (expected at least 1)"));
        }
        if self.max_iterations == Some(0) {
            return Err(Error::invalid("max_iterations", "0 (expected at least 1, or none)"));
        }
        if let Some(t) = self.target
            && !t.is_finite()
        {
            return Err(Error::invalid("target", format!("{t} (expected a finite number)")));
        }
        self.budget.validate()?;
        if !(self.tolerance > 0.0 && self.tolerance.is_finite()) {
            return Err(Error::invalid("tolerance", format!("{} (expected a positive number)", self.tolerance)));
        }
        if let Some(n) = self.threads {
            crate::control::check_threads(n)?;
        }
        if self.restarts > MAX_RESTARTS {
            return Err(Error::invalid("restarts", format!("{} (expected 0..={MAX_RESTARTS})", self.restarts)));
        }
        let most = MAX_ITERATION_EPISODES / self.samples;
        if self.episodes == 0 || self.episodes > most {
            return Err(Error::invalid(
                "episodes",
                format!("{} (expected 1..={most}: samples × episodes at most {MAX_ITERATION_EPISODES})", self.episodes),
            ));
        }
        if self.candidates == 0 || self.candidates > self.samples {
            return Err(Error::invalid(
                "candidates",
                format!("{} (expected 1..={}, the samples)", self.candidates, self.samples),
            ));
        }
        crate::evaluate::check_episodes(self.select_episodes).map_err(|_| {
            Error::invalid(
                "select_episodes",
                format!("{} (expected 1..={})", self.select_episodes, crate::evaluate::MAX_EPISODES),
            )
        })?;
        crate::evaluate::check_episodes(self.eval_episodes).map_err(|_| {
            Error::invalid(
                "eval_episodes",
                format!("{} (expected 1..={})", self.eval_episodes, crate::evaluate::MAX_EPISODES),
            )
        })?;
        if !(self.template_weight >= 0.0 && self.template_weight < 1.0) {
            return Err(Error::invalid(
                "template_weight",
                format!("{} (expected 0 <= template_weight < 1)", self.template_weight),
            ));
        }
        if !(self.injection > 0.0 && self.injection <= 1.0) {
            return Err(Error::invalid("injection", format!("{} (expected 0 < injection <= 1)", self.injection)));
        }
        self.validate_memory()
    }

    /// Refuses a memory that does not fit: registers or a memoryless stage without Mealy
    /// decisions, registers too few, too small or too many nodes.
    fn validate_memory(&self) -> Result<()> {
        let needs_mealy: Vec<String> = [
            // A clock's decisions are its own (Moore), and it has no memoryless stage.
            (self.memoryless_patience > 0 && self.memory != Memory::Clock)
                .then(|| format!("memoryless_patience {}", self.memoryless_patience)),
            matches!(self.memory, Memory::Registers | Memory::Alternate)
                .then(|| format!("memory \"{}\"", self.memory.as_str())),
        ]
        .into_iter()
        .flatten()
        .collect();
        if self.decisions != Decisions::Mealy && !needs_mealy.is_empty() {
            let name = if self.memoryless_patience > 0 { "memoryless_patience" } else { "memory" };
            return Err(Error::invalid(
                name,
                format!(
                    "{} with decisions \"{}\" (a memoryless stage and registers need decisions \"mealy\": one \
                     Moore node is a blind policy; or memoryless_patience 0 and memory \"nodes\" or \"clock\")",
                    needs_mealy.join(" and "),
                    self.decisions.as_str()
                ),
            ));
        }
        if matches!(self.memory, Memory::Registers | Memory::Alternate) {
            let nodes = self.register_nodes();
            if self.registers < 2 || self.register_size < 2 || nodes.is_none_or(|n| n > crate::policy::MAX_LEVEL_SIZE) {
                return Err(Error::invalid(
                    "registers",
                    format!(
                        "{} of register_size {} (expected at least 2 registers of at least 2 values, \
                         register_size^registers <= {})",
                        self.registers,
                        self.register_size,
                        crate::policy::MAX_LEVEL_SIZE
                    ),
                ));
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn runs_alternate_between_flat_nodes_a_shift_register_and_a_clock() {
        let sampled = ControllerConfig::defaults_for(ValueKind::Sampled);
        assert_eq!(sampled.memory, Memory::Alternate);
        let shape = |m: RunMemory| (m.nodes, m.registers, m.template, m.template_weight, m.mealy);
        assert_eq!(shape(sampled.memory_of(0)), (8, 0, Template::Mixed, 0.5, true));
        assert_eq!(shape(sampled.memory_of(1)), (64, 3, Template::Window, 0.5, true));
        assert_eq!(shape(sampled.memory_of(2)), (64, 0, Template::Clock, 0.99, false));
        assert_eq!(sampled.memory_of(3), sampled.memory_of(0));
        assert_eq!(sampled.most_nodes(), 64);
        let exact = ControllerConfig { growths: 2, ..ControllerConfig::default() };
        assert_eq!((shape(exact.memory_of(1)), exact.most_nodes()), ((8, 0, Template::Uniform, 0.5, false), 10));
        let registers = ControllerConfig { memory: Memory::Registers, register_size: 3, ..sampled };
        assert_eq!((shape(registers.memory_of(0)), registers.most_nodes()), ((27, 3, Template::Mixed, 0.5, true), 27));
        // A clock is a Moore machine without a memoryless stage, whatever the decisions asked.
        let clock = ControllerConfig { memory: Memory::Clock, decisions: Decisions::Moore, ..sampled };
        assert!(clock.validate().is_ok());
        assert_eq!(clock.memory_of(5), sampled.memory_of(2));
        for name in ["nodes", "registers", "clock", "alternate"] {
            assert_eq!(Memory::parse(name).unwrap().as_str(), name);
        }
        assert!(Memory::parse("flat").unwrap_err().to_string().contains("\"alternate\""));
    }
}
