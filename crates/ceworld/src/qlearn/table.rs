//! The Q table: `f32` values, one 64-byte-aligned row per known state, and its size (checked
//! against the memory available before allocating it, `crate::memory`).

use super::Ties;
use crate::error::Error;
use crate::error::Result;
use crate::memory::{available_memory, check_memory};

/// Bytes of a table of `n_states × n_actions` `f32` values (with the 64 bytes of alignment slack).
pub fn table_bytes(n_states: usize, n_actions: usize) -> Result<u64> {
    let values = (n_states as u128) * (n_actions as u128);
    let bytes = values * 4 + 64;
    if bytes > isize::MAX as u128 {
        return Err(Error::invalid(
            "world",
            format!("a Q table of {n_states} × {n_actions} values ({bytes} bytes) exceeds the address space"),
        ));
    }
    Ok(bytes as u64)
}

/// The Q table: `f32` values, row-major `[state][action]`, rows aligned to 64 bytes.
#[derive(Clone)]
pub struct QTable {
    /// The values, with up to 16 leading slack values so that `values[offset]` is 64-byte aligned.
    pub(super) values: Vec<f32>,
    pub(super) offset: usize,
    pub(super) n_states: usize,
    pub(super) n_actions: usize,
}

/// Slack values allocated so that the table can start on a 64-byte boundary.
const ALIGN_SLACK: usize = 64 / std::mem::size_of::<f32>();

impl QTable {
    /// A table of zeros, after checking that it fits in the available memory.
    pub fn zeros(n_states: usize, n_actions: usize) -> Result<QTable> {
        if n_states == 0 || n_actions == 0 {
            return Err(Error::invalid("table", format!("{n_states} × {n_actions} (expected at least 1 × 1)")));
        }
        let needed = table_bytes(n_states, n_actions)?;
        check_memory(
            &format!("a Q table of {n_states} states × {n_actions} actions (f32)"),
            needed,
            available_memory(),
        )?;
        // `vec![0.0; n]` asks the allocator for zeroed memory: fresh pages, zeroed on first touch.
        let values = vec![0f32; n_states * n_actions + ALIGN_SLACK];
        let offset = values.as_ptr().align_offset(64);
        let offset = if offset < ALIGN_SLACK { offset } else { 0 };
        advise_huge_pages(&values);
        Ok(QTable { values, offset, n_states, n_actions })
    }

    /// Number of states (rows).
    pub fn n_states(&self) -> usize {
        self.n_states
    }

    /// Number of actions (columns).
    pub fn n_actions(&self) -> usize {
        self.n_actions
    }

    /// Size of the values in bytes.
    pub fn bytes(&self) -> u64 {
        (self.n_states * self.n_actions * 4) as u64
    }

    /// Every value, row-major `[state][action]`.
    pub fn values(&self) -> &[f32] {
        &self.values[self.offset..self.offset + self.n_states * self.n_actions]
    }

    pub(super) fn values_mut(&mut self) -> &mut [f32] {
        let len = self.n_states * self.n_actions;
        &mut self.values[self.offset..self.offset + len]
    }

    /// The values `Q(s, ·)`.
    #[inline]
    pub fn row(&self, s: usize) -> &[f32] {
        let start = self.offset + s * self.n_actions;
        &self.values[start..start + self.n_actions]
    }

    /// The lowest greedy action of state `s` (the first index of the largest value).
    #[inline]
    pub fn greedy(&self, s: usize) -> usize {
        greedy_and_max(self.row(s)).0
    }

    /// A greedy action of state `s`, ties broken by `ties`; `bits` (called only when there is a
    /// tie to break at random) gives 32 random bits.
    #[inline]
    pub fn greedy_with(&self, s: usize, ties: Ties, bits: impl FnOnce() -> u32) -> usize {
        let row = self.row(s);
        let (first, max) = greedy_and_max(row);
        if ties == Ties::Lowest {
            return first;
        }
        let count = row.iter().filter(|&&v| v == max).count();
        if count == 1 {
            return first;
        }
        let k = ((bits() as u64 * count as u64) >> 32) as usize;
        row.iter().enumerate().filter(|&(_, &v)| v == max).nth(k).map_or(first, |(a, _)| a)
    }

    /// `Q(s, a) += α (r + γ max_a' Q(s', a') − Q(s, a))`; returns `max_a' Q(s', a')` as read
    /// before the update.
    #[inline]
    pub fn update(&mut self, s: usize, a: usize, reward: f32, s_next: usize, alpha: f32, gamma: f32) -> f32 {
        let (_, max) = greedy_and_max(self.row(s_next));
        let q = &mut self.values[self.offset + s * self.n_actions + a];
        *q += alpha * (reward + gamma * max - *q);
        max
    }
}

impl PartialEq for QTable {
    fn eq(&self, other: &QTable) -> bool {
        self.n_actions == other.n_actions && self.values() == other.values()
    }
}

impl std::fmt::Debug for QTable {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "QTable({} states × {} actions, {} bytes)", self.n_states, self.n_actions, self.bytes())
    }
}

/// Asks Linux to back the table with 2 MiB pages (transparent huge pages, where the system
/// allows them on request): a step reads one random row of a multi-gigabyte table, and with
/// 4 KiB pages nearly every read would also miss the TLB. Advisory only: no effect on results.
pub(super) fn advise_huge_pages(values: &[f32]) {
    #[cfg(target_os = "linux")]
    {
        const HUGE: usize = 2 << 20;
        let start = values.as_ptr() as usize;
        let end = start + std::mem::size_of_val(values);
        let (first, last) = (start.next_multiple_of(HUGE), end / HUGE * HUGE);
        if last > first {
            // SAFETY: madvise only advises the kernel on pages inside the live allocation
            // `values`; it reads and writes no memory, and its failure is harmless.
            unsafe {
                libc::madvise(first as *mut libc::c_void, last - first, libc::MADV_HUGEPAGE);
            }
        }
    }
    #[cfg(not(target_os = "linux"))]
    let _ = values;
}

/// The first index of the largest value, and that value.
#[inline]
pub(super) fn greedy_and_max(row: &[f32]) -> (usize, f32) {
    let mut best = (0, row[0]);
    for (k, &v) in row.iter().enumerate().skip(1) {
        if v > best.1 {
            best = (k, v);
        }
    }
    best
}
