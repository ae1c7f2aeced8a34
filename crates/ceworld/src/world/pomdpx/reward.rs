//! The rewards: the `<Func>`s summed, as entries over the parts of `(a, s, s', o)` they depend
//! on; and the observations left out where fully observed variables make them many.

use roxmltree::Node;

use super::Ctx;
use super::Result;
use super::factor::Section;
use super::flatten::{Flat, Offsets, Tables, at, section_node};
use super::vars::Variables;
use crate::world::cassandra::RewardEntry;

impl Flat {
    /// The summed rewards as entries over the parts of `(a, s, s', o)` they depend on.
    pub fn rewards(
        &self,
        ctx: &Ctx,
        vars: &Variables,
        root: Node,
        tables: &Tables,
        transition: &[f64],
        observation: &[f64],
    ) -> Result<Vec<RewardEntry>> {
        let (ns, na, no) = (self.ns, self.na, self.no);
        let offsets: Vec<Offsets> = tables.reward.iter().map(|f| self.offsets(vars, f)).collect();
        let uses = |part: fn(&Offsets) -> &Vec<usize>| offsets.iter().any(|o| !part(o).is_empty());
        let (ua, us, us2, uo) = (uses(|o| &o.a), uses(|o| &o.s), uses(|o| &o.s2), uses(|o| &o.o));
        let range = |used: bool, n: usize| if used { n } else { 1 };
        let (ra, rs, rs2, ro) = (range(ua, na), range(us, ns), range(us2, ns), range(uo, no));
        let limit = ctx.options.max_entries;
        let combinations = ra.checked_mul(rs).and_then(|x| x.checked_mul(rs2)?.checked_mul(ro));
        if combinations.is_none_or(|c| c > limit) {
            let parts: Vec<&str> = [(ua, "A"), (us, "S"), (us2, "S'"), (uo, "O")]
                .iter()
                .filter_map(|&(used, name)| used.then_some(name))
                .collect();
            return Err(ctx.error(
                section_node(root, Section::Reward),
                format!(
                    "the rewards depend on {}: more than {limit} combinations (the most a reward table may have)",
                    parts.join(" x ")
                ),
            ));
        }
        let mut entries = Vec::new();
        let some = |used: bool, i: usize| used.then_some(i);
        for a in 0..ra {
            for s in 0..rs {
                for s2 in 0..rs2 {
                    if ua && us && us2 && transition.get((a * ns + s) * ns + s2).is_none_or(|&t| t == 0.0) {
                        continue;
                    }
                    for o in 0..ro {
                        if ua && us2 && uo && observation.get((a * ns + s2) * no + o).is_none_or(|&p| p == 0.0) {
                            continue;
                        }
                        let value: f64 = tables
                            .reward
                            .iter()
                            .zip(&offsets)
                            .map(|(f, off)| {
                                let cell = at(&off.a, a) + at(&off.s, s) + at(&off.s2, s2) + at(&off.o, o);
                                f.table.get(cell).copied().unwrap_or(0.0)
                            })
                            .sum();
                        if value != 0.0 {
                            entries.push(RewardEntry {
                                action: some(ua, a),
                                state: some(us, s),
                                next_state: some(us2, s2),
                                observation: some(uo, o),
                                value,
                            });
                        }
                    }
                }
            }
        }
        Ok(entries)
    }
}

/// The observations that some `(a, s')` may emit, the others left out (with the rewards of
/// those): an observation made of a fully observed state variable's value and the observation
/// variables' is the product of both, of which a file's tables commonly show a few (`TagAvoid`: 58
/// of 870).
pub(super) fn prune_observations(
    names: Vec<String>,
    observation: &[f64],
    rewards: &mut Vec<RewardEntry>,
) -> (Vec<String>, Vec<f64>) {
    let no = names.len().max(1);
    let mut emitted = vec![false; no];
    for row in observation.chunks(no) {
        for (seen, &p) in emitted.iter_mut().zip(row) {
            *seen |= p > 0.0;
        }
    }
    let mut new_index = vec![None; no];
    let mut kept = 0;
    for (o, seen) in emitted.iter().enumerate() {
        if *seen {
            new_index[o] = Some(kept);
            kept += 1;
        }
    }
    let pruned: Vec<f64> = observation
        .chunks(no)
        .flat_map(|row| row.iter().zip(&emitted).filter(|(_, seen)| **seen).map(|(&p, _)| p))
        .collect();
    rewards.retain_mut(|e| match e.observation {
        None => true,
        Some(o) => {
            e.observation = new_index.get(o).copied().flatten();
            e.observation.is_some()
        }
    });
    let names = names.into_iter().zip(&emitted).filter(|(_, seen)| **seen).map(|(n, _)| n).collect();
    (names, pruned)
}
