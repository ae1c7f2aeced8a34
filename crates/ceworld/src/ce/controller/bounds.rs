//! The bounds a controller search is held to before it starts (model §8): the policy its
//! largest controller makes must have no more entries than a policy may, make a policy file the
//! engine reads back, and fit in memory three times over; each memory of its runs is bounded with
//! its own decisions and named by the setting that sizes it.

use super::config::ControllerConfig;
use super::memory::{Memory, RunMemory, Template};
use crate::error::Result;
use crate::policy::Layout;
use crate::policy::controller::Controller;

/// Refuses, before a search, controllers of up to `nodes` nodes (`mealy`: with Mealy
/// decisions) whose policy file ([`Controller::to_hhmm`]) may not fit: `[nodes, nodes]`, or
/// for a Mealy machine `[pairs, nodes]` with up to `nodes · min(Y, D)` pairs. It may not
/// have more table entries than a policy may, its file may not be larger than the engine
/// reads back ([`crate::policy::file::MAX_FILE_BYTES`], at 4 bytes an entry: `0.0,`), and
/// its tables must fit three times in the memory available: the result's, the best so far's
/// that a callback holds, and one being built (measured: a search ending with `[1024, 64]` on
/// 512 observations, 537 MB of tables, peaked at 1.39 GB; its file is streamed to disk).
/// `memory` names the memory whose nodes these are (`nodes 8`, `registers 3 of register_size
/// 4`, `memory "clock"`) and `option` the setting that sets it, which the error names with what
/// to change.
pub fn check_fits(option: &str, memory: &str, nodes: usize, mealy: bool, n_obs: usize, n_actions: usize) -> Result<()> {
    let pairs = if mealy { nodes.saturating_mul(n_obs.min(n_actions)) } else { nodes };
    let size = if mealy {
        format!(
            "{memory} ({nodes} nodes) with Mealy decisions on {n_obs} observations and {n_actions} decisions: \
             its policy file may hold {pairs} (decision, next node) pairs"
        )
    } else {
        format!("{memory} ({nodes} nodes) on {n_obs} observations and {n_actions} decisions")
    };
    let change = if mealy {
        "fewer nodes or observations: cehmm.spaces.Hashed(k) or Bins; memory \"nodes\" for no registers; or \
         Moore decisions"
    } else {
        "fewer nodes or observations: cehmm.spaces.Hashed(k) or Bins"
    };
    let refuse = |why: String| crate::error::Error::invalid(option, format!("{size}, and {why} (expected {change})"));
    let layout = Layout::new(n_obs, n_actions, &[pairs.max(1), nodes.max(1)]).map_err(|e| refuse(e.to_string()))?;
    let file_bytes: u64 = layout.tables.iter().map(|t| (t.rows * (4 * t.cols + 2)) as u64).sum();
    let most = crate::policy::file::MAX_FILE_BYTES;
    if file_bytes > most {
        return Err(refuse(format!(
            "its {} table entries make a policy file of at least {file_bytes} bytes, more than the {most} a \
             policy file may have to be read back",
            layout.len
        )));
    }
    let what = format!("three copies of the policy of {size} ({} table entries)", layout.len);
    crate::memory::check_memory(&what, 3 * layout.policy_bytes(), crate::memory::available_memory())
}

/// Refuses a search whose largest controller's policy may not fit (model §8): the model's
/// start and its growths, or each memory the runs take ([`check_fits`]).
pub(super) fn check_policy_fits(
    start: Option<&Controller>,
    config: &ControllerConfig,
    y1: usize,
    n_actions: usize,
) -> Result<()> {
    match start {
        Some(s) => {
            let (nodes, mealy) = (s.nodes() + config.growths, (0..3).any(|r| config.memory_of(r).mealy));
            let memory = format!("the model's start and growths {}", config.growths);
            check_fits("model_nodes", &memory, nodes, mealy, y1, n_actions)
        }
        None => config.check_memories(|option, memory, m| {
            let nodes = m.nodes + if m.registers == 0 { config.growths } else { 0 };
            check_fits(option, memory, nodes, m.mealy, y1, n_actions)
        }),
    }
}

impl ControllerConfig {
    /// `check` of each memory the runs take (where no model start is kept), with the setting
    /// that sizes it and how to name it: `nodes` (`nodes 8`), `registers` (`registers 3 of
    /// register_size 4`), `memory` (`memory "clock"`).
    pub(super) fn check_memories(&self, check: impl Fn(&str, &str, RunMemory) -> Result<()>) -> Result<()> {
        let runs = if self.memory == Memory::Alternate { 3 } else { 1 };
        for m in (0..runs).map(|r| self.memory_of(r)) {
            let (option, memory) = match (m.registers, m.template) {
                (0, Template::Clock) => ("memory", format!("memory \"{}\"", Memory::Clock.as_str())),
                (0, _) => ("nodes", format!("nodes {}", self.nodes)),
                (r, _) => ("registers", format!("registers {r} of register_size {}", self.register_size)),
            };
            check(option, &memory, m)?;
        }
        Ok(())
    }

    /// The most nodes of a run's memory (where no model start is kept).
    pub fn most_nodes(&self) -> usize {
        let runs = if self.memory == Memory::Alternate { 3 } else { 1 };
        (0..runs)
            .map(|r| self.memory_of(r))
            .map(|m| m.nodes + if m.registers == 0 { self.growths } else { 0 })
            .max()
            .unwrap_or(0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_largest_policy_of_a_search_must_fit_and_be_read_back() {
        // Before a search: 64 Mealy nodes on 1024 observations and 104 decisions may need 6656
        // pairs, 437 million entries: refused, naming the option; over 128 observations they fit.
        let fits = |nodes, mealy, y, d| check_fits("nodes", &format!("nodes {nodes}"), nodes, mealy, y, d);
        let e = fits(64, true, 1024, 104).unwrap_err().to_string();
        assert!(e.contains("invalid nodes: nodes 64 (64 nodes) with Mealy decisions") && e.contains("6656"), "{e}");
        fits(64, true, 128, 104).unwrap();
        fits(64, false, 1024, 104).unwrap();
        // 64 nodes on 2048 observations and 16 decisions: 1024 pairs, 134 million entries (a
        // file of at least 537 MB, which would not be read back), refused; 1024 observations
        // make a file of at least 269 MB, refused too; 512 fit.
        let e = fits(64, true, 2048, 16).unwrap_err().to_string();
        assert!(e.contains("more than the 268435456 a policy file may have"), "{e}");
        assert!(fits(64, true, 1024, 16).is_err());
        fits(64, true, 512, 16).unwrap();
    }
}
