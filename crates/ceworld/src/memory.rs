//! The memory a run may take: what the system says is available, and the one refusal of work
//! that would not fit, made before allocating anything.

use crate::error::{Error, Result};

/// The memory a new allocation of this process can take, in bytes: `MemAvailable` from
/// `/proc/meminfo`, lowered to what the process's own limits leave: its cgroup's (v2, or v1),
/// its address space (`RLIMIT_AS`, `ulimit -v`) and data (`RLIMIT_DATA`) limits less what it
/// already maps; `None` when none of them is known.
pub fn available_memory() -> Option<u64> {
    let meminfo = std::fs::read_to_string("/proc/meminfo").ok();
    let free = meminfo.as_deref().and_then(|m| kib_field(m, "MemAvailable:"));
    [free, cgroup_left(), rlimit_left()].into_iter().flatten().min()
}

/// A `Name:   1234 kB` field of a `/proc` file, in bytes.
fn kib_field(text: &str, name: &str) -> Option<u64> {
    let kib = text.lines().find_map(|l| l.strip_prefix(name))?.trim().strip_suffix("kB")?.trim();
    kib.parse::<u64>().ok()?.checked_mul(1024)
}

/// What the process's cgroup leaves: v2 (`memory.max` less `memory.current`, in the process's
/// own cgroup or at the root), or v1 (`memory.limit_in_bytes` less `memory.usage_in_bytes`).
fn cgroup_left() -> Option<u64> {
    let number = |path: String| std::fs::read_to_string(path).ok()?.trim().parse::<u64>().ok();
    let own = std::fs::read_to_string("/proc/self/cgroup").ok().and_then(|c| {
        c.lines().find_map(|l| l.strip_prefix("0::")).map(|p| p.trim().trim_end_matches('/').to_string())
    });
    let mut dirs: Vec<String> = own.into_iter().map(|p| format!("/sys/fs/cgroup{p}")).collect();
    dirs.push("/sys/fs/cgroup".into());
    for dir in dirs {
        if let (Some(limit), Some(used)) =
            (number(format!("{dir}/memory.max")), number(format!("{dir}/memory.current")))
        {
            return Some(limit.saturating_sub(used));
        }
    }
    let v1 = "/sys/fs/cgroup/memory";
    match (number(format!("{v1}/memory.limit_in_bytes")), number(format!("{v1}/memory.usage_in_bytes"))) {
        // v1 reports "no limit" as a number near 2^63.
        (Some(limit), Some(used)) if limit < 1 << 60 => Some(limit.saturating_sub(used)),
        _ => None,
    }
}

/// What `RLIMIT_AS` and `RLIMIT_DATA` leave, given the process's mapped (`VmSize`) and data
/// (`VmData`) memory.
#[cfg(unix)]
fn rlimit_left() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok();
    let left = |resource, field: &str| {
        let mut limit = libc::rlimit { rlim_cur: 0, rlim_max: 0 };
        // SAFETY: getrlimit writes the struct it is given.
        if unsafe { libc::getrlimit(resource, &raw mut limit) } != 0 || limit.rlim_cur == libc::RLIM_INFINITY {
            return None;
        }
        let used = status.as_deref().and_then(|s| kib_field(s, field)).unwrap_or(0);
        Some(limit.rlim_cur.saturating_sub(used))
    };
    [left(libc::RLIMIT_AS, "VmSize:"), left(libc::RLIMIT_DATA, "VmData:")].into_iter().flatten().min()
}

#[cfg(not(unix))]
fn rlimit_left() -> Option<u64> {
    None
}

/// `Ok` when `needed` bytes fit in `available` (unknown: assumed to fit), else [`Error::Memory`].
pub fn check_memory(what: &str, needed: u64, available: Option<u64>) -> Result<()> {
    match available {
        Some(available) if needed > available => Err(Error::Memory { what: what.to_string(), needed, available }),
        _ => Ok(()),
    }
}
