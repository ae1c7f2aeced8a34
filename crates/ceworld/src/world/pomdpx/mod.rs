//! A reader of APPL's `.pomdpx` files (the factored XML format SARSOP reads), flattened into
//! the same [`Pomdp`] as a Cassandra `.pomdp` file.
//!
//! ```
//! use ceworld::world::{cassandra::Options, pomdpx};
//! let text = r#"<pomdpx version="1.0"><Discount>0.9</Discount>
//!   <Variable>
//!     <StateVar vnamePrev="x_0" vnameCurr="x_1"><NumValues>2</NumValues></StateVar>
//!     <ActionVar vname="act"><ValueEnum>stay</ValueEnum></ActionVar>
//!     <RewardVar vname="r"/>
//!   </Variable>
//!   <StateTransitionFunction><CondProb><Var>x_1</Var><Parent>act x_0</Parent>
//!     <Parameter><Entry><Instance>stay - -</Instance><ProbTable>identity</ProbTable></Entry></Parameter>
//!   </CondProb></StateTransitionFunction>
//!   <RewardFunction><Func><Var>r</Var><Parent>x_0</Parent>
//!     <Parameter><Entry><Instance>s1</Instance><ValueTable>1</ValueTable></Entry></Parameter>
//!   </Func></RewardFunction>
//! </pomdpx>"#;
//! let pomdp = pomdpx::parse(text, &Options::default()).unwrap();
//! assert_eq!(pomdp.states, ["s0", "s1"]);
//! assert_eq!(pomdp.expected_reward(), vec![0.0, 1.0]);
//! ```
//!
//! # What is read
//!
//! * `<Discount>` (`0..=1`; optional: none gives `γ = 1`, as a `.pomdp` file without one).
//! * `<Variable>`: `<StateVar vnamePrev vnameCurr fullyObs>`, `<ObsVar vname>`, `<ActionVar
//!   vname>`, each with `<ValueEnum>` (names) or `<NumValues>` (a count: the values are then
//!   `s0 s1 …`, `o0 …`, `a0 …`, as APPL names them), and `<RewardVar vname>`.
//! * The flat model: a state is a value of every state variable, row-major in declaration order
//!   (the first declared varies slowest), named by its values joined with `_`; actions likewise
//!   over the action variables. An observation is a value of every fully observed state variable
//!   (`fullyObs="true"`, its new value: the agent sees it, as in APPL's mixed observability) and
//!   of every observation variable, row-major in declaration order; where fully observed
//!   variables take part, the combinations that no `(a, s')` emits are left out. With neither
//!   kind of variable, there is one observation, `none`.
//! * `<InitialStateBelief>`, `<StateTransitionFunction>`, `<ObsFunction>`: one `<CondProb>` per
//!   state (resp. observation) variable, their product the flat start belief, `T(s'|s,a)` and
//!   `O(o|a,s')`; no `<InitialStateBelief>`: uniform. `<RewardFunction>`: its `<Func>`s summed.
//!   A `<CondProb>` of the transition may have parents among the actions, the previous state and
//!   the new state; of the observation, among the actions, the new state and the other
//!   observations; of the initial belief, `null` or other state variables; a `<Func>` any.
//! * `<Parameter type="TBL">` with `<Entry><Instance>` (a value of each parent then, in a
//!   `<CondProb>`, of the variable: a name, an index, `*` every value, `-` every value in turn,
//!   the table running over the `-`s row-major) and `<ProbTable>` / `<ValueTable>` (numbers;
//!   `identity` with one `-` parent and `-` last, of equal sizes; `uniform` with `-` last).
//!   Later entries override earlier ones; cells no entry writes are 0.
//!
//! # What is refused
//!
//! With the line of the element at fault: XML that is not well formed; elements other than
//! these (`<TerminalStateRewardFunction>`, a `<DAG>`); `type="DD"` (decision diagrams, which APPL
//! does not read either); names declared twice, unknown variables and values; an `<Instance>` or
//! table of the wrong length; negative or non-finite numbers; probability rows (of a
//! `<CondProb>`, and of the flat `T`, `O` and start) off 1 by more than [`Options::tolerance`]
//! (within it they are renormalised, noted in [`Pomdp::renormalised`]); an observation that
//! depends on the previous state (not an `O(o|a,s')`); and models whose dense tables, or a table
//! of one `<CondProb>` or of the summed reward, pass [`Options::max_entries`].
//!
//! Rewards become [`crate::world::cassandra::RewardEntry`]s over the parts of `(a, s, s', o)`
//! that the `<Func>`s depend on, the others `*`: one entry per combination of nonzero sum
//! (combinations of `s'` or `o` that cannot follow are left out).

mod factor;
mod flatten;
mod reward;
mod vars;

use std::cell::RefCell;
use std::fmt::Write as _;

use crate::world::cassandra::{Options, ParseError, Pomdp};

pub(crate) type Result<T> = std::result::Result<T, ParseError>;

/// The most XML nodes a document may have (about 1 GiB of tree); the published files have a
/// few hundred thousand.
const MAX_NODES: u32 = 1 << 24;

/// Whether `bytes` are an XML document rather than a Cassandra file: the first character after
/// a byte-order mark and whitespace is `<` (`<?xml`, `<pomdpx`, a comment). A `.pomdp` file
/// never starts so: its statements start with a letter, its comments with `#`.
pub fn looks_like_pomdpx(bytes: &[u8]) -> bool {
    let bytes = bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes);
    bytes.iter().find(|b| !b.is_ascii_whitespace()) == Some(&b'<')
}

/// Parses the text of a `.pomdpx` file.
///
/// # Errors
/// A [`ParseError`] with the line and column of the element at fault.
pub fn parse(text: &str, options: &Options) -> Result<Pomdp> {
    let lines = Lines::new(text);
    let opt = roxmltree::ParsingOptions { nodes_limit: MAX_NODES, ..roxmltree::ParsingOptions::default() };
    let doc = roxmltree::Document::parse_with_options(text, opt).map_err(|e| {
        let pos = e.pos();
        let message = e.to_string();
        let message = message.strip_suffix(&format!(" at {pos}")).unwrap_or(&message);
        ParseError {
            file: None,
            line: pos.row as usize,
            column: pos.col as usize,
            message: format!("not well-formed XML: {message}"),
        }
    })?;
    let ctx = Ctx { lines, options, notes: RefCell::new(Vec::new()) };
    flatten::read(&ctx, doc.root_element())
}

/// Parses a `.pomdpx` file given as bytes: UTF-8, or ISO-8859-1 where its XML declaration says
/// so (as APPL's examples do; their text is ASCII).
///
/// # Errors
/// A [`ParseError`] with the line and column of the first problem.
pub fn parse_bytes(bytes: &[u8], options: &Options) -> Result<Pomdp> {
    match std::str::from_utf8(bytes) {
        Ok(text) => parse(text, options),
        Err(_) if declares_latin1(bytes) => {
            let text: String = bytes.iter().map(|&b| char::from(b)).collect();
            parse(&text, options)
        }
        Err(e) => {
            let valid = std::str::from_utf8(&bytes[..e.valid_up_to()]).unwrap_or_default();
            let (line, column) = Lines::new(valid).at(valid.len());
            Err(ParseError {
                file: None,
                line,
                column,
                message: "bytes that are not UTF-8 (expected UTF-8, or ISO-8859-1 declared as the \
                          XML declaration's encoding)"
                    .to_string(),
            })
        }
    }
}

/// Whether the XML declaration names ISO-8859-1 (Latin-1), whose bytes are the first 256 code
/// points.
fn declares_latin1(bytes: &[u8]) -> bool {
    let head = &bytes[..bytes.len().min(200)];
    let Some(end) = head.windows(2).position(|w| w == b"?>") else { return false };
    let decl = String::from_utf8_lossy(&head[..end]).to_ascii_lowercase();
    decl.trim_start().starts_with("<?xml")
        && ["iso-8859-1", "iso8859-1", "latin1", "latin-1"].iter().any(|name| decl.contains(name))
}

/// What every part of the reader needs: positions, the options and the notes of rows
/// renormalised.
pub(crate) struct Ctx<'o> {
    lines: Lines,
    pub options: &'o Options,
    notes: RefCell<Vec<String>>,
}

impl Ctx<'_> {
    /// An error at `node`'s start.
    pub fn error(&self, node: roxmltree::Node, message: impl Into<String>) -> ParseError {
        self.error_at(node.range().start, message)
    }

    /// An error at the byte `offset` of the text.
    pub fn error_at(&self, offset: usize, message: impl Into<String>) -> ParseError {
        let (line, column) = self.lines.at(offset);
        ParseError { file: None, line, column, message: message.into() }
    }

    /// Notes a probability row that was renormalised.
    pub fn note(&self, note: String) {
        self.notes.borrow_mut().push(note);
    }

    /// The notes so far.
    pub fn take_notes(&self) -> Vec<String> {
        self.notes.take()
    }

    /// The line where `node` starts.
    pub fn line(&self, node: roxmltree::Node) -> usize {
        self.lines.at(node.range().start).0
    }
}

/// Byte offsets to lines and columns (1-based), found by bisection.
struct Lines {
    starts: Vec<usize>,
}

impl Lines {
    fn new(text: &str) -> Self {
        Lines { starts: std::iter::once(0).chain(text.match_indices('\n').map(|(i, _)| i + 1)).collect() }
    }

    fn at(&self, offset: usize) -> (usize, usize) {
        let line = self.starts.partition_point(|&s| s <= offset).max(1);
        (line, offset - self.starts.get(line - 1).copied().unwrap_or(0) + 1)
    }
}

/// The element children of `node`.
pub(crate) fn elements<'a, 'i>(node: roxmltree::Node<'a, 'i>) -> impl Iterator<Item = roxmltree::Node<'a, 'i>> {
    node.children().filter(roxmltree::Node::is_element)
}

/// The text of `node` (its text children, comments left out), refusing child elements.
pub(crate) fn text_of(ctx: &Ctx, node: roxmltree::Node) -> Result<String> {
    if let Some(child) = elements(node).next() {
        return Err(ctx.error(
            child,
            format!("<{}> inside <{}> (expected text only)", child.tag_name().name(), node.tag_name().name()),
        ));
    }
    Ok(node.children().filter_map(|n| n.text()).collect::<Vec<_>>().join(" "))
}

/// The one child element `name` of `node`.
pub(crate) fn only_child<'a, 'i>(
    ctx: &Ctx,
    node: roxmltree::Node<'a, 'i>,
    name: &str,
) -> Result<roxmltree::Node<'a, 'i>> {
    let mut found = elements(node).filter(|c| c.tag_name().name() == name);
    let first = found.next().ok_or_else(|| {
        ctx.error(node, format!("<{}> has no <{name}> (expected exactly one)", node.tag_name().name()))
    })?;
    if let Some(second) = found.next() {
        return Err(ctx.error(second, format!("a second <{name}> in <{}> (expected one)", node.tag_name().name())));
    }
    Ok(first)
}

/// Row-major strides of dimensions of `sizes` (the first varies slowest).
pub(crate) fn strides(sizes: &[usize]) -> Vec<usize> {
    let mut strides = vec![1; sizes.len()];
    for d in (0..sizes.len().saturating_sub(1)).rev() {
        strides[d] = strides[d + 1] * sizes[d + 1];
    }
    strides
}

/// A list written with "first, second, ... (N in all)" past eight items.
pub(crate) fn shown(items: &[String]) -> String {
    const SHOWN: usize = 8;
    let mut list = items.iter().take(SHOWN).cloned().collect::<Vec<_>>().join(", ");
    if items.len() > SHOWN {
        let _ = write!(list, ", ... ({} in all)", items.len());
    }
    list
}
