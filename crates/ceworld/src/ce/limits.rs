//! What one CE run may take (model §3): the 32-bit counters, the recorded episodes, and the
//! memory at its peak, each refused before any work with the size it would need.

use crate::error::{Error, Result};
use crate::policy::Layout;

/// Largest size in bytes of the recorded episodes of one iteration.
pub const MAX_RECORD_BYTES: usize = 8 << 30;
/// Elite episodes per block of forward–backward counts (the blocks are summed in order).
pub const FB_BLOCK: usize = 32;

/// The sizes of a run that decide its memory.
#[derive(Clone, Copy, Debug)]
pub struct RunSize {
    /// Episodes per iteration `N`.
    pub samples: usize,
    /// Elite episodes per iteration.
    pub elite: usize,
    /// Steps per episode.
    pub horizon: usize,
    /// Fresh episodes of the final evaluation.
    pub eval_episodes: usize,
    /// Whether the elite's memory is counted by forward–backward.
    pub forward_backward: bool,
    /// Worker threads.
    pub threads: usize,
}

/// Refuses an iteration whose elite would overflow the 32-bit counts or whose recorded episodes
/// (`n` episodes of `stride` numbers) would not fit in [`MAX_RECORD_BYTES`].
pub fn check_iteration_size(n: usize, elite_count: usize, horizon: usize, stride: usize) -> Result<()> {
    if elite_count.saturating_mul(horizon) > u32::MAX as usize {
        return Err(Error::invalid("samples", format!("{n}: ceil(rho·N)·T overflows the 32-bit counters")));
    }
    let record_bytes = (n as u128) * (stride as u128) * 2;
    if record_bytes > MAX_RECORD_BYTES as u128 {
        return Err(Error::invalid(
            "samples",
            format!(
                "{n}: the episodes of one iteration would take {} MiB (at most {} MiB)",
                record_bytes >> 20,
                MAX_RECORD_BYTES >> 20
            ),
        ));
    }
    Ok(())
}

/// The bytes a run holds at its peak: six policies (the current one, the best so far, the
/// initial one kept for restarts, the caller's, the result's best and last policy files) of 16
/// bytes an entry, and the JSON document of a policy file being saved (48 bytes an entry); the counts of the elite
/// (sampled: a table of 4 bytes an entry per thread and their sum; forward–backward: 8 bytes an
/// entry per block of [`FB_BLOCK`] elite episodes and their sum); the recorded episodes (2 bytes
/// a number) with their rewards, tie keys and order (24 bytes an episode); and the evaluation's
/// rewards with their sorted copy (16 bytes an episode).
pub fn peak_bytes(layout: &Layout, size: &RunSize) -> u128 {
    let len = layout.len as u128;
    let policies = 6 * 16 * len + 48 * len;
    let counts = if size.forward_backward {
        8 * len * (size.elite.div_ceil(FB_BLOCK) as u128 + 1)
    } else {
        4 * len * (size.threads as u128 + 1)
    };
    let n = size.samples as u128;
    let episodes = n * (size.horizon * layout.record_width()) as u128 * 2 + 24 * n;
    policies + counts + episodes + 16 * size.eval_episodes as u128
}

/// Refuses a run whose peak ([`peak_bytes`]) exceeds the memory available, naming the size.
pub fn check_run_memory(layout: &Layout, size: &RunSize) -> Result<()> {
    let needed = u64::try_from(peak_bytes(layout, size)).unwrap_or(u64::MAX);
    let what =
        format!("a CE run with levels {:?} and {} samples of {} steps", layout.levels, size.samples, size.horizon);
    crate::memory::check_memory(&what, needed, crate::memory::available_memory())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_peak_counts_every_holding_by_hand() {
        // Y = D = 2, levels [3]: h0 3×2 + h1 2×1×3 = 12 entries; record width Λ + 2 = 3.
        let layout = Layout::new(2, 2, &[3]).unwrap();
        assert_eq!(layout.len, 12);
        let size =
            RunSize { samples: 10, elite: 5, horizon: 5, eval_episodes: 100, forward_backward: false, threads: 2 };
        let by_hand = 6 * 16 * 12 + 48 * 12 + 4 * 12 * (2 + 1) + (10 * 5 * 3 * 2 + 24 * 10) + 16 * 100;
        assert_eq!(peak_bytes(&layout, &size), by_hand);
        let fb = RunSize { forward_backward: true, elite: 70, ..size };
        assert_eq!(peak_bytes(&layout, &fb), by_hand - 4 * 12 * 3 + 8 * 12 * (3 + 1));
    }

    #[test]
    fn a_run_that_cannot_fit_is_refused_before_it_starts() {
        // 65535 × 240 memory states, 16 observations and decisions: 268 million entries, within
        // the layout's bound, but about 42 GB for a run (it used to abort at about 20 GB).
        let layout = Layout::new(16, 16, &[65535, 240]).unwrap();
        let size = RunSize {
            samples: 1000,
            elite: 500,
            horizon: 100,
            eval_episodes: 10_000,
            forward_backward: false,
            threads: 2,
        };
        let needed = peak_bytes(&layout, &size);
        assert!(needed > 38 << 30, "{needed}");
        let e = crate::memory::check_memory("a run", u64::try_from(needed).unwrap(), Some(24 << 30)).unwrap_err();
        assert!(e.to_string().contains("GiB"), "{e}");
    }
}
