//! The expected immediate reward `r(a, s)`, computed from the reward entries
//! without ever building the dense `R(a, s, s', o)`.

use crate::world::cassandra::model::{Pomdp, RewardEntry};

/// Scratch space reused across `(a, s)` pairs.
struct Scratch {
    /// Entries that apply to the current `(a, s)`, in file order.
    merged: Vec<usize>,
    /// Of the tail, the entries with `s' = *`.
    wild_next: Vec<usize>,
    /// Of the tail, the entries with a specific `s'` (only reachable ones).
    per_next: Vec<Vec<usize>>,
    /// The `s'` whose `per_next` list is non-empty.
    touched: Vec<usize>,
    /// `seen[o] == stamp` when observation `o` already has its value.
    seen: Vec<usize>,
    stamp: usize,
}

/// Entries grouped by which of `(a, s)` they fix, each group in file order.
struct Buckets {
    both: Vec<Vec<usize>>,
    action_only: Vec<Vec<usize>>,
    state_only: Vec<Vec<usize>>,
    neither: Vec<usize>,
}

impl Buckets {
    fn new(entries: &[RewardEntry], na: usize, ns: usize) -> Self {
        let mut b = Buckets {
            both: vec![Vec::new(); na * ns],
            action_only: vec![Vec::new(); na],
            state_only: vec![Vec::new(); ns],
            neither: Vec::new(),
        };
        for (i, e) in entries.iter().enumerate() {
            let list = match (e.action, e.state) {
                (Some(a), Some(s)) if a < na && s < ns => b.both.get_mut(a * ns + s),
                (Some(a), None) => b.action_only.get_mut(a),
                (None, Some(s)) => b.state_only.get_mut(s),
                (None, None) => Some(&mut b.neither),
                (Some(_), Some(_)) => None,
            };
            if let Some(list) = list {
                list.push(i);
            }
        }
        b
    }

    fn collect(&self, a: usize, s: usize, ns: usize, out: &mut Vec<usize>) {
        out.clear();
        for list in [self.both.get(a * ns + s), self.action_only.get(a), self.state_only.get(s), Some(&self.neither)]
            .into_iter()
            .flatten()
        {
            out.extend_from_slice(list);
        }
        // The four groups are disjoint; sorting restores file order.
        out.sort_unstable();
    }
}

impl Pomdp {
    /// The expected immediate reward `r(a, s) = Σ_{s'} T(s'|s,a) Σ_o O(o|a,s')
    /// R(a, s, s', o)`, as a dense A×S table at index `a*S + s`.
    ///
    /// Values are as written: for a [`crate::world::cassandra::Values::Cost`] file these are
    /// expected costs.
    ///
    /// For each `(a, s)`, only the entries after the last one with `s' = *`
    /// and `o = *` matter, and for each reachable `s'` only those after the
    /// last one with `o = *`; so wildcard entries cost O(1), not O(S·O).
    #[must_use]
    pub fn expected_reward(&self) -> Vec<f64> {
        let (na, ns, no) = (self.num_actions(), self.num_states(), self.num_observations());
        let mut out = vec![0.0; na * ns];
        if self.transition.len() != na * ns * ns || self.observation.len() != na * ns * no {
            return out;
        }
        // osum[a*S + s'] = Σ_o O(o|a,s'): 1 up to rounding, kept exact.
        let osum: Vec<f64> = self.observation.chunks(no.max(1)).map(|row| row.iter().sum()).collect();
        let buckets = Buckets::new(&self.rewards, na, ns);
        let mut sc = Scratch {
            merged: Vec::new(),
            wild_next: Vec::new(),
            per_next: vec![Vec::new(); ns],
            touched: Vec::new(),
            seen: vec![0; no],
            stamp: 0,
        };
        for a in 0..na {
            let orow_sums = osum.get(a * ns..(a + 1) * ns).unwrap_or_default();
            let orows = self.observation.get(a * ns * no..(a + 1) * ns * no).unwrap_or_default();
            for s in 0..ns {
                let trow = self.transition.get((a * ns + s) * ns..(a * ns + s + 1) * ns).unwrap_or_default();
                buckets.collect(a, s, ns, &mut sc.merged);
                let value = self.expected_one(trow, orows, orow_sums, &mut sc);
                if let Some(slot) = out.get_mut(a * ns + s) {
                    *slot = value;
                }
            }
        }
        out
    }

    /// `r(a, s)` from the entries in `sc.merged` (those matching `(a, s)`).
    fn expected_one(&self, trow: &[f64], orows: &[f64], orow_sums: &[f64], sc: &mut Scratch) -> f64 {
        let entries = &self.rewards;
        let no = self.num_observations();
        let entry = |i: usize| entries.get(i);
        let last_full = sc
            .merged
            .iter()
            .rposition(|&i| entry(i).is_some_and(|e| e.next_state.is_none() && e.observation.is_none()));
        let base = last_full.and_then(|k| sc.merged.get(k)).and_then(|&i| entry(i)).map_or(0.0, |e| e.value);
        let tail = sc.merged.get(last_full.map_or(0, |k| k + 1)..).unwrap_or_default();
        if tail.is_empty() {
            let mass: f64 = trow.iter().zip(orow_sums).map(|(t, m)| t * m).sum();
            return base * mass;
        }
        sc.wild_next.clear();
        for &i in tail {
            let Some(e) = entry(i) else { continue };
            match e.next_state {
                None => sc.wild_next.push(i),
                Some(n) if trow.get(n).is_some_and(|&t| t > 0.0) => {
                    if let Some(list) = sc.per_next.get_mut(n) {
                        if list.is_empty() {
                            sc.touched.push(n);
                        }
                        list.push(i);
                    }
                }
                Some(_) => {}
            }
        }
        let mut total = 0.0;
        for (s2, &t) in trow.iter().enumerate() {
            if t <= 0.0 {
                continue;
            }
            let orow = orows.get(s2 * no..(s2 + 1) * no).unwrap_or_default();
            let specific: &[usize] = sc.per_next.get(s2).map_or(&[], Vec::as_slice);
            sc.stamp += 1;
            let (mut acc, mut covered, mut base2) = (0.0, 0.0, base);
            // Walk both lists backwards in file order: the first entry met
            // for each observation is the one that wins.
            let (mut wild_left, mut spec_left) = (sc.wild_next.len(), specific.len());
            while wild_left > 0 || spec_left > 0 {
                let wi = wild_left.checked_sub(1).and_then(|k| sc.wild_next.get(k));
                let sj = spec_left.checked_sub(1).and_then(|k| specific.get(k));
                let idx = match (wi, sj) {
                    (Some(&x), Some(&y)) if x > y => {
                        wild_left -= 1;
                        x
                    }
                    (_, Some(&y)) => {
                        spec_left -= 1;
                        y
                    }
                    (Some(&x), None) => {
                        wild_left -= 1;
                        x
                    }
                    (None, None) => break,
                };
                let Some(ent) = entry(idx) else { continue };
                match ent.observation {
                    None => {
                        base2 = ent.value;
                        break;
                    }
                    Some(obs) => {
                        if let Some(mark) = sc.seen.get_mut(obs)
                            && *mark != sc.stamp
                        {
                            *mark = sc.stamp;
                            let prob = orow.get(obs).copied().unwrap_or(0.0);
                            acc += prob * ent.value;
                            covered += prob;
                        }
                    }
                }
            }
            let osum = orow_sums.get(s2).copied().unwrap_or(0.0);
            total += t * (acc + base2 * (osum - covered));
        }
        for n in sc.touched.drain(..) {
            if let Some(list) = sc.per_next.get_mut(n) {
                list.clear();
            }
        }
        total
    }
}

/// The reward of every outcome `(s', o)` of one `(a, s)`: the value of the last entry in file
/// order that matches (0 where none does), found in O(entries + O) for each `s'` rather than by
/// scanning the entries for each outcome (a file of wildcard lines over thousands of states
/// would take cubic time).
pub struct OutcomeRewards<'a> {
    pomdp: &'a Pomdp,
    /// The entries that match the current `(a, s)`, in file order.
    entries: Vec<usize>,
    /// For each `o`, the last of `entries` with `s' = *` matching `o` (a position in `entries`).
    wild: Vec<Option<usize>>,
    /// For each `s'`, the positions in `entries` of those with that `s'`.
    by_next: Vec<Vec<usize>>,
    touched: Vec<usize>,
    last: Vec<Option<usize>>,
    row: Vec<f64>,
}

impl Pomdp {
    /// An [`OutcomeRewards`] for this model (call [`OutcomeRewards::select`] first).
    pub fn outcome_rewards(&self) -> OutcomeRewards<'_> {
        let (ns, no) = (self.num_states(), self.num_observations());
        OutcomeRewards {
            pomdp: self,
            entries: Vec::new(),
            wild: vec![None; no],
            by_next: vec![Vec::new(); ns],
            touched: Vec::new(),
            last: vec![None; no],
            row: vec![0.0; no],
        }
    }
}

impl OutcomeRewards<'_> {
    /// Makes `(a, s)` the pair whose outcomes [`OutcomeRewards::row`] gives.
    pub fn select(&mut self, a: usize, s: usize) {
        let rewards = &self.pomdp.rewards;
        self.entries.clear();
        self.entries.extend(
            (0..rewards.len())
                .filter(|&i| rewards[i].action.is_none_or(|x| x == a) && rewards[i].state.is_none_or(|x| x == s)),
        );
        for n in self.touched.drain(..) {
            self.by_next[n].clear();
        }
        self.wild.fill(None);
        let mut wild_all = None;
        for (k, &i) in self.entries.iter().enumerate() {
            let e = &rewards[i];
            match (e.next_state, e.observation) {
                (None, None) => wild_all = Some(k),
                (None, Some(o)) => {
                    if let Some(w) = self.wild.get_mut(o) {
                        *w = Some(k);
                    }
                }
                (Some(n), _) => {
                    if let Some(list) = self.by_next.get_mut(n) {
                        if list.is_empty() {
                            self.touched.push(n);
                        }
                        list.push(k);
                    }
                }
            }
        }
        // `None < Some`: the later of the two wins.
        self.wild.iter_mut().for_each(|w| *w = (*w).max(wild_all));
    }

    /// The reward of each observation `o` after the move to `s2`, at index `o`.
    pub fn row(&mut self, s2: usize) -> &[f64] {
        let rewards = &self.pomdp.rewards;
        let value = |k: Option<usize>| k.map_or(0.0, |k| rewards[self.entries[k]].value);
        let specific = self.by_next.get(s2).map_or(&[][..], Vec::as_slice);
        let mut specific_all = None;
        let last = &mut self.last;
        last.copy_from_slice(&self.wild);
        for &k in specific {
            match rewards[self.entries[k]].observation {
                None => specific_all = Some(k),
                Some(o) => {
                    if let Some(l) = last.get_mut(o) {
                        *l = (*l).max(Some(k));
                    }
                }
            }
        }
        for (slot, l) in self.row.iter_mut().zip(last.iter()) {
            *slot = value((*l).max(specific_all));
        }
        &self.row
    }
}
