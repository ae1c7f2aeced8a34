//! The document's sections, and the flat model: the products of the tables over every state,
//! action and observation.

use roxmltree::Node;

use super::factor::{Factor, Section};
use super::vars::{Observed, Ref, Variables};
use super::{Ctx, Result, elements, strides, text_of};
use crate::world::cassandra::validate::{RowCheck, fmt_num, normalise};
use crate::world::cassandra::{Pomdp, Values};

/// The tables of each section, one per variable (rewards: all of them, to be summed).
pub(super) struct Tables<'a, 'i> {
    pub belief: Option<(Node<'a, 'i>, Vec<Option<Factor>>)>,
    pub transition: Vec<Option<Factor>>,
    pub observation: Vec<Option<Factor>>,
    pub reward: Vec<Factor>,
}

/// Reads the `<pomdpx>` element into the flat model.
pub(crate) fn read(ctx: &Ctx, root: Node) -> Result<Pomdp> {
    if root.tag_name().name() != "pomdpx" {
        return Err(ctx.error(root, format!("the root element is <{}> (expected <pomdpx>)", root.tag_name().name())));
    }
    let (mut discount, mut variables) = (None, None);
    let mut sections = Vec::new();
    for child in elements(root) {
        let name = child.tag_name().name();
        let twice = |seen: bool| {
            if seen { Err(ctx.error(child, format!("a second <{name}> (expected one)"))) } else { Ok(()) }
        };
        match name {
            "Description" => {}
            "Discount" => {
                twice(discount.is_some())?;
                let text = text_of(ctx, child)?;
                let gamma = text.trim().parse::<f64>().ok().filter(|g| (0.0..=1.0).contains(g));
                discount = Some(gamma.ok_or_else(|| {
                    ctx.error(child, format!("<Discount>{}</Discount> (expected a number in [0, 1])", text.trim()))
                })?);
            }
            "Variable" => {
                twice(variables.is_some())?;
                variables = Some(child);
            }
            "InitialStateBelief" => sections.push((Section::Belief, child)),
            "StateTransitionFunction" => sections.push((Section::Transition, child)),
            "ObsFunction" => sections.push((Section::Observation, child)),
            "RewardFunction" => sections.push((Section::Reward, child)),
            other => {
                return Err(ctx.error(
                    child,
                    format!(
                        "unknown element <{other}> in <pomdpx> (expected <Description>, <Discount>, <Variable>, \
                         <InitialStateBelief>, <StateTransitionFunction>, <ObsFunction> or <RewardFunction>)"
                    ),
                ));
            }
        }
    }
    let variables = variables.ok_or_else(|| ctx.error(root, "no <Variable> (expected the variables' declarations)"))?;
    let vars = Variables::read(ctx, variables)?;
    let tables = read_tables(ctx, &vars, root, &sections)?;
    Flat::new(ctx, &vars, variables)?.build(ctx, &vars, root, discount, &tables)
}

fn read_tables<'a, 'i>(
    ctx: &Ctx,
    vars: &Variables,
    root: Node<'a, 'i>,
    sections: &[(Section, Node<'a, 'i>)],
) -> Result<Tables<'a, 'i>> {
    let mut tables = Tables {
        belief: None,
        transition: (0..vars.states.len()).map(|_| None).collect(),
        observation: (0..vars.observations.len()).map(|_| None).collect(),
        reward: Vec::new(),
    };
    for &(section, node) in sections {
        if section == Section::Belief && tables.belief.is_none() {
            tables.belief = Some((node, (0..vars.states.len()).map(|_| None).collect()));
        }
        for child in elements(node) {
            if child.tag_name().name() != section.element() {
                return Err(ctx.error(
                    child,
                    format!(
                        "<{}> in <{}> (expected <{}>s)",
                        child.tag_name().name(),
                        section.container(),
                        section.element()
                    ),
                ));
            }
            let factor = Factor::read(ctx, vars, section, child)?;
            let slot = match (section, factor.var) {
                (Section::Belief, Ref::Prev(i)) => tables.belief.as_mut().and_then(|(_, b)| b.get_mut(i)),
                (Section::Transition, Ref::Curr(i)) => tables.transition.get_mut(i),
                (Section::Observation, Ref::Obs(j)) => tables.observation.get_mut(j),
                (Section::Reward, _) => {
                    tables.reward.push(factor);
                    continue;
                }
                // The other pairings are refused as the table is read.
                _ => None,
            };
            let Some(slot) = slot else { continue };
            if let Some(first) = slot {
                return Err(ctx.error(
                    child,
                    format!(
                        "a second <{}> of {} in <{}> (the first is on line {})",
                        section.element(),
                        vars.name(factor.var),
                        section.container(),
                        first.line
                    ),
                ));
            }
            *slot = Some(factor);
        }
    }
    let section_node = |s: Section| sections.iter().find(|(t, _)| *t == s).map_or(root, |&(_, n)| n);
    let state_name = |i: usize| vars.states.get(i).map_or(String::new(), |s| s.var.name.clone());
    complete(ctx, Section::Transition, &tables.transition, &state_name, section_node(Section::Transition))?;
    let obs_name = |j: usize| vars.observations.get(j).map_or(String::new(), |v| v.name.clone());
    complete(ctx, Section::Observation, &tables.observation, &obs_name, section_node(Section::Observation))?;
    if let Some((node, belief)) = &tables.belief {
        let prev_name = |i: usize| vars.states.get(i).map_or(String::new(), |s| s.prev.clone());
        complete(ctx, Section::Belief, belief, &prev_name, *node)?;
    }
    Ok(tables)
}

/// Refuses a section without a table of each of its variables (`name(i)` the `i`-th's name).
fn complete(
    ctx: &Ctx,
    section: Section,
    list: &[Option<Factor>],
    name: &dyn Fn(usize) -> String,
    at: Node,
) -> Result<()> {
    match list.iter().position(Option::is_none) {
        Some(i) => Err(ctx.error(
            at,
            format!(
                "no <{}> of {} in <{}> (expected one per variable)",
                section.element(),
                name(i),
                section.container()
            ),
        )),
        None => Ok(()),
    }
}

/// The flat model's sizes and how its indices decompose into the variables' values.
pub(super) struct Flat {
    pub ns: usize,
    pub na: usize,
    pub no: usize,
    /// Row-major strides of the state, action and observation parts.
    pub state_strides: Vec<usize>,
    pub action_strides: Vec<usize>,
    pub obs_strides: Vec<usize>,
}

/// Where a table's cell is, by part of the flat `(a, s, s', o)`: the offset each value of a
/// part adds (empty where the table does not depend on that part).
pub(super) struct Offsets {
    pub a: Vec<usize>,
    pub s: Vec<usize>,
    pub s2: Vec<usize>,
    pub o: Vec<usize>,
}

pub(super) fn at(offsets: &[usize], i: usize) -> usize {
    offsets.get(i).copied().unwrap_or(0)
}

impl Flat {
    /// The sizes, refused past [`crate::world::cassandra::Options::max_entries`].
    fn new(ctx: &Ctx, vars: &Variables, at_node: Node) -> Result<Flat> {
        let state_sizes: Vec<usize> = vars.states.iter().map(|s| s.var.len()).collect();
        let action_sizes: Vec<usize> = vars.actions.iter().map(super::vars::Var::len).collect();
        let obs_sizes: Vec<usize> = vars.observed.iter().map(|&c| observed_len(vars, c)).collect();
        let product = |sizes: &[usize]| sizes.iter().try_fold(1usize, |p, &n| p.checked_mul(n));
        let limit = ctx.options.max_entries;
        let (ns, na, no) = (product(&state_sizes), product(&action_sizes), product(&obs_sizes));
        let t_size = ns.zip(na).and_then(|(ns, na)| na.checked_mul(ns)?.checked_mul(ns));
        let o_size = ns.zip(na).zip(no).and_then(|((ns, na), no)| na.checked_mul(ns)?.checked_mul(no));
        let shown = |n: Option<usize>, sizes: &[usize]| {
            let n = n.map_or_else(|| "too many".to_string(), |n| n.to_string());
            if sizes.len() > 1 {
                format!("{n} ({})", sizes.iter().map(ToString::to_string).collect::<Vec<_>>().join(" x "))
            } else {
                n
            }
        };
        for (size, table) in [(t_size, "transition table T (A x S x S)"), (o_size, "observation table O (A x S x O)")] {
            if size.is_none_or(|x| x > limit) {
                return Err(ctx.error(
                    at_node,
                    format!(
                        "the model is too large: with {} states, {} actions and {} observations the {table} would \
                         have more than {limit} entries",
                        shown(ns, &state_sizes),
                        shown(na, &action_sizes),
                        shown(no, &obs_sizes)
                    ),
                ));
            }
        }
        let (ns, na, no) = (ns.unwrap_or(0), na.unwrap_or(0), no.unwrap_or(0));
        let bytes = (t_size.unwrap_or(0) as u64 + o_size.unwrap_or(0) as u64).saturating_mul(8);
        let what = format!("the tables T and O of a model with {ns} states, {na} actions and {no} observations");
        crate::memory::check_memory(&what, bytes, crate::memory::available_memory())
            .map_err(|e| ctx.error(at_node, e.to_string()))?;
        Ok(Flat {
            ns,
            na,
            no,
            state_strides: strides(&state_sizes),
            action_strides: strides(&action_sizes),
            obs_strides: strides(&obs_sizes),
        })
    }

    /// The value of variable `r` in the flat index `i` of its part.
    fn value(&self, vars: &Variables, r: Ref, i: usize) -> usize {
        let (stride, n) = match r {
            Ref::Prev(k) | Ref::Curr(k) => (self.state_strides.get(k), vars.states.get(k).map(|s| s.var.len())),
            Ref::Action(k) => (self.action_strides.get(k), vars.actions.get(k).map(super::vars::Var::len)),
            Ref::Obs(j) => {
                let c = vars.observed.iter().position(|&c| c == Observed::Obs(j)).unwrap_or(usize::MAX);
                (self.obs_strides.get(c), vars.observations.get(j).map(super::vars::Var::len))
            }
            Ref::Reward => (None, None),
        };
        (i / stride.copied().unwrap_or(1).max(1)) % n.unwrap_or(1).max(1)
    }

    pub fn offsets(&self, vars: &Variables, factor: &Factor) -> Offsets {
        let strides = factor.strides();
        let part = |len: usize, keep: &dyn Fn(Ref) -> bool| -> Vec<usize> {
            let dims: Vec<(Ref, usize)> =
                factor.dims.iter().zip(&strides).filter(|(r, _)| keep(**r)).map(|(&r, &s)| (r, s)).collect();
            if dims.is_empty() {
                return Vec::new();
            }
            (0..len).map(|i| dims.iter().map(|&(r, stride)| self.value(vars, r, i) * stride).sum()).collect()
        };
        Offsets {
            a: part(self.na, &|r| matches!(r, Ref::Action(_))),
            s: part(self.ns, &|r| matches!(r, Ref::Prev(_))),
            s2: part(self.ns, &|r| matches!(r, Ref::Curr(_))),
            o: part(self.no, &|r| matches!(r, Ref::Obs(_))),
        }
    }

    /// The names of a part's flat values: the values of its variables joined with `_`.
    fn names(n: usize, parts: &[&[String]]) -> Vec<String> {
        if parts.is_empty() {
            return vec!["none".to_string(); n.min(1)];
        }
        let strides = strides(&parts.iter().map(|v| v.len()).collect::<Vec<_>>());
        (0..n)
            .map(|i| {
                let values = parts.iter().zip(&strides);
                values
                    .map(|(values, &stride)| values.get((i / stride) % values.len().max(1)).map_or("", String::as_str))
                    .collect::<Vec<_>>()
                    .join("_")
            })
            .collect()
    }

    /// Of each observation and of each state, the values of the fully observed state variables
    /// as one number: an observation may follow a move to a state only where the two agree.
    fn shown_keys(&self, vars: &Variables) -> (Vec<usize>, Vec<usize>) {
        let key = |value: &dyn Fn(usize, usize) -> usize| {
            vars.observed
                .iter()
                .enumerate()
                .filter_map(|(c, &part)| match part {
                    Observed::State(k) => Some(value(c, k) * self.obs_strides[c]),
                    Observed::Obs(_) => None,
                })
                .sum::<usize>()
        };
        let shown = (0..self.no)
            .map(|o| key(&|c, k| (o / self.obs_strides[c]) % vars.states.get(k).map_or(1, |s| s.var.len()).max(1)))
            .collect();
        let actual = (0..self.ns).map(|s| key(&|_, k| self.value(vars, Ref::Prev(k), s))).collect();
        (shown, actual)
    }

    /// The start: the product of the initial belief's tables (`None` without them).
    fn start(&self, ctx: &Ctx, vars: &Variables, tables: &Tables) -> Result<Option<Vec<f64>>> {
        let Some((node, belief)) = &tables.belief else { return Ok(None) };
        let factors: Vec<&Factor> = belief.iter().flatten().collect();
        let offsets: Vec<Offsets> = factors.iter().map(|f| self.offsets(vars, f)).collect();
        let bases = vec![0; factors.len()];
        let mut start: Vec<f64> =
            (0..self.ns).map(|s| product(&factors, &offsets, &bases, |off| at(&off.s, s))).collect();
        let label = || "the initial belief".to_string();
        check(ctx, &mut start, ctx.options.tolerance, &label, || ctx.error(*node, ""))?;
        Ok(Some(start))
    }

    fn build(self, ctx: &Ctx, vars: &Variables, root: Node, discount: Option<f64>, tables: &Tables) -> Result<Pomdp> {
        let (ns, na, no) = (self.ns, self.na, self.no);
        let states = Self::names(ns, &vars.states.iter().map(|s| &s.var.values[..]).collect::<Vec<_>>());
        let actions = Self::names(na, &vars.actions.iter().map(|v| &v.values[..]).collect::<Vec<_>>());
        let observed: Vec<&[String]> = vars
            .observed
            .iter()
            .map(|&c| match c {
                Observed::State(i) => vars.states.get(i).map_or(&[][..], |s| &s.var.values[..]),
                Observed::Obs(j) => vars.observations.get(j).map_or(&[][..], |v| &v.values[..]),
            })
            .collect();
        let observations = Self::names(no, &observed);
        let tol = ctx.options.tolerance;
        let transition_node = section_node(root, Section::Transition);
        let transition_factors: Vec<&Factor> = tables.transition.iter().flatten().collect();
        let t_offsets: Vec<Offsets> = transition_factors.iter().map(|f| self.offsets(vars, f)).collect();
        let mut transition = vec![0.0; na * ns * ns];
        let mut bases = vec![0; transition_factors.len()];
        for (r, row) in transition.chunks_mut(ns.max(1)).enumerate() {
            let (a, s) = (r / ns.max(1), r % ns.max(1));
            for (b, off) in bases.iter_mut().zip(&t_offsets) {
                *b = at(&off.a, a) + at(&off.s, s);
            }
            for (s2, cell) in row.iter_mut().enumerate() {
                *cell = product(&transition_factors, &t_offsets, &bases, |off| at(&off.s2, s2));
            }
            let label = || format!("T(.|a={}, s={})", actions[a], states[s]);
            check(ctx, row, tol, &label, || {
                let in_row = |r: Ref| matches!(r, Ref::Action(_) | Ref::Prev(_));
                diagnose(ctx, vars, &transition_factors, &bases, &in_row, transition_node.range().start)
            })?;
        }
        let (shown_state, true_state) = self.shown_keys(vars);
        let observation_node = section_node(root, Section::Observation);
        let observation_factors: Vec<&Factor> = tables.observation.iter().flatten().collect();
        let o_offsets: Vec<Offsets> = observation_factors.iter().map(|f| self.offsets(vars, f)).collect();
        let mut observation = vec![0.0; na * ns * no];
        let mut bases = vec![0; observation_factors.len()];
        for (r, row) in observation.chunks_mut(no.max(1)).enumerate() {
            let (a, s2) = (r / ns.max(1), r % ns.max(1));
            for (b, off) in bases.iter_mut().zip(&o_offsets) {
                *b = at(&off.a, a) + at(&off.s2, s2);
            }
            for (o, cell) in row.iter_mut().enumerate() {
                if shown_state[o] == true_state[s2] {
                    *cell = product(&observation_factors, &o_offsets, &bases, |off| at(&off.o, o));
                }
            }
            let label = || format!("O(.|a={}, s'={})", actions[a], states[s2]);
            check(ctx, row, tol, &label, || {
                let in_row = |r: Ref| matches!(r, Ref::Action(_) | Ref::Curr(_));
                diagnose(ctx, vars, &observation_factors, &bases, &in_row, observation_node.range().start)
            })?;
        }
        let start = self.start(ctx, vars, tables)?;
        let mut rewards = self.rewards(ctx, vars, root, tables, &transition, &observation)?;
        let (observations, observation) = if vars.observed.iter().any(|c| matches!(c, Observed::State(_))) {
            super::reward::prune_observations(observations, &observation, &mut rewards)
        } else {
            (observations, observation)
        };
        Ok(Pomdp {
            discount,
            values: Values::Reward,
            states,
            actions,
            observations,
            start,
            transition,
            observation,
            rewards,
            renormalised: ctx.take_notes(),
        })
    }
}

fn observed_len(vars: &Variables, part: Observed) -> usize {
    match part {
        Observed::State(i) => vars.states.get(i).map_or(1, |s| s.var.len()),
        Observed::Obs(j) => vars.observations.get(j).map_or(1, super::vars::Var::len),
    }
}

pub(super) fn section_node<'a, 'i>(root: Node<'a, 'i>, section: Section) -> Node<'a, 'i> {
    elements(root).find(|c| c.tag_name().name() == section.container()).unwrap_or(root)
}

/// The product of the factors' cells at `bases[f] + more(offsets[f])`, 0 as soon as one is.
fn product(factors: &[&Factor], offsets: &[Offsets], bases: &[usize], more: impl Fn(&Offsets) -> usize) -> f64 {
    let mut p = 1.0;
    for ((f, off), &base) in factors.iter().zip(offsets).zip(bases) {
        p *= f.table.get(base + more(off)).copied().unwrap_or(0.0);
        if p == 0.0 {
            break;
        }
    }
    p
}

/// Checks a flat probability row (renormalising it within the tolerance); `fail` gives the
/// error's place and cause, its message then prefixed with the row and its sum.
fn check(
    ctx: &Ctx,
    row: &mut [f64],
    tol: f64,
    label: &dyn Fn() -> String,
    fail: impl FnOnce() -> crate::world::cassandra::ParseError,
) -> Result<()> {
    match normalise(row, tol) {
        RowCheck::Exact => Ok(()),
        RowCheck::Renormalised(sum) => {
            ctx.note(format!("{} summed to {}; renormalised", label(), fmt_num(sum)));
            Ok(())
        }
        RowCheck::Bad(sum) => {
            let mut e = fail();
            let cause = if e.message.is_empty() { String::new() } else { format!(": {}", e.message) };
            e.message = format!(
                "{}, the product of the <CondProb>s, sums to {} (expected 1 within {tol:e}){cause}",
                label(),
                fmt_num(sum)
            );
            Err(e)
        }
    }
}

/// Why a flat row does not sum to 1, where it is found: a table whose row for these values of
/// its parents no `<Entry>` wrote (of the tables whose parents are all `in_row`: fixed by the
/// flat row, their part of the cell's offset in `bases`).
fn diagnose(
    ctx: &Ctx,
    vars: &Variables,
    factors: &[&Factor],
    bases: &[usize],
    in_row: &dyn Fn(Ref) -> bool,
    at_offset: usize,
) -> crate::world::cassandra::ParseError {
    for (f, &base) in factors.iter().zip(bases) {
        // The variable is the last dimension, of stride 1: `base` is its row's first cell.
        let parents = &f.dims[..f.dims.len().saturating_sub(1)];
        let row = base / f.sizes.last().copied().unwrap_or(1).max(1);
        if parents.iter().all(|&r| in_row(r)) && !f.row_written(row) {
            return ctx.error_at(at_offset, format!("{} has no <Entry>{}", f.label(vars), f.row_name(vars, row)));
        }
    }
    ctx.error_at(at_offset, "")
}
