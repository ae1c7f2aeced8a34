//! The policy family: a hierarchical HMM with input and output (model §2).
//!
//! Every conditional table is a block of rows in one flat `Vec<f64>`; each row also has an
//! alias table (Walker/Vose) so that a draw costs one random number and one or two reads,
//! whatever the row's length. Table order: `h0`, `h1`, then for each level `l = 2..=Λ` its
//! `start` and `step` tables. Row layouts follow the policy file (model §6): `h0[m1]`,
//! `h1[y][u]`, `start[u]`, `step[p][u]` flattened row-major.

use rand::{Rng, RngExt};
use rayon::prelude::*;

use crate::error::{Error, Result};
use crate::rng::EngineRng;

pub mod agent;
pub(crate) mod alias;
pub mod controller;
pub mod file;
pub(crate) mod flat;
pub mod graph;
pub mod shaped;

use alias::{AliasEntry, AliasScratch, build_alias, pick};

/// Largest memory size of one level (trajectories store states as `u16`).
pub const MAX_LEVEL_SIZE: usize = 65_535;

/// Largest number of table entries of one policy (each costs 16 bytes: probability and cumulated value).
pub const MAX_ENTRIES: usize = 1 << 28;

/// Where one conditional table sits in the flat parameter vector.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct TableShape {
    /// The table's path in the policy file: `"h0"`, `"h1"`, `"upper[0].start"`, `"upper[0].step"`, ...
    pub name: String,
    /// The table's shape as in the policy file; the last axis is the outcome.
    pub dims: Vec<usize>,
    /// Number of conditioning rows (product of all axes but the last).
    pub rows: usize,
    /// Number of outcomes per row (the last axis).
    pub cols: usize,
    /// Index of the table's first entry in the flat vector.
    pub offset: usize,
}

/// The sizes that fix a policy's tables.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Layout {
    /// Number of observations `Y`.
    pub n_obs: usize,
    /// Number of decisions `D`.
    pub n_actions: usize,
    /// Memory sizes `|M_1|, ..., |M_Λ|`.
    pub levels: Vec<usize>,
    /// The tables, in the order `h0, h1, upper[0].start, upper[0].step, upper[1].start, ...`.
    pub tables: Vec<TableShape>,
    /// Total number of entries.
    pub len: usize,
}

impl Layout {
    /// Bytes of one policy of this layout in memory: each entry's probability and alias entry.
    pub fn policy_bytes(&self) -> u64 {
        self.len as u64 * 16
    }

    /// The layout, if one policy of it fits in the memory available, else [`Error::Memory`]
    /// (checked before the tables are allocated).
    pub fn fits_in_memory(self) -> Result<Layout> {
        let what = format!("a policy with levels {:?} ({} table entries)", self.levels, self.len);
        crate::memory::check_memory(&what, self.policy_bytes(), crate::memory::available_memory())?;
        Ok(self)
    }

    /// The layout for `levels` (bottom level first) in a world with `n_obs` observations and
    /// `n_actions` decisions; every size must be in `1..=65535`.
    pub fn new(n_obs: usize, n_actions: usize, levels: &[usize]) -> Result<Layout> {
        if levels.is_empty() {
            return Err(Error::invalid("levels", "[] (expected at least one level, e.g. [16])"));
        }
        for (l, &size) in levels.iter().enumerate() {
            if size == 0 || size > MAX_LEVEL_SIZE {
                return Err(Error::invalid(
                    "levels",
                    format!("{levels:?}: level {} has size {size} (expected 1..={MAX_LEVEL_SIZE})", l + 1),
                ));
            }
        }
        for (name, v) in [("n_obs", n_obs), ("n_actions", n_actions)] {
            if v == 0 || v > MAX_LEVEL_SIZE {
                return Err(Error::invalid(name, format!("{v} (expected 1..={MAX_LEVEL_SIZE})")));
            }
        }
        // The shapes first (as in the policy file, model §6), their size checked before any
        // table exists; sizes in u128 so that no product can overflow.
        let lambda = levels.len();
        let upper = |l: usize| if l < lambda { levels[l] } else { 1 }; // |M_{l+1}|, 1-based l
        let mut shapes =
            vec![("h0".to_string(), vec![levels[0], n_actions]), ("h1".into(), vec![n_obs, upper(1), levels[0]])];
        for l in 2..=lambda {
            shapes.push((format!("upper[{}].start", l - 2), vec![upper(l), levels[l - 1]]));
            shapes.push((format!("upper[{}].step", l - 2), vec![levels[l - 2], upper(l), levels[l - 1]]));
        }
        let entries: u128 = shapes.iter().map(|(_, dims)| dims.iter().map(|&d| d as u128).product::<u128>()).sum();
        if entries > MAX_ENTRIES as u128 {
            return Err(Error::invalid(
                "levels",
                format!(
                    "{levels:?} needs {entries} table entries (at most {MAX_ENTRIES}, i.e. {} GiB of tables)",
                    (MAX_ENTRIES * 16) >> 30
                ),
            ));
        }
        let mut tables = Vec::with_capacity(shapes.len());
        let mut offset = 0;
        for (name, dims) in shapes {
            let cols = *dims.last().expect("every table has an outcome axis");
            let rows = dims[..dims.len() - 1].iter().product::<usize>();
            tables.push(TableShape { name, dims, rows, cols, offset });
            offset += rows * cols;
        }
        Ok(Layout { n_obs, n_actions, levels: levels.to_vec(), tables, len: offset })
    }

    /// Number of levels `Λ`.
    pub fn depth(&self) -> usize {
        self.levels.len()
    }

    /// The paper's count of free parameters, start tables excluded (model §2).
    pub fn parameter_count(&self) -> usize {
        let m = &self.levels;
        let upper = |l: usize| if l < m.len() { m[l] } else { 1 };
        let mut n = (self.n_actions - 1) * m[0] + (m[0] - 1) * self.n_obs * upper(1);
        for l in 2..=m.len() {
            n += (m[l - 1] - 1) * m[l - 2] * upper(l);
        }
        n
    }

    /// Size of the upper condition of level `l` (1-based): `|M_{l+1}|`, or 1 at the top.
    #[inline]
    pub fn upper_size(&self, l: usize) -> usize {
        if l < self.levels.len() { self.levels[l] } else { 1 }
    }

    /// Index of the `start` table of level `l >= 2`.
    #[inline]
    pub fn start_table(l: usize) -> usize {
        2 * l - 2
    }

    /// Index of the `step` table of level `l >= 2`.
    #[inline]
    pub fn step_table(l: usize) -> usize {
        2 * l - 1
    }

    /// Numbers stored per step of a recorded trajectory: `y`, `d`, then `m_1..m_Λ`.
    #[inline]
    pub fn record_width(&self) -> usize {
        2 + self.levels.len()
    }
}

/// A hierarchical HMM policy: the tables and their alias tables for sampling.
#[derive(Clone, Debug, PartialEq)]
pub struct Hhmm {
    layout: Layout,
    probs: Vec<f64>,
    alias: Vec<AliasEntry>,
    /// `(offset, cols)` of every table, compact for the sampling loop.
    spans: Vec<(usize, usize)>,
}

impl Hhmm {
    /// The policy whose every row is uniform (the CE starting point).
    pub fn uniform(n_obs: usize, n_actions: usize, levels: &[usize]) -> Result<Hhmm> {
        let layout = Layout::new(n_obs, n_actions, levels)?.fits_in_memory()?;
        let mut probs = vec![0.0; layout.len];
        for t in &layout.tables {
            probs[t.offset..t.offset + t.rows * t.cols].fill(1.0 / t.cols as f64);
        }
        Ok(Self::from_parts(layout, probs))
    }

    /// A policy whose rows are drawn at random (each entry uniform in (0, 1], then normalised).
    pub fn random(n_obs: usize, n_actions: usize, levels: &[usize], rng: &mut EngineRng) -> Result<Hhmm> {
        let layout = Layout::new(n_obs, n_actions, levels)?.fits_in_memory()?;
        let mut probs: Vec<f64> = (0..layout.len).map(|_| 1.0 - rng.random::<f64>()).collect();
        for t in &layout.tables {
            for row in probs[t.offset..t.offset + t.rows * t.cols].chunks_mut(t.cols) {
                let total: f64 = row.iter().sum();
                for p in row.iter_mut() {
                    *p /= total;
                }
            }
        }
        Ok(Self::from_parts(layout, probs))
    }

    /// A two-level policy whose memory is a clock: `m_1[t] = m_2[t] = (t − 1) mod |M|`, whatever
    /// the observation, and whose decisions are uniform. Counting keeps one-hot rows one-hot,
    /// so under CE the clock persists and `h0` becomes a time-indexed plan (`h0[t]` = the
    /// decision law at step `t`): a structure for worlds where the observation says little
    /// (case 2). Needs `levels = [M, M]`; `M >= T` gives every step its own row.
    pub fn clock(n_obs: usize, n_actions: usize, levels: &[usize]) -> Result<Hhmm> {
        if levels.len() != 2 || levels[0] != levels[1] {
            return Err(Error::invalid(
                "levels",
                format!("{levels:?} (a clock needs two equal levels, e.g. [100, 100])"),
            ));
        }
        let layout = Layout::new(n_obs, n_actions, levels)?.fits_in_memory()?;
        let m = levels[0];
        let mut probs = vec![0.0; layout.len];
        let t = &layout.tables;
        probs[t[0].offset..t[0].offset + t[0].rows * t[0].cols].fill(1.0 / n_actions as f64);
        for y in 0..n_obs {
            for u in 0..m {
                probs[t[1].offset + (y * m + u) * m + u] = 1.0;
            }
        }
        probs[t[2].offset] = 1.0;
        for p in 0..m {
            probs[t[3].offset + p * m + (p + 1) % m] = 1.0;
        }
        Ok(Self::from_parts(layout, probs))
    }

    /// A policy from its flat table entries, checked: every entry finite and non-negative,
    /// every row summing to 1 within `1e-6`.
    pub fn from_flat(layout: Layout, probs: Vec<f64>) -> Result<Hhmm> {
        if probs.len() != layout.len {
            return Err(Error::format(format!("{} table entries (expected {})", probs.len(), layout.len)));
        }
        for t in &layout.tables {
            for (r, row) in probs[t.offset..t.offset + t.rows * t.cols].chunks(t.cols).enumerate() {
                let at = || row_name(t, r);
                if let Some((k, p)) = row.iter().enumerate().find(|(_, p)| !p.is_finite() || **p < 0.0) {
                    return Err(Error::format(format!("{}[{k}] = {p} (expected a finite probability >= 0)", at())));
                }
                let total: f64 = row.iter().sum();
                if (total - 1.0).abs() > 1e-6 {
                    return Err(Error::format(format!("row {} sums to {total} (expected 1 within 1e-6)", at())));
                }
            }
        }
        Ok(Self::from_parts(layout, probs))
    }

    fn from_parts(layout: Layout, probs: Vec<f64>) -> Hhmm {
        let spans = layout.tables.iter().map(|t| (t.offset, t.cols)).collect();
        let mut h = Hhmm { alias: vec![AliasEntry::default(); probs.len()], spans, layout, probs };
        h.rebuild_samplers();
        h
    }

    /// Rebuilds every row's alias table after the probabilities changed (Vose's method).
    pub(crate) fn rebuild_samplers(&mut self) {
        let mut scratch = AliasScratch::default();
        for t in &self.layout.tables {
            let range = t.offset..t.offset + t.rows * t.cols;
            for (p, a) in self.probs[range.clone()].chunks(t.cols).zip(self.alias[range].chunks_mut(t.cols)) {
                build_alias(p, a, &mut scratch);
            }
        }
    }

    /// The CE update (model §3): each row with counts becomes `α·counts/total + (1 − α)·old`,
    /// with `α = decision` for `h0` when given; rows without counts keep their values. `counts` is laid out as the tables. Rows are
    /// refitted in parallel (on the current rayon pool); each row's result is independent of
    /// the split, so the update is bit-identical whatever the number of threads.
    pub fn refit<C: Copy + Into<f64> + Sync>(&mut self, counts: &[C], smoothing: f64, decision: Option<f64>) {
        assert_eq!(counts.len(), self.probs.len(), "counts laid out as the tables");
        for (index, t) in self.layout.tables.iter().enumerate() {
            let smoothing = if index == 0 { decision.unwrap_or(smoothing) } else { smoothing };
            let range = t.offset..t.offset + t.rows * t.cols;
            let rows = self.probs[range.clone()]
                .par_chunks_mut(t.cols)
                .zip(self.alias[range.clone()].par_chunks_mut(t.cols))
                .zip(counts[range].par_chunks(t.cols));
            rows.for_each_init(AliasScratch::default, |scratch, ((row, alias), c)| {
                // Integer counts sum exactly in f64 (below 2^53).
                let total: f64 = c.iter().map(|&x| x.into()).sum();
                if total <= 0.0 {
                    return;
                }
                let inv = 1.0 / total;
                for (p, &x) in row.iter_mut().zip(c) {
                    *p = smoothing * (x.into() * inv) + (1.0 - smoothing) * *p;
                }
                build_alias(row, alias, scratch);
            });
        }
    }

    /// The layout (sizes and table positions).
    pub fn layout(&self) -> &Layout {
        &self.layout
    }

    /// Memory sizes per level, bottom first.
    pub fn levels(&self) -> &[usize] {
        &self.layout.levels
    }

    /// All table entries, flat, in layout order.
    pub fn probs(&self) -> &[f64] {
        &self.probs
    }

    /// The entries of table `index` (see [`Layout::tables`]), row-major.
    pub fn table(&self, index: usize) -> &[f64] {
        let t = &self.layout.tables[index];
        &self.probs[t.offset..t.offset + t.rows * t.cols]
    }

    /// Draws an outcome of row `row` of table `table`: the high 32 random bits pick a column
    /// uniformly, the low 32 bits keep it or take its alias.
    #[inline]
    fn draw(&self, table: usize, row: usize, rng: &mut EngineRng) -> usize {
        let (offset, cols) = self.spans[table];
        pick(&self.alias, offset + row * cols, cols, rng.next_u64())
    }

    /// Checks that the policy's observation and decision counts are `n_obs` and `n_actions`
    /// (a world's).
    pub fn check_shape(&self, n_obs: usize, n_actions: usize) -> Result<()> {
        let l = &self.layout;
        if l.n_obs != n_obs || l.n_actions != n_actions {
            return Err(Error::Mismatch(format!(
                "the policy has {} observations and {} decisions, the world {n_obs} and {n_actions}",
                l.n_obs, l.n_actions
            )));
        }
        Ok(())
    }

    /// One step of top-down sampling (model §2). `memory[l - 1]` holds `m_l[t - 1]` on entry and
    /// `m_l[t]` on return; `first` marks `t = 1`, where the start tables are used. Returns `d_t`.
    #[inline]
    pub fn step(&self, y: usize, memory: &mut [u16], first: bool, rng: &mut EngineRng) -> usize {
        let lambda = memory.len();
        for l in (2..=lambda).rev() {
            let u = if l < lambda { memory[l] as usize } else { 0 };
            let m = if first {
                self.draw(Layout::start_table(l), u, rng)
            } else {
                let p = memory[l - 2] as usize;
                self.draw(Layout::step_table(l), p * self.layout.upper_size(l) + u, rng)
            };
            memory[l - 1] = m as u16;
        }
        let u = if lambda >= 2 { memory[1] as usize } else { 0 };
        let m1 = self.draw(1, y * self.layout.upper_size(1) + u, rng);
        memory[0] = m1 as u16;
        self.draw(0, m1, rng)
    }

    /// The law of the memory `m[t]` that [`Hhmm::step`] draws from `y` and `m[t-1]` (`previous`,
    /// bottom first; unused when `first`): every memory of positive probability, with it.
    pub fn memory_law(&self, y: usize, previous: &[u16], first: bool) -> Vec<(Vec<u16>, f64)> {
        let mut out = Vec::new();
        let mut memory = vec![0; self.levels().len()];
        self.expand_memory(y, previous, first, memory.len(), &mut memory, 1.0, &mut out);
        out
    }

    /// Draws level `l`, then the ones below, given the levels above in `memory`.
    #[allow(clippy::too_many_arguments)]
    fn expand_memory(
        &self,
        y: usize,
        previous: &[u16],
        first: bool,
        l: usize,
        memory: &mut [u16],
        p: f64,
        out: &mut Vec<(Vec<u16>, f64)>,
    ) {
        let lambda = memory.len();
        let upper = self.layout.upper_size(l);
        let u = if l < lambda { memory[l] as usize } else { 0 };
        let (table, row) = match l {
            1 => (1, y * upper + u),
            _ if first => (Layout::start_table(l), u),
            _ => (Layout::step_table(l), previous[l - 2] as usize * upper + u),
        };
        let cols = self.layout.tables[table].cols;
        for (v, &q) in self.table(table)[row * cols..(row + 1) * cols].iter().enumerate() {
            if q > 0.0 {
                memory[l - 1] = v as u16;
                if l > 1 {
                    self.expand_memory(y, previous, first, l - 1, memory, p * q, out);
                } else {
                    out.push((memory.to_vec(), p * q));
                }
            }
        }
    }

    /// The decision law `h0[m_1]`.
    pub fn decision_law(&self, m1: usize) -> &[f64] {
        let d = self.layout.n_actions;
        &self.table(0)[m1 * d..(m1 + 1) * d]
    }
}

/// `"h1[3, 0]"`: a row's name for error messages.
fn row_name(t: &TableShape, row: usize) -> String {
    let mut index = Vec::with_capacity(t.dims.len() - 1);
    let mut r = row;
    for &d in t.dims[..t.dims.len() - 1].iter().rev() {
        index.push(r % d);
        r /= d;
    }
    index.reverse();
    let index: Vec<String> = index.iter().map(std::string::ToString::to_string).collect();
    format!("{}[{}]", t.name, index.join("]["))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::{Purpose, stream};

    #[test]
    fn the_decision_table_takes_its_own_smoothing() {
        let mut h = Hhmm::uniform(2, 2, &[2]).unwrap();
        // Every count on decision 0 and memory 0: h0 rows move by 0.1, h1 rows by 0.5.
        let mut counts = vec![0.0; h.probs().len()];
        for (index, table) in h.layout().tables.clone().iter().enumerate() {
            for row in 0..table.rows {
                counts[table.offset + row * table.cols] = if index == 0 { 4.0 } else { 2.0 };
            }
        }
        h.refit(&counts, 0.5, Some(0.1));
        assert_eq!(h.table(0), &[0.55, 0.45, 0.55, 0.45]);
        assert_eq!(h.table(1), &[0.75, 0.25, 0.75, 0.25]);
        h.refit(&counts, 0.5, None);
        assert_eq!(h.table(0), &[0.775, 0.225, 0.775, 0.225]);
    }

    #[test]
    fn parameter_count_matches_the_paper() {
        assert_eq!(Layout::new(16, 16, &[16, 16]).unwrap().parameter_count(), 4320);
        assert_eq!(Layout::new(16, 16, &[16, 2, 2, 2]).unwrap().parameter_count(), 758);
        assert_eq!(Layout::new(16, 16, &[16]).unwrap().parameter_count(), 15 * 16 + 15 * 16);
    }

    #[test]
    fn shapes_follow_the_policy_file() {
        let l = Layout::new(16, 4, &[8, 3, 2]).unwrap();
        let dims: Vec<_> = l.tables.iter().map(|t| (t.name.as_str(), t.dims.clone())).collect();
        assert_eq!(
            dims,
            vec![
                ("h0", vec![8, 4]),
                ("h1", vec![16, 3, 8]),
                ("upper[0].start", vec![2, 3]),
                ("upper[0].step", vec![8, 2, 3]),
                ("upper[1].start", vec![1, 2]),
                ("upper[1].step", vec![3, 1, 2]),
            ]
        );
        assert_eq!(l.len, 32 + 384 + 6 + 48 + 2 + 6);
    }

    #[test]
    fn bad_levels_are_refused() {
        assert!(Layout::new(16, 16, &[]).is_err());
        let e = Layout::new(16, 16, &[16, 0]).unwrap_err().to_string();
        assert!(e.contains("level 2 has size 0"), "{e}");
        assert!(Layout::new(16, 16, &[70_000]).is_err());
        assert!(Layout::new(16, 16, &[1024, 1024]).is_ok());
        let e = Layout::new(16, 16, &[65_535, 65_535]).unwrap_err().to_string();
        assert!(e.contains("table entries"), "{e}");
        // 285,282,304 entries, just over 2^28, most of them in h1 (16 × 4096 × 4096).
        let e = Layout::new(16, 16, &[4096, 4096]).unwrap_err().to_string();
        assert!(e.contains("285282304 table entries"), "{e}");
    }

    #[test]
    fn random_rows_are_uniform_draws_normalised() {
        // 20,000 rows of two entries u0, u1 uniform in (0, 1]: p0 = u0 / (u0 + u1) < 1/4 when
        // u1 > 3·u0, which has probability 1/6.
        let n = 20_000;
        let h = Hhmm::random(1, 2, &[n], &mut stream(5, Purpose::Init, 0, 0)).unwrap();
        assert!(Hhmm::from_flat(h.layout().clone(), h.probs().to_vec()).is_ok(), "every row sums to 1");
        assert!(h.probs().iter().all(|&p| p > 0.0 && p < 1.0));
        let low = h.table(0).chunks(2).filter(|row| row[0] < 0.25).count();
        let (p, sd) = (1.0 / 6.0, (1.0 / 6.0 * 5.0 / 6.0 / n as f64).sqrt());
        let f = low as f64 / n as f64;
        assert!((f - p).abs() < 4.0 * sd, "P(p0 < 1/4) = {f}, expected {p} ± {}", 4.0 * sd);
        // Rows of three: p0 > 0.6 when u1 + u2 < 2·u0/3, which has probability 2/27 (the law of
        // the normalised draws, not only their ratios).
        let h = Hhmm::random(1, 3, &[n], &mut stream(6, Purpose::Init, 0, 0)).unwrap();
        let high = h.table(0).chunks(3).filter(|row| row[0] > 0.6).count();
        let (p, sd) = (2.0 / 27.0, (2.0 / 27.0 * 25.0 / 27.0 / n as f64).sqrt());
        let f = high as f64 / n as f64;
        assert!((f - p).abs() < 4.0 * sd, "P(p0 > 0.6) = {f}, expected {p} ± {}", 4.0 * sd);
    }

    #[test]
    fn clock_tables_by_hand() {
        // Y = 3, D = 2, levels [4, 4]: h0 uniform, h1[y][u] = e_u for every y, start = e_0,
        // step[p][0] = e_{p+1 mod 4}.
        let h = Hhmm::clock(3, 2, &[4, 4]).unwrap();
        assert!(Hhmm::from_flat(h.layout().clone(), h.probs().to_vec()).is_ok(), "every row sums to 1");
        assert!(h.table(0).iter().all(|&p| p == 0.5));
        for (row, probs) in h.table(1).chunks(4).enumerate() {
            let u = row % 4;
            assert!(
                probs.iter().enumerate().all(|(m, &p)| p == f64::from(u8::from(m == u))),
                "h1 row {row}: {probs:?}"
            );
        }
        assert_eq!(h.table(2), &[1.0, 0.0, 0.0, 0.0]);
        for (p, probs) in h.table(3).chunks(4).enumerate() {
            assert!(probs.iter().enumerate().all(|(m, &q)| q == f64::from(u8::from(m == (p + 1) % 4))), "step {p}");
        }
    }

    #[test]
    fn from_flat_rejects_bad_rows() {
        let u = Hhmm::uniform(2, 2, &[2]).unwrap();
        let mut probs = u.probs().to_vec();
        probs[0] = -0.5;
        probs[1] = 1.5;
        let e = Hhmm::from_flat(u.layout().clone(), probs).unwrap_err().to_string();
        assert!(e.contains("h0[0][0] = -0.5"), "{e}");
        let mut probs = u.probs().to_vec();
        probs[5] = 0.7;
        let e = Hhmm::from_flat(u.layout().clone(), probs).unwrap_err().to_string();
        assert!(e.contains("h1[0][0] sums to 1.2"), "{e}");
    }

    #[test]
    fn the_observation_selects_the_row_of_h1() {
        // Λ = 2, Y = 3, levels [2, 2]: m2 starts at 1 for sure, and h1[y][1] is one-hot on a
        // different m1 for y = 1 than for y = 0 and 2, so m1 (and d = m1, by h0) shows the row.
        let layout = Layout::new(3, 2, &[2, 2]).unwrap();
        let h0 = vec![1.0, 0.0, 0.0, 1.0];
        let h1 = vec![0.5, 0.5, 1.0, 0.0, 0.5, 0.5, 0.0, 1.0, 0.5, 0.5, 1.0, 0.0];
        let (start, step) = (vec![0.0, 1.0], vec![0.0, 1.0, 0.0, 1.0]);
        let h = Hhmm::from_flat(layout, [h0, h1, start, step].concat()).unwrap();
        let mut rng = stream(1, Purpose::Evaluate, 0, 0);
        for (y, d) in [(0, 0), (1, 1), (2, 0)] {
            let mut memory = [0u16; 2];
            assert_eq!(h.step(y, &mut memory, true, &mut rng), d, "y = {y}");
            assert_eq!(memory, [d as u16, 1]);
        }
    }

    /// Draw frequencies of a fixed row against its probabilities: Pearson's chi-square with a
    /// fixed seed, below the 0.999 quantile of chi2(k - 1).
    #[test]
    fn draw_frequencies_match_probabilities() {
        for cols in [5usize, 40] {
            let layout = Layout::new(1, cols, &[1]).unwrap();
            let mut probs = vec![0.0; layout.len];
            let weights: Vec<f64> = (0..cols).map(|k| if k % 4 == 3 { 0.0 } else { 1.0 + k as f64 }).collect();
            let total: f64 = weights.iter().sum();
            for (k, w) in weights.iter().enumerate() {
                probs[k] = w / total;
            }
            probs[layout.tables[1].offset] = 1.0;
            let h = Hhmm::from_flat(layout, probs.clone()).unwrap();
            let mut rng = stream(42, Purpose::Optimise, 0, cols as u64);
            let n = 200_000;
            let mut counts = vec![0usize; cols];
            let mut memory = [0u16];
            for _ in 0..n {
                counts[h.step(0, &mut memory, false, &mut rng)] += 1;
            }
            let mut chi2 = 0.0;
            let mut dof = 0;
            for k in 0..cols {
                let expected = probs[k] * n as f64;
                if expected == 0.0 {
                    assert_eq!(counts[k], 0, "outcome {k} has probability 0");
                } else {
                    chi2 += (counts[k] as f64 - expected).powi(2) / expected;
                    dof += 1;
                }
            }
            // 0.999 quantiles of chi2(k): k = 3 -> 16.27, k = 29 -> 58.30.
            let limit = if dof - 1 == 3 { 16.27 } else { 58.30 };
            assert_eq!(dof - 1, if cols == 5 { 3 } else { 29 });
            assert!(chi2 < limit, "chi2 = {chi2} with {} degrees of freedom", dof - 1);
        }
    }
}
