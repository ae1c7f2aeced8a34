//! Checking and renormalising probability rows, and the dense tables.

use std::cmp::Ordering;
use std::ops::Range;

use crate::world::cassandra::lexer::Pos;

/// Deviations from 1 at or below this are floating-point noise: such rows
/// are accepted as they are, without renormalising or a note.
pub(crate) const NOISE: f64 = 1e-10;

/// The outcome of checking one probability row.
pub(crate) enum RowCheck {
    /// Sums to 1 up to [`NOISE`].
    Exact,
    /// Summed to this, within tolerance; now divided by it.
    Renormalised(f64),
    /// Sums to this, which is not within tolerance of 1.
    Bad(f64),
}

/// Checks that `row` sums to 1 within `tol`, renormalising it if needed.
/// The caller has already refused negative entries.
pub(crate) fn normalise(row: &mut [f64], tol: f64) -> RowCheck {
    let sum: f64 = row.iter().sum();
    let dev = (sum - 1.0).abs();
    // A NaN tolerance or sum counts as bad.
    let within = matches!(dev.partial_cmp(&tol), Some(Ordering::Less | Ordering::Equal));
    if !within || sum <= 0.0 {
        return RowCheck::Bad(sum);
    }
    if dev > NOISE {
        for x in row.iter_mut() {
            *x /= sum;
        }
        return RowCheck::Renormalised(sum);
    }
    RowCheck::Exact
}

/// Formats a sum for a message: 12 decimals with trailing zeros trimmed, so
/// that `0.4 + 0.7` shows as `1.1`.
pub(crate) fn fmt_num(x: f64) -> String {
    if !x.is_finite() || x.abs() >= 1e6 {
        return format!("{x:e}");
    }
    let s = format!("{x:.12}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s == "-0" { "0".to_string() } else { s.to_string() }
}

/// The range of indices a selector covers: one index, or all for `*`.
pub(crate) fn span(sel: Option<usize>, n: usize) -> Range<usize> {
    match sel {
        Some(i) => i..i.saturating_add(1).min(n),
        None => 0..n,
    }
}

/// A dense table of probability rows, one row per `(a, s)`: `T` (rows over
/// `s'`) or `O` (rows over `o`, indexed by `(a, s')`).
pub(crate) struct Dense {
    pub data: Vec<f64>,
    /// Where each row was last written; `None` if never.
    pub loc: Vec<Option<Pos>>,
    /// Number of actions.
    pub na: usize,
    /// Rows per action (the number of states).
    pub ns: usize,
    /// Row length.
    pub len: usize,
}

impl Dense {
    /// A zero table; the caller has checked that `na * ns * len` fits.
    pub fn new(na: usize, ns: usize, len: usize) -> Self {
        Dense { data: vec![0.0; na * ns * len], loc: vec![None; na * ns], na, ns, len }
    }

    /// The rows `a*S + s` that the selectors cover.
    fn rows(&self, a: Option<usize>, s: Option<usize>) -> impl Iterator<Item = usize> + use<> {
        let ns = self.ns;
        let states = span(s, ns);
        span(a, self.na).flat_map(move |a| states.clone().map(move |s| a * ns + s))
    }

    fn mark(&mut self, row: usize, pos: Pos) {
        if let Some(l) = self.loc.get_mut(row) {
            *l = Some(pos);
        }
    }

    /// Sets one entry (or many, through wildcards).
    pub fn set(&mut self, a: Option<usize>, s: Option<usize>, col: Option<usize>, v: f64, pos: Pos) {
        for row in self.rows(a, s) {
            for c in span(col, self.len) {
                if let Some(x) = self.data.get_mut(row * self.len + c) {
                    *x = v;
                }
            }
            self.mark(row, pos);
        }
    }

    /// Sets whole rows to `values` (of length `len`).
    pub fn set_row(&mut self, a: Option<usize>, s: Option<usize>, values: &[f64], pos: Pos) {
        for row in self.rows(a, s) {
            if let Some(dst) = self.data.get_mut(row * self.len..(row + 1) * self.len) {
                for (d, v) in dst.iter_mut().zip(values) {
                    *d = *v;
                }
            }
            self.mark(row, pos);
        }
    }

    /// Sets every row of the actions selected to the same row.
    pub fn set_all_rows(&mut self, a: Option<usize>, values: &[f64], pos: Pos) {
        self.set_row(a, None, values, pos);
    }

    /// Sets the matrices of the actions selected; `row_pos[s]` is where row
    /// `s` of the matrix starts in the file.
    pub fn set_matrix(&mut self, a: Option<usize>, m: &[f64], row_pos: &[Pos]) {
        for a in span(a, self.na) {
            for (s, pos) in row_pos.iter().enumerate().take(self.ns) {
                let src = m.get(s * self.len..(s + 1) * self.len).unwrap_or_default();
                self.set_row(Some(a), Some(s), src, *pos);
            }
        }
    }

    /// Sets the matrices of the actions selected to the identity.
    pub fn set_identity(&mut self, a: Option<usize>, pos: Pos) {
        for a in span(a, self.na) {
            for s in 0..self.ns {
                let row = a * self.ns + s;
                if let Some(dst) = self.data.get_mut(row * self.len..(row + 1) * self.len) {
                    for (c, d) in dst.iter_mut().enumerate() {
                        *d = if c == s { 1.0 } else { 0.0 };
                    }
                }
                self.mark(row, pos);
            }
        }
    }

    /// Checks every row, renormalising those within `tol`. `label(a, s)`
    /// names a row. Notes go to `notes`; the error at the earliest position
    /// (rows never written count as being at `eof`) is kept in `worst`.
    pub fn check(
        &mut self,
        tol: f64,
        eof: Pos,
        label: &dyn Fn(usize, usize) -> String,
        notes: &mut Vec<String>,
        worst: &mut Option<(Pos, String)>,
    ) {
        let len = self.len.max(1);
        for (r, row) in self.data.chunks_mut(len).enumerate() {
            let (a, s) = (r / self.ns.max(1), r % self.ns.max(1));
            // Every write marks its row, so a row never written is all zero;
            // it is not summed (this keeps a partial parse of a big model cheap).
            let loc = self.loc.get(r).copied().flatten();
            let check = if loc.is_some() { normalise(row, tol) } else { RowCheck::Bad(0.0) };
            let problem = match (loc, check) {
                (_, RowCheck::Exact) => None,
                (_, RowCheck::Renormalised(sum)) => {
                    notes.push(format!("{} summed to {}; renormalised", label(a, s), fmt_num(sum)));
                    None
                }
                (None, RowCheck::Bad(_)) => Some((
                    eof,
                    format!(
                        "{} was never written (expected a row of {} probabilities summing to 1)",
                        label(a, s),
                        self.len
                    ),
                )),
                (Some(pos), RowCheck::Bad(sum)) => {
                    Some((pos, format!("{} sums to {} (expected 1 within {tol:e})", label(a, s), fmt_num(sum))))
                }
            };
            if let Some((pos, msg)) = problem
                && worst.as_ref().is_none_or(|(w, _)| pos < *w)
            {
                *worst = Some((pos, msg));
            }
        }
    }
}
