//! The memory of the controllers a search draws (model §8): its layout (flat nodes or
//! registers) and the templates its first laws lean towards.

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};

/// How a controller's memory is laid out in the laws (model §8).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Memory {
    /// `nodes` flat nodes: one successor law per node and observation.
    Nodes,
    /// `registers` registers of `register_size` values (`register_size^registers` nodes),
    /// each moving on the observation and the register before it.
    Registers,
    /// A clock of [`CLOCK_NODES`] nodes: node `t` is step `t` (the last node holds), kept at
    /// [`CLOCK_WEIGHT`], with Moore decisions: a time-indexed, open-loop policy whose decisions
    /// the credit within episodes learns.
    Clock,
    /// Runs take turns between three memories: flat nodes from `template`, registers from the
    /// `window` template (a shift register of the last observations), then the clock; the best
    /// run is kept. In the first round, the first run ends by [`ALTERNATE_SHARES`]`[0]` of the
    /// time limit and the second by [`ALTERNATE_SHARES`]`[1]`.
    Alternate,
}

/// The nodes of a clock: the first 64 steps each have their own node.
pub const CLOCK_NODES: usize = 64;
/// The weight of the clock template in a clock's successor laws: the clock is kept.
pub const CLOCK_WEIGHT: f64 = 0.99;
/// Where the first and second runs of alternating memories end, as fractions of the time limit.
pub const ALTERNATE_SHARES: [f64; 2] = [0.5, 0.95];

impl Memory {
    /// `"nodes"`, `"registers"`, `"clock"` or `"alternate"`.
    pub fn as_str(self) -> &'static str {
        match self {
            Memory::Nodes => "nodes",
            Memory::Registers => "registers",
            Memory::Clock => "clock",
            Memory::Alternate => "alternate",
        }
    }

    /// The layout named `name`, or an error listing them.
    pub fn parse(name: &str) -> Result<Memory> {
        match name {
            "nodes" => Ok(Memory::Nodes),
            "registers" => Ok(Memory::Registers),
            "clock" => Ok(Memory::Clock),
            "alternate" => Ok(Memory::Alternate),
            other => Err(Error::invalid(
                "memory",
                format!("{other:?} (expected \"nodes\", \"registers\", \"clock\" or \"alternate\")"),
            )),
        }
    }
}

/// The memory of one run where no model start is kept: the first laws it draws from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RunMemory {
    /// Nodes of its controllers.
    pub nodes: usize,
    /// Registers of a factored memory (0: flat nodes).
    pub registers: usize,
    /// The template its first successor laws lean towards, and the template's weight there.
    pub template: Template,
    pub template_weight: f64,
    /// Whether its decisions read the observation too (Mealy) or the node alone (Moore).
    pub mealy: bool,
    /// Whether it starts with a memoryless stage (Mealy decisions and a memoryless patience).
    pub staged: bool,
}

/// The memory a search starts from (its first laws): every successor law is the uniform law
/// with `template_weight` of it moved onto the template's successor.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Template {
    /// No template: uniform laws.
    Uniform,
    /// A latch: every node but the start node stays where it is, whatever it observes, so
    /// that what the first observations chose is held.
    Hold,
    /// A clock: node `q` moves on to `q + 1` (the last node stays), whatever it observes.
    Clock,
    /// The weight shared by `Hold` and `Clock` (the start node: all on `Clock`).
    Mixed,
    /// A window of the last observations (a shift register): after observation `y` node `q`
    /// moves to `(q·Y + y) mod n`, so that with `n = Y^k` nodes a node is the last `k`
    /// observations (frame stacking).
    Window,
}

impl Template {
    /// Every template, in the order of their names.
    pub const ALL: [Template; 5] =
        [Template::Uniform, Template::Hold, Template::Clock, Template::Mixed, Template::Window];

    /// `"uniform"`, `"hold"`, `"clock"`, `"mixed"` or `"window"`.
    pub fn as_str(self) -> &'static str {
        match self {
            Template::Uniform => "uniform",
            Template::Hold => "hold",
            Template::Clock => "clock",
            Template::Mixed => "mixed",
            Template::Window => "window",
        }
    }

    /// The template named `name`, or an error listing them.
    pub fn parse(name: &str) -> Result<Template> {
        Template::ALL.into_iter().find(|t| t.as_str() == name).ok_or_else(|| {
            Error::invalid("template", format!("{name:?} (expected one of uniform, hold, clock, mixed, window)"))
        })
    }

    /// The successors the template gives node `q` of `n` after observation `y` of `n_obs`.
    pub(super) fn successors(self, q: usize, y: usize, n: usize, n_obs: usize) -> Vec<usize> {
        let hold = (q > 0).then_some(q);
        let clock = Some((q + 1).min(n - 1));
        match self {
            Template::Uniform => Vec::new(),
            Template::Hold => hold.into_iter().collect(),
            Template::Clock => clock.into_iter().collect(),
            Template::Mixed => hold.into_iter().chain(clock).collect(),
            Template::Window => vec![(q * n_obs + y) % n],
        }
    }

    /// The values the template gives register `i` of `d` values, now `b`, after observation `y`
    /// with register `i − 1` at `a` (laws module docs): `Hold` keeps `b` (but the start value
    /// 0), `Clock` counts up to `d − 1`, `Window` copies its input (`y mod d` for the first
    /// register, `a` for the others: a shift register), `Mixed` shares the weight between
    /// `Hold` and `Window`.
    pub(super) fn register_successors(self, i: usize, y: usize, a: usize, b: usize, d: usize) -> Vec<usize> {
        let hold = (b > 0).then_some(b);
        let copy = if i == 0 { y % d } else { a };
        match self {
            Template::Uniform => Vec::new(),
            Template::Hold => hold.into_iter().collect(),
            Template::Clock => vec![(b + 1).min(d - 1)],
            Template::Mixed if hold == Some(copy) => vec![copy],
            Template::Mixed => hold.into_iter().chain([copy]).collect(),
            Template::Window => vec![copy],
        }
    }
}
