//! The memory a run may take: what the system says is available, and the one refusal of work
//! that would not fit, made before allocating anything.

use crate::error::{Error, Result};

/// The memory the system says a new allocation can take, in bytes: `MemAvailable` from
/// `/proc/meminfo`, lowered to what a cgroup (v2) limit leaves; `None` when unknown.
pub fn available_memory() -> Option<u64> {
    let meminfo = std::fs::read_to_string("/proc/meminfo").ok()?;
    let kib = meminfo.lines().find_map(|l| l.strip_prefix("MemAvailable:"))?.trim().strip_suffix("kB")?.trim();
    let mut available = kib.parse::<u64>().ok()?.checked_mul(1024)?;
    let read = |name: &str| std::fs::read_to_string(format!("/sys/fs/cgroup/{name}")).ok()?.trim().parse::<u64>().ok();
    if let (Some(limit), Some(used)) = (read("memory.max"), read("memory.current")) {
        available = available.min(limit.saturating_sub(used));
    }
    Some(available)
}

/// `Ok` when `needed` bytes fit in `available` (unknown: assumed to fit), else [`Error::Memory`].
pub fn check_memory(what: &str, needed: u64, available: Option<u64>) -> Result<()> {
    match available {
        Some(available) if needed > available => Err(Error::Memory { what: what.to_string(), needed, available }),
        _ => Ok(()),
    }
}
