//! The parser: statements, the preamble and the start belief. The `T:`,
//! `O:` and `R:` entries are in `entries.rs`.

use std::collections::HashMap;
use std::fmt::Write as _;
use std::path::Path;

use crate::world::cassandra::error::ParseError;
use crate::world::cassandra::lexer::{Pos, Tok, Token, tokenize};
use crate::world::cassandra::model::{Options, Pomdp, RewardEntry, Values};
use crate::world::cassandra::validate::Dense;

/// The words that start statements; they cannot be used as names.
const STATEMENT_KEYWORDS: &[&str] =
    &["discount", "values", "states", "actions", "observations", "start", "T", "O", "R"];

pub(crate) type Result<T> = std::result::Result<T, ParseError>;

/// Parses the text of a `.pomdp` file.
///
/// # Errors
/// A [`ParseError`] with the line and column of the first problem.
pub fn parse(text: &str, options: &Options) -> Result<Pomdp> {
    parse_bytes(text.as_bytes(), options)
}

/// Parses a `.pomdp` file given as bytes. Bytes that are not ASCII are
/// accepted inside comments only, so invalid UTF-8 there is harmless.
///
/// # Errors
/// A [`ParseError`] with the line and column of the first problem.
pub fn parse_bytes(bytes: &[u8], options: &Options) -> Result<Pomdp> {
    Parser::new(tokenize(bytes), options).run()
}

/// Largest `.pomdp` file read (bytes); the read stops there.
pub const MAX_FILE_BYTES: u64 = 256 << 20;

/// Reads and parses a `.pomdp` file; errors carry the file name.
///
/// # Errors
/// A [`ParseError`] if the file cannot be read (line and column 0) or parsed.
pub fn parse_file(path: &Path, options: &Options) -> Result<Pomdp> {
    let file = Some(path.display().to_string());
    let bytes = crate::files::read_limited(path, MAX_FILE_BYTES, "pomdp file").map_err(|e| ParseError {
        file: file.clone(),
        line: 0,
        column: 0,
        message: format!("cannot read the file: {e}"),
    })?;
    parse_bytes(&bytes, options).map_err(|e| ParseError { file, ..e })
}

/// A number read from the text, with its sign if that was a separate token.
#[derive(Clone, Copy)]
pub(crate) struct Num<'a> {
    pub value: f64,
    pub pos: Pos,
    /// The number token as written.
    pub text: &'a str,
    /// A separate sign token before it: `Some(true)` for `-`.
    pub sign: Option<bool>,
}

impl Num<'_> {
    /// The digits, if written as a plain non-negative integer.
    pub fn int_text(&self) -> Option<&str> {
        (self.sign.is_none() && self.text.bytes().all(|b| b.is_ascii_digit())).then_some(self.text)
    }
}

impl std::fmt::Display for Num<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if self.sign == Some(true) {
            write!(f, "-")?;
        }
        write!(f, "{}", self.text)
    }
}

/// States, actions or observations.
#[derive(Clone, Copy, PartialEq, Eq)]
pub(crate) enum Kind {
    State,
    Action,
    Observation,
}

impl Kind {
    pub fn noun(self) -> &'static str {
        match self {
            Kind::State => "state",
            Kind::Action => "action",
            Kind::Observation => "observation",
        }
    }
    pub fn keyword(self) -> &'static str {
        match self {
            Kind::State => "states",
            Kind::Action => "actions",
            Kind::Observation => "observations",
        }
    }
}

/// A declared set of states, actions or observations.
pub(crate) struct Entities {
    pub count: usize,
    /// `None` when declared by a count.
    pub names: Option<Vec<String>>,
    pub lookup: HashMap<String, usize>,
}

/// The preamble lines, for duplicate detection.
#[derive(Clone, Copy)]
pub(crate) enum Item {
    Discount = 0,
    Values,
    States,
    Actions,
    Observations,
    Start,
}

pub(crate) struct Parser<'a> {
    toks: Vec<Token<'a>>,
    i: usize,
    pub tolerance: f64,
    pub max_entries: usize,
    pub discount: Option<f64>,
    pub values: Option<Values>,
    pub states: Option<Entities>,
    pub actions: Option<Entities>,
    pub observations: Option<Entities>,
    pub start: Option<Vec<f64>>,
    pub seen: [Option<Pos>; 6],
    /// Where the first `T:`/`O:`/`R:` entry is, once there is one.
    pub first_entry: Option<Pos>,
    pub t: Option<Dense>,
    pub o: Option<Dense>,
    pub rewards: Vec<RewardEntry>,
    pub notes: Vec<String>,
}

impl<'a> Parser<'a> {
    fn new(toks: Vec<Token<'a>>, options: &Options) -> Self {
        Parser {
            toks,
            i: 0,
            tolerance: options.tolerance,
            max_entries: options.max_entries,
            discount: None,
            values: None,
            states: None,
            actions: None,
            observations: None,
            start: None,
            seen: [None; 6],
            first_entry: None,
            t: None,
            o: None,
            rewards: Vec::new(),
            notes: Vec::new(),
        }
    }

    // ----- token access -------------------------------------------------

    /// The token `k` places ahead (the final `Eof`/`Bad` repeats forever).
    pub fn peek_at(&self, k: usize) -> &Token<'a> {
        static EOF: Token<'static> = Token { tok: Tok::Eof, pos: Pos { line: 1, col: 1 } };
        let last = self.toks.len().saturating_sub(1);
        self.toks.get(self.i.saturating_add(k).min(last)).unwrap_or(&EOF)
    }

    pub fn peek(&self) -> &Token<'a> {
        self.peek_at(0)
    }

    pub fn bump(&mut self) -> Token<'a> {
        let t = self.peek().clone();
        if self.i + 1 < self.toks.len() {
            self.i += 1;
        }
        t
    }

    /// "expected X, found Y" at the next token (a lexical error wins).
    pub fn unexpected(&self, expected: &str) -> ParseError {
        let t = self.peek();
        match &t.tok {
            Tok::Bad(m) => ParseError::at(t.pos, m.clone()),
            other => ParseError::at(t.pos, format!("expected {expected}, found {}", other.describe())),
        }
    }

    pub fn expect_colon(&mut self, after: &str) -> Result<()> {
        if self.peek().tok == Tok::Colon {
            self.bump();
            Ok(())
        } else {
            Err(self.unexpected(&format!("':' after '{after}'")))
        }
    }

    /// Whether the next token starts a new statement, which ends any list
    /// of names before it: a statement keyword (reserved, as in
    /// pomdp-solve, so `states: a T` is refused rather than read as a state
    /// named `T`), or any name followed by `:`.
    pub fn at_statement(&self) -> bool {
        match self.peek().tok {
            Tok::Name(n) => STATEMENT_KEYWORDS.contains(&n) || self.peek_at(1).tok == Tok::Colon,
            _ => false,
        }
    }

    /// A number, with an optional separate sign token before it; `None`
    /// (consuming nothing) when the next token is neither.
    pub fn number(&mut self) -> Result<Option<Num<'a>>> {
        let t = self.peek().clone();
        match t.tok {
            Tok::Number { value, text } => {
                self.bump();
                Ok(Some(Num { value, pos: t.pos, text, sign: None }))
            }
            Tok::Sign(neg) => {
                self.bump();
                match self.peek().tok {
                    Tok::Number { value, text } if !text.starts_with(['+', '-']) => {
                        self.bump();
                        Ok(Some(Num { value: if neg { -value } else { value }, pos: t.pos, text, sign: Some(neg) }))
                    }
                    _ => Err(self.unexpected(&format!("a number after '{}'", if neg { '-' } else { '+' }))),
                }
            }
            _ => Ok(None),
        }
    }

    // ----- names ---------------------------------------------------------

    pub fn entities(&self, kind: Kind) -> Option<&Entities> {
        match kind {
            Kind::State => self.states.as_ref(),
            Kind::Action => self.actions.as_ref(),
            Kind::Observation => self.observations.as_ref(),
        }
    }

    /// A state/action/observation reference: a name, an index or `*`
    /// (`None`). Also returns the text as written, for messages.
    pub fn entity(&mut self, kind: Kind) -> Result<(Option<usize>, &'a str)> {
        let noun = kind.noun();
        let t = self.peek().clone();
        let Some(ents) = self.entities(kind) else {
            return Err(ParseError::at(t.pos, format!("no {}: line before this", kind.keyword())));
        };
        let n = ents.count;
        let found = match &t.tok {
            Tok::Star => Ok((None, "*")),
            Tok::Number { text, .. } if t.tok.int_literal().is_some() => {
                match t.tok.int_literal().and_then(|i| usize::try_from(i).ok()) {
                    Some(i) if i < n => Ok((Some(i), *text)),
                    _ => Err(format!(
                        "{noun} index {text} is out of range (there {} {n} {noun}{}: 0..{})",
                        if n == 1 { "is" } else { "are" },
                        if n == 1 { "" } else { "s" },
                        n - 1
                    )),
                }
            }
            Tok::Name(name) => match ents.lookup.get(*name) {
                Some(&i) => Ok((Some(i), *name)),
                None => Err(unknown_name(kind, name, ents)),
            },
            _ => return Err(self.unexpected(&format!("{noun} (a name, an index or '*')"))),
        };
        match found {
            Ok(v) => {
                self.bump();
                Ok(v)
            }
            Err(m) => Err(ParseError::at(t.pos, m)),
        }
    }

    // ----- statements ----------------------------------------------------

    fn run(mut self) -> Result<Pomdp> {
        loop {
            let t = self.peek().clone();
            match t.tok {
                Tok::Eof => break,
                Tok::Name("discount") => self.preamble(Item::Discount, "discount")?,
                Tok::Name("values") => self.preamble(Item::Values, "values")?,
                Tok::Name("states") => self.preamble(Item::States, "states")?,
                Tok::Name("actions") => self.preamble(Item::Actions, "actions")?,
                Tok::Name("observations") => self.preamble(Item::Observations, "observations")?,
                Tok::Name("start") => self.start_line()?,
                Tok::Name("T") => self.transition_entry()?,
                Tok::Name("O") => self.observation_entry()?,
                Tok::Name("R") => self.reward_entry()?,
                _ => {
                    return Err(self.unexpected(
                        "a preamble line (discount:, values:, states:, actions:, observations:, \
                         start:) or an entry (T:, O:, R:)",
                    ));
                }
            }
        }
        let eof = self.peek().pos;
        self.finish(eof)
    }

    // ----- the end -------------------------------------------------------

    /// Checks that states, actions and observations are declared (before
    /// the entry at `pos`, or at the end of the file) and makes the tables.
    pub fn ensure_tables(&mut self, pos: Pos, what: &str) -> Result<()> {
        if self.t.is_some() && self.o.is_some() {
            return Ok(());
        }
        for kind in [Kind::State, Kind::Action, Kind::Observation] {
            if self.entities(kind).is_none() {
                return Err(ParseError::at(
                    pos,
                    format!("missing '{}:' line (expected in the preamble, before {what})", kind.keyword()),
                ));
            }
        }
        let count = |k: Kind| self.entities(k).map_or(0, |e| e.count);
        let (ns, na, no) = (count(Kind::State), count(Kind::Action), count(Kind::Observation));
        let t_size = na.checked_mul(ns).and_then(|x| x.checked_mul(ns));
        let o_size = na.checked_mul(ns).and_then(|x| x.checked_mul(no));
        for (size, table) in [(t_size, "transition table T (A x S x S)"), (o_size, "observation table O (A x S x O)")] {
            if size.is_none_or(|x| x > self.max_entries) {
                return Err(ParseError::at(
                    pos,
                    format!(
                        "the model is too large: with {ns} states, {na} actions and {no} \
                         observations the {table} would have more than {} entries",
                        self.max_entries
                    ),
                ));
            }
        }
        // Both dense tables and their rows' positions, against the memory this process may use.
        let entries = t_size.unwrap_or(usize::MAX).saturating_add(o_size.unwrap_or(usize::MAX));
        let rows = na.saturating_mul(ns).saturating_mul(2);
        let bytes = (entries as u64)
            .saturating_mul(8)
            .saturating_add((rows as u64).saturating_mul(size_of::<Option<Pos>>() as u64));
        let what = format!("the tables T and O of a model with {ns} states, {na} actions and {no} observations");
        crate::memory::check_memory(&what, bytes, crate::memory::available_memory())
            .map_err(|e| ParseError::at(pos, e.to_string()))?;
        self.t = Some(Dense::new(na, ns, ns));
        self.o = Some(Dense::new(na, ns, no));
        Ok(())
    }

    fn finish(mut self, eof: Pos) -> Result<Pomdp> {
        self.ensure_tables(eof, "the end of the file")?;
        let (Some(mut t), Some(mut o)) = (self.t.take(), self.o.take()) else {
            return Err(ParseError::at(eof, "internal error: tables missing"));
        };
        let names = |e: Option<Entities>| match e {
            Some(Entities { names: Some(n), .. }) => n,
            Some(Entities { count, .. }) => (0..count).map(|i| i.to_string()).collect(),
            None => Vec::new(),
        };
        let states = names(self.states.take());
        let actions = names(self.actions.take());
        let observations = names(self.observations.take());
        let name = |v: &[String], i: usize| v.get(i).cloned().unwrap_or_default();
        let mut worst = None;
        let tl = |a: usize, s: usize| format!("T: a={} s={}", name(&actions, a), name(&states, s));
        t.check(self.tolerance, eof, &tl, &mut self.notes, &mut worst);
        let ol = |a: usize, s: usize| format!("O: a={} s'={}", name(&actions, a), name(&states, s));
        o.check(self.tolerance, eof, &ol, &mut self.notes, &mut worst);
        if let Some((pos, msg)) = worst {
            return Err(ParseError::at(pos, msg));
        }
        Ok(Pomdp {
            discount: self.discount,
            values: self.values.unwrap_or_default(),
            states,
            actions,
            observations,
            start: self.start,
            transition: t.data,
            observation: o.data,
            rewards: self.rewards,
            renormalised: self.notes,
        })
    }
}

/// "unknown state 'foo' (expected one of: a, b, ... (N in all), an index or '*')".
fn unknown_name(kind: Kind, name: &str, ents: &Entities) -> String {
    let noun = kind.noun();
    match &ents.names {
        None => format!(
            "unknown {noun} '{name}' ({}s are declared by count: expected an index 0..{} or '*')",
            noun,
            ents.count.saturating_sub(1)
        ),
        Some(names) => {
            const SHOWN: usize = 8;
            let mut list = names.iter().take(SHOWN).cloned().collect::<Vec<_>>().join(", ");
            if names.len() > SHOWN {
                let _ = write!(list, ", ... ({} in all)", names.len());
            }
            format!("unknown {noun} '{name}' (expected one of: {list}; an index; or '*')")
        }
    }
}
