//! The sufficient statistics of the CE update: counting the (condition, outcome) pairs of a
//! recorded episode (model §3).

use crate::policy::Layout;

/// Adds one recorded episode's (condition, outcome) pairs to `counts` (laid out as the
/// policy's flat tables): the sufficient statistics of the CE update (model §3).
#[inline]
pub fn count_episode(layout: &Layout, record: &[u16], counts: &mut [u32]) {
    let width = layout.record_width();
    let depth = layout.depth();
    let tables = &layout.tables;
    let (h0, h1) = (&tables[0], &tables[1]);
    let u1 = layout.upper_size(1);
    let mut previous: &[u16] = &[];
    for step in record.chunks_exact(width) {
        let (y, d, m) = (step[0] as usize, step[1] as usize, &step[2..]);
        counts[h0.offset + m[0] as usize * h0.cols + d] += 1;
        let u = if depth >= 2 { m[1] as usize } else { 0 };
        counts[h1.offset + (y * u1 + u) * h1.cols + m[0] as usize] += 1;
        for l in 2..=depth {
            let u = if l < depth { m[l] as usize } else { 0 };
            let outcome = m[l - 1] as usize;
            if previous.is_empty() {
                let t = &tables[Layout::start_table(l)];
                counts[t.offset + u * t.cols + outcome] += 1;
            } else {
                let t = &tables[Layout::step_table(l)];
                let row = previous[l - 2] as usize * layout.upper_size(l) + u;
                counts[t.offset + row * t.cols + outcome] += 1;
            }
        }
        previous = m;
    }
}
