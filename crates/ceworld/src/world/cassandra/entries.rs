//! `T:`, `O:` and `R:` entries.

use crate::world::cassandra::error::ParseError;
use crate::world::cassandra::lexer::{Pos, Tok};
use crate::world::cassandra::model::RewardEntry;
use crate::world::cassandra::parse::{Kind, Parser, Result};

impl<'a> Parser<'a> {
    fn count(&self, kind: Kind) -> usize {
        self.entities(kind).map_or(0, |e| e.count)
    }

    /// Consumes `T`/`O`/`R` and the colon; makes the tables on first use.
    fn begin_entry(&mut self, kw: &str) -> Result<()> {
        let pos = self.bump().pos;
        if self.first_entry.is_none() {
            self.first_entry = Some(pos);
        }
        self.ensure_tables(pos, &format!("this first {kw}: entry"))?;
        self.expect_colon(kw)
    }

    /// Consumes the next token if it is one of the `allowed` keywords.
    fn keyword(&mut self, allowed: &[&str]) -> Option<(&'a str, Pos)> {
        match self.peek().tok {
            Tok::Name(n) if allowed.contains(&n) => {
                let pos = self.bump().pos;
                Some((n, pos))
            }
            _ => None,
        }
    }

    /// Reads exactly `n` numbers (rows of `row_len`) after `ctx`; returns
    /// them and where each row starts. `alts` lists keywords that were also
    /// possible here, for the message. Probabilities may not be negative.
    fn values(
        &mut self,
        n: usize,
        row_len: usize,
        ctx: &[&str],
        alts: &str,
        prob: bool,
    ) -> Result<(Vec<f64>, Vec<Pos>)> {
        let plural = |k: usize| match (prob, k == 1) {
            (true, true) => format!("{k} probability"),
            (true, false) => format!("{k} probabilities"),
            (false, true) => format!("{k} number"),
            (false, false) => format!("{k} numbers"),
        };
        let shape =
            if n > row_len && row_len > 0 { format!(" (a {}x{row_len} matrix)", n / row_len) } else { String::new() };
        let mut vals = Vec::new();
        let mut rows = Vec::new();
        for k in 0..n {
            let Some(num) = self.number()? else {
                let t = self.peek();
                let found = match &t.tok {
                    Tok::Bad(m) => return Err(ParseError::at(t.pos, m.clone())),
                    other => other.describe(),
                };
                let msg = if k == 0 {
                    format!("expected {}{shape}{alts} after '{}', found {found}", plural(n), show(ctx))
                } else {
                    format!("expected {}{shape} after '{}', found {k}, then {found}", plural(n), show(ctx))
                };
                return Err(ParseError::at(t.pos, msg));
            };
            let (v, pos) = (num.value, num.pos);
            if prob && v < 0.0 {
                return Err(ParseError::at(pos, format!("negative probability {num} after '{}'", show(ctx))));
            }
            if row_len > 0 && k % row_len == 0 {
                rows.push(pos);
            }
            vals.push(v);
        }
        let t = self.peek();
        if matches!(t.tok, Tok::Number { .. } | Tok::Sign(_)) {
            return Err(ParseError::at(
                t.pos,
                format!(
                    "too many numbers after '{}': expected {}{shape}, found another: {}",
                    show(ctx),
                    plural(n),
                    t.tok.describe()
                ),
            ));
        }
        Ok((vals, rows))
    }

    /// One number after `ctx`.
    fn single(&mut self, ctx: &[&str], prob: bool) -> Result<(f64, Pos)> {
        let (v, rows) = self.values(1, 1, ctx, "", prob)?;
        Ok((v.first().copied().unwrap_or(0.0), rows.first().copied().unwrap_or(Pos { line: 0, col: 0 })))
    }

    /// `T: a : s : s' p` | `T: a : s` row/`uniform`/`reset` |
    /// `T: a` matrix/`uniform`/`identity`.
    pub(crate) fn transition_entry(&mut self) -> Result<()> {
        self.begin_entry("T")?;
        let ns = self.count(Kind::State);
        #[allow(clippy::cast_precision_loss)] // counts are far below 2^52
        let uniform = vec![1.0 / ns as f64; ns];
        let (a, at) = self.entity(Kind::Action)?;
        if self.peek().tok != Tok::Colon {
            let ctx = ["T", at];
            match self.keyword(&["uniform", "identity"]) {
                Some(("identity", pos)) => self.t_mut().set_identity(a, pos),
                Some((_, pos)) => self.t_mut().set_all_rows(a, &uniform, pos),
                None => {
                    let (m, rows) = self.values(ns * ns, ns, &ctx, ", 'uniform' or 'identity'", true)?;
                    self.t_mut().set_matrix(a, &m, &rows);
                }
            }
            return Ok(());
        }
        self.bump();
        let (s, st) = self.entity(Kind::State)?;
        if self.peek().tok == Tok::Colon {
            self.bump();
            let (s2, s2t) = self.entity(Kind::State)?;
            let (v, pos) = self.single(&["T", at, st, s2t], true)?;
            self.t_mut().set(a, s, s2, v, pos);
            return Ok(());
        }
        let ctx = ["T", at, st];
        match self.keyword(&["uniform", "reset"]) {
            Some(("reset", pos)) => {
                let row = self.start.clone().unwrap_or(uniform);
                self.t_mut().set_row(a, s, &row, pos);
            }
            Some((_, pos)) => self.t_mut().set_row(a, s, &uniform, pos),
            None => {
                let (row, rows) = self.values(ns, ns, &ctx, ", 'uniform' or 'reset'", true)?;
                let pos = rows.first().copied().unwrap_or(self.peek().pos);
                self.t_mut().set_row(a, s, &row, pos);
            }
        }
        Ok(())
    }

    /// `O: a : s' : o p` | `O: a : s'` row/`uniform` | `O: a` matrix/`uniform`.
    pub(crate) fn observation_entry(&mut self) -> Result<()> {
        self.begin_entry("O")?;
        let ns = self.count(Kind::State);
        let no = self.count(Kind::Observation);
        #[allow(clippy::cast_precision_loss)] // counts are far below 2^52
        let uniform = vec![1.0 / no as f64; no];
        let (a, at) = self.entity(Kind::Action)?;
        if self.peek().tok != Tok::Colon {
            let ctx = ["O", at];
            if let Some((_, pos)) = self.keyword(&["uniform"]) {
                self.o_mut().set_all_rows(a, &uniform, pos);
            } else {
                let (m, rows) = self.values(ns * no, no, &ctx, " or 'uniform'", true)?;
                self.o_mut().set_matrix(a, &m, &rows);
            }
            return Ok(());
        }
        self.bump();
        let (s2, st) = self.entity(Kind::State)?;
        if self.peek().tok == Tok::Colon {
            self.bump();
            let (o, ot) = self.entity(Kind::Observation)?;
            let (v, pos) = self.single(&["O", at, st, ot], true)?;
            self.o_mut().set(a, s2, o, v, pos);
            return Ok(());
        }
        let ctx = ["O", at, st];
        if let Some((_, pos)) = self.keyword(&["uniform"]) {
            self.o_mut().set_row(a, s2, &uniform, pos);
        } else {
            let (row, rows) = self.values(no, no, &ctx, " or 'uniform'", true)?;
            let pos = rows.first().copied().unwrap_or(self.peek().pos);
            self.o_mut().set_row(a, s2, &row, pos);
        }
        Ok(())
    }

    /// `R: a : s : s' : o v` | `R: a : s : s'` row over `o` |
    /// `R: a : s` matrix over `(s', o)`.
    pub(crate) fn reward_entry(&mut self) -> Result<()> {
        self.begin_entry("R")?;
        let ns = self.count(Kind::State);
        let no = self.count(Kind::Observation);
        let (a, at) = self.entity(Kind::Action)?;
        if self.peek().tok != Tok::Colon {
            return Err(self.unexpected(&format!("':' after 'R: {at}'")));
        }
        self.bump();
        let (s, st) = self.entity(Kind::State)?;
        let entry =
            |next_state, observation, value| RewardEntry { action: a, state: s, next_state, observation, value };
        if self.peek().tok != Tok::Colon {
            let (m, _) = self.values(ns * no, no, &["R", at, st], "", false)?;
            for (k, &v) in m.iter().enumerate() {
                let (s2, o) = (k / no.max(1), k % no.max(1));
                self.rewards.push(entry(Some(s2), Some(o), v));
            }
            return Ok(());
        }
        self.bump();
        let (s2, s2t) = self.entity(Kind::State)?;
        if self.peek().tok != Tok::Colon {
            let ctx = ["R", at, st, s2t];
            let (row, _) = self.values(no, no, &ctx, "", false)?;
            for (o, &v) in row.iter().enumerate() {
                self.rewards.push(entry(s2, Some(o), v));
            }
            return Ok(());
        }
        self.bump();
        let (o, ot) = self.entity(Kind::Observation)?;
        let (v, _) = self.single(&["R", at, st, s2t, ot], false)?;
        self.rewards.push(entry(s2, o, v));
        Ok(())
    }

    fn t_mut(&mut self) -> &mut crate::world::cassandra::validate::Dense {
        self.t.get_or_insert_with(|| crate::world::cassandra::validate::Dense::new(0, 0, 0))
    }

    fn o_mut(&mut self) -> &mut crate::world::cassandra::validate::Dense {
        self.o.get_or_insert_with(|| crate::world::cassandra::validate::Dense::new(0, 0, 0))
    }
}

/// Shows an entry's head, e.g. `["T", "a", "s"]` as `T: a : s`.
fn show(parts: &[&str]) -> String {
    match parts.split_first() {
        Some((kw, rest)) => format!("{kw}: {}", rest.join(" : ")),
        None => String::new(),
    }
}
