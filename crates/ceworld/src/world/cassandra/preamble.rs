//! The preamble (`discount:`, `values:`, `states:`, `actions:`,
//! `observations:`) and the start belief.

use std::collections::HashMap;

use crate::world::cassandra::error::ParseError;
use crate::world::cassandra::lexer::{Pos, Tok};
use crate::world::cassandra::model::Values;
use crate::world::cassandra::parse::{Entities, Item, Kind, Parser, Result};
use crate::world::cassandra::validate::{RowCheck, fmt_num, normalise, span};

impl Parser<'_> {
    /// Common checks for a preamble line; consumes the keyword and colon.
    fn begin_preamble(&mut self, item: Item, kw: &str) -> Result<Pos> {
        let pos = self.bump().pos;
        if let Some(first) = self.first_entry {
            return Err(ParseError::at(
                pos,
                format!("'{kw}' must come before the first T:, O: or R: entry (which is at {first})"),
            ));
        }
        if let Some(prev) = self.seen.get(item as usize).copied().flatten() {
            return Err(ParseError::at(pos, format!("duplicate '{kw}' line (first given at {prev})")));
        }
        if let Some(slot) = self.seen.get_mut(item as usize) {
            *slot = Some(pos);
        }
        Ok(pos)
    }

    pub(crate) fn preamble(&mut self, item: Item, kw: &str) -> Result<()> {
        self.begin_preamble(item, kw)?;
        self.expect_colon(kw)?;
        match item {
            Item::Discount => {
                let Some(num) = self.number()? else {
                    return Err(self.unexpected("a number after 'discount:'"));
                };
                let (v, pos) = (num.value, num.pos);
                if !(0.0..=1.0).contains(&v) {
                    return Err(ParseError::at(
                        pos,
                        format!("discount {num} is out of range (expected a number from 0 to 1)"),
                    ));
                }
                self.discount = Some(v);
            }
            Item::Values => {
                let t = self.peek().clone();
                self.values = Some(match t.tok {
                    Tok::Name("reward" | "rewards") => Values::Reward,
                    Tok::Name("cost" | "costs") => Values::Cost,
                    _ => return Err(self.unexpected("'reward' or 'cost' after 'values:'")),
                });
                self.bump();
            }
            Item::States => self.states = Some(self.declaration(Kind::State)?),
            Item::Actions => self.actions = Some(self.declaration(Kind::Action)?),
            Item::Observations => self.observations = Some(self.declaration(Kind::Observation)?),
            Item::Start => {}
        }
        Ok(())
    }

    /// `states: N` or `states: name name ...` (likewise actions, observations).
    fn declaration(&mut self, kind: Kind) -> Result<Entities> {
        let kw = kind.keyword();
        let t = self.peek().clone();
        if let Some(count) = t.tok.int_literal() {
            let limit = self.max_entries;
            let fits = |n: usize| match kind {
                Kind::State => n.checked_mul(n).is_some_and(|x| x <= limit),
                _ => n <= limit,
            };
            let count = match usize::try_from(count).ok() {
                Some(0) => {
                    return Err(ParseError::at(
                        t.pos,
                        format!("'{kw}: 0': there must be at least one {}", kind.noun()),
                    ));
                }
                Some(c) if fits(c) => c,
                _ => {
                    return Err(ParseError::at(t.pos, too_many(kind, &t.tok.describe(), limit)));
                }
            };
            self.bump();
            return Ok(Entities { count, names: None, lookup: HashMap::new() });
        }
        let mut names = Vec::new();
        let mut lookup = HashMap::new();
        let mut first_pos = Vec::new();
        while let Tok::Name(name) = self.peek().tok {
            if self.at_statement() {
                break;
            }
            let pos = self.bump().pos;
            if let Some(&prev) = lookup.get(name) {
                let at = first_pos.get(prev).copied().unwrap_or(pos);
                return Err(ParseError::at(pos, format!("duplicate {} name '{name}' (first at {at})", kind.noun())));
            }
            lookup.insert(name.to_string(), names.len());
            names.push(name.to_string());
            first_pos.push(pos);
        }
        if names.is_empty() {
            return Err(self.unexpected(&format!("a count or a list of {} names after '{kw}:'", kind.noun())));
        }
        let n = names.len();
        if kind == Kind::State && n.checked_mul(n).is_none_or(|x| x > self.max_entries) {
            return Err(ParseError::at(t.pos, too_many(kind, &format!("{n} names"), self.max_entries)));
        }
        Ok(Entities { count: n, names: Some(names), lookup })
    }

    /// `start: ...`, `start include: ...` or `start exclude: ...`.
    pub(crate) fn start_line(&mut self) -> Result<()> {
        let pos = self.begin_preamble(Item::Start, "start")?;
        let Some(ns) = self.states.as_ref().map(|e| e.count) else {
            return Err(ParseError::at(pos, "'start' must come after 'states:' (the start belief is over the states)"));
        };
        let mode = match self.peek().tok {
            Tok::Name(m @ ("include" | "exclude")) => {
                self.bump();
                Some(m == "include")
            }
            _ => None,
        };
        self.expect_colon(match mode {
            Some(true) => "start include",
            Some(false) => "start exclude",
            None => "start",
        })?;
        let mut dist =
            if let Some(include) = mode { self.start_list(ns, include, pos)? } else { self.start_value(ns)? };
        match normalise(&mut dist, self.tolerance) {
            RowCheck::Exact => {}
            RowCheck::Renormalised(sum) => self.notes.push(format!("start summed to {}; renormalised", fmt_num(sum))),
            RowCheck::Bad(sum) => {
                return Err(ParseError::at(
                    pos,
                    format!("start sums to {} (expected 1 within {:e})", fmt_num(sum), self.tolerance),
                ));
            }
        }
        self.start = Some(dist);
        Ok(())
    }

    /// The states listed after `start include:` / `start exclude:`.
    fn start_list(&mut self, ns: usize, include: bool, pos: Pos) -> Result<Vec<f64>> {
        let mut listed = vec![false; ns];
        let mut any = false;
        loop {
            let t = &self.peek().tok;
            let is_ref = matches!(t, Tok::Star | Tok::Name(_)) || t.int_literal().is_some();
            if !is_ref || self.at_statement() {
                break;
            }
            let (sel, _) = self.entity(Kind::State)?;
            for s in span(sel, ns) {
                if let Some(x) = listed.get_mut(s) {
                    *x = true;
                }
            }
            any = true;
        }
        let word = if include { "include" } else { "exclude" };
        if !any {
            return Err(self.unexpected(&format!("a state after 'start {word}:'")));
        }
        let chosen: Vec<bool> = listed.into_iter().map(|x| x == include).collect();
        let k = chosen.iter().filter(|&&x| x).count();
        if k == 0 {
            return Err(ParseError::at(pos, "'start exclude:' excludes every state"));
        }
        // Counts of states are far below 2^52: exact.
        #[allow(clippy::cast_precision_loss)]
        let p = 1.0 / k as f64;
        Ok(chosen.into_iter().map(|x| if x { p } else { 0.0 }).collect())
    }

    /// After `start:`: `uniform`, a state name, a single state index, or S
    /// probabilities.
    fn start_value(&mut self, ns: usize) -> Result<Vec<f64>> {
        let t = self.peek().clone();
        #[allow(clippy::cast_precision_loss)] // counts of states are far below 2^52
        let uniform = 1.0 / ns as f64;
        match t.tok {
            Tok::Name("uniform") => {
                self.bump();
                return Ok(vec![uniform; ns]);
            }
            Tok::Name(_) if !self.at_statement() => {
                let (sel, _) = self.entity(Kind::State)?;
                return Ok(one_hot(sel, ns));
            }
            _ => {}
        }
        let mut values = Vec::new();
        while let Some(num) = self.number()? {
            if num.value < 0.0 {
                return Err(ParseError::at(num.pos, format!("negative probability {num} in 'start:'")));
            }
            values.push(num);
        }
        // A single integer names the start state by index (with one state,
        // `start: 1` is also a valid probability vector).
        if let [num] = values.as_slice()
            && let Some(text) = num.int_text()
        {
            match text.parse::<usize>() {
                Ok(i) if i < ns => return Ok(one_hot(Some(i), ns)),
                Ok(1) if ns == 1 => return Ok(vec![1.0]),
                _ => {
                    return Err(ParseError::at(
                        num.pos,
                        format!(
                            "start state index {text} is out of range (there {} {ns} state{}: 0..{})",
                            if ns == 1 { "is" } else { "are" },
                            if ns == 1 { "" } else { "s" },
                            ns - 1
                        ),
                    ));
                }
            }
        }
        if values.len() == ns {
            return Ok(values.into_iter().map(|num| num.value).collect());
        }
        if values.is_empty() {
            return Err(self.unexpected(&format!("{ns} probabilities, 'uniform' or a state after 'start:'")));
        }
        if let Some(extra) = values.get(ns) {
            return Err(ParseError::at(
                extra.pos,
                format!(
                    "too many numbers after 'start:': expected {ns} probabilities, \
                     found another: number {extra}"
                ),
            ));
        }
        let t = self.peek();
        Err(match &t.tok {
            Tok::Bad(m) => ParseError::at(t.pos, m.clone()),
            other => ParseError::at(
                t.pos,
                format!(
                    "expected {ns} probabilities after 'start:' (or one state index), \
                     found {}, then {}",
                    values.len(),
                    other.describe()
                ),
            ),
        })
    }
}

fn one_hot(sel: Option<usize>, ns: usize) -> Vec<f64> {
    match sel {
        Some(i) => (0..ns).map(|s| if s == i { 1.0 } else { 0.0 }).collect(),
        // `start: *` is read as uniform.
        #[allow(clippy::cast_precision_loss)] // counts of states are far below 2^52
        None => vec![1.0 / ns as f64; ns],
    }
}

fn too_many(kind: Kind, found: &str, limit: usize) -> String {
    let table = match kind {
        Kind::State => "the transition table (S x S per action)",
        _ => "the tables",
    };
    format!(
        "'{}:' gives too many {}s ({found}): {table} would have more than {limit} entries",
        kind.keyword(),
        kind.noun()
    )
}
