//! Alias tables (Walker, Vose): one draw of a row of probabilities from one random word, in
//! constant time. The policy's tables and the tabular worlds sample through them.

/// One column of a row's alias table: keep the column when the low 32 random bits are below
/// `threshold`, else take `alias`. A column with `alias` equal to itself is always kept.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) struct AliasEntry {
    pub(crate) threshold: u32,
    pub(crate) alias: u32,
}

/// The outcome of the alias row of `cols` entries starting at `alias[start]` for the random word
/// `x`: its high 32 bits pick a column uniformly, its low 32 bits keep the column when below the
/// column's threshold, else take its alias.
#[inline]
pub(crate) fn pick(alias: &[AliasEntry], start: usize, cols: usize, x: u64) -> usize {
    let column = (((x >> 32) * cols as u64) >> 32) as usize;
    let entry = alias[start + column];
    if (x as u32) < entry.threshold { column } else { entry.alias as usize }
}

/// Reused buffers of [`build_alias`].
#[derive(Default)]
pub(crate) struct AliasScratch {
    small: Vec<usize>,
    large: Vec<usize>,
    scaled: Vec<f64>,
}

/// Fills `alias` for the row `probs` (any non-negative weights with a positive sum). Zero-weight
/// columns are paired first, so rounding can never leave one of them drawable.
pub(crate) fn build_alias(probs: &[f64], alias: &mut [AliasEntry], scratch: &mut AliasScratch) {
    const SCALE: f64 = 4_294_967_296.0; // 2^32
    let AliasScratch { small, large, scaled } = scratch;
    let n = probs.len();
    // Fast path for one-hot rows, the common case once basic CE has converged.
    let mut nonzero = probs.iter().enumerate().filter(|(_, p)| **p > 0.0);
    if let (Some((k, _)), None) = (nonzero.next(), nonzero.next()) {
        alias.fill(AliasEntry { threshold: 0, alias: k as u32 });
        alias[k] = AliasEntry { threshold: u32::MAX, alias: k as u32 };
        return;
    }
    let total: f64 = probs.iter().sum();
    scaled.clear();
    scaled.extend(probs.iter().map(|p| p * n as f64 / total));
    small.clear();
    large.clear();
    // `small` is a stack: push the zero columns last so that they are paired first.
    small.extend((0..n).filter(|&k| scaled[k] < 1.0 && scaled[k] > 0.0));
    small.extend((0..n).filter(|&k| scaled[k] == 0.0));
    large.extend((0..n).filter(|&k| scaled[k] >= 1.0));
    while let (Some(&s), Some(&l)) = (small.last(), large.last()) {
        small.pop();
        alias[s] = AliasEntry { threshold: (scaled[s] * SCALE) as u32, alias: l as u32 };
        scaled[l] -= 1.0 - scaled[s];
        if scaled[l] < 1.0 {
            large.pop();
            small.push(l);
        }
    }
    // What is left has scaled weight 1 up to rounding: always keep it.
    for &k in small.iter().chain(large.iter()) {
        alias[k] = AliasEntry { threshold: u32::MAX, alias: k as u32 };
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The alias row of `weights`, built as the sampler builds it.
    fn alias_row(weights: &[f64]) -> Vec<AliasEntry> {
        let mut alias = vec![AliasEntry::default(); weights.len()];
        build_alias(weights, &mut alias, &mut AliasScratch::default());
        alias
    }

    #[test]
    fn alias_rows_by_hand() {
        // Weights 1 and 3 (not normalised): scaled 0.5 and 1.5, so column 0 is kept half the
        // time and otherwise gives way to column 1, which is always kept.
        let row = alias_row(&[1.0, 3.0]);
        assert_eq!(row[0], AliasEntry { threshold: 1 << 31, alias: 1 });
        assert_eq!(row[1], AliasEntry { threshold: u32::MAX, alias: 1 });
        // A one-hot row: every other column has threshold 0 and the hot one as alias.
        let row = alias_row(&[0.0, 1.0, 0.0]);
        assert_eq!(row, [AliasEntry { threshold: 0, alias: 1 }, AliasEntry { threshold: u32::MAX, alias: 1 }, row[0]]);
    }

    #[test]
    fn a_draw_keeps_a_column_strictly_below_its_threshold() {
        let row = alias_row(&[1.0, 3.0]);
        // High bits 0 pick column 0; low bits decide: below 2^31 keep it, from 2^31 on take 1.
        assert_eq!(pick(&row, 0, 2, (1 << 31) - 1), 0);
        assert_eq!(pick(&row, 0, 2, 1 << 31), 1);
        // High bits 2^31 pick column 1 (always kept, even with the largest low bits).
        assert_eq!(pick(&row, 0, 2, (1 << 63) | u64::from(u32::MAX)), 1);
        // Weights 0.5, 1 and 1.5 (scaled exactly so): the column of scaled weight 1, and the one
        // brought down to exactly 1 by pairing, keep themselves even for the largest low bits.
        let row = alias_row(&[0.5, 1.0, 1.5]);
        assert_eq!(pick(&row, 0, 3, (0x5555_5556 << 32) | u64::from(u32::MAX)), 1);
        assert_eq!(pick(&row, 0, 3, (0xAAAA_AAAB << 32) | u64::from(u32::MAX)), 2);
        assert_eq!(pick(&row, 0, 3, 1 << 30), 0);
        assert_eq!(pick(&row, 0, 3, (1 << 31) | 1), 2);
        // A zero-probability column is never drawn, even with low bits 0.
        let hot = alias_row(&[0.0, 1.0, 0.0]);
        for x in [0, u64::from(u32::MAX), u64::MAX, 1 << 63] {
            assert_eq!(pick(&hot, 0, 3, x), 1, "x = {x:#x}");
        }
    }
}
