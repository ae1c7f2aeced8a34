//! One `<CondProb>` or `<Func>`: a dense table over its parents' values (and its variable's).

use roxmltree::Node;

use super::vars::{Ref, Variables};
use super::{Ctx, Result, elements, only_child, shown, strides, text_of};
use crate::world::cassandra::validate::{RowCheck, fmt_num, normalise};

/// Which part of the file a table belongs to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Section {
    Belief,
    Transition,
    Observation,
    Reward,
}

impl Section {
    /// The element that holds the section's tables.
    pub fn container(self) -> &'static str {
        match self {
            Section::Belief => "InitialStateBelief",
            Section::Transition => "StateTransitionFunction",
            Section::Observation => "ObsFunction",
            Section::Reward => "RewardFunction",
        }
    }

    /// The element of one table.
    pub fn element(self) -> &'static str {
        if self == Section::Reward { "Func" } else { "CondProb" }
    }

    fn numbers(self) -> &'static str {
        if self == Section::Reward { "ValueTable" } else { "ProbTable" }
    }
}

/// What one `<Instance>` token picks of its dimension.
#[derive(Clone, Copy)]
enum Pick {
    /// `*`: every value, the same number for each.
    Every,
    /// `-`: every value in turn, the table running over it.
    Each,
    One(usize),
}

/// What a `<ProbTable>` or `<ValueTable>` gives.
enum Numbers {
    List(Vec<f64>),
    /// 1 where the one `-` parent (this dimension) equals the variable.
    Identity(usize),
    Uniform,
}

/// A dense table over the parents' values and, of a `<CondProb>`, its variable's (the last
/// dimension), row-major.
pub(crate) struct Factor {
    /// The variable the table is of: what it gives the law of, or a reward variable. In the
    /// initial belief, state variables are all `Ref::Prev`.
    pub var: Ref,
    /// Each parent, then (of a `<CondProb>`) the variable.
    pub dims: Vec<Ref>,
    pub sizes: Vec<usize>,
    pub table: Vec<f64>,
    /// Of a `<CondProb>`, one per row (a value of every parent): 1 + the offset of the last
    /// `<Entry>` that wrote it, 0 where none did.
    written: Vec<u32>,
    section: Section,
    /// The line of the element, for messages.
    pub line: usize,
}

impl Factor {
    /// Reads a `<CondProb>` (or, in the reward section, a `<Func>`).
    pub fn read(ctx: &Ctx, vars: &Variables, section: Section, node: Node) -> Result<Factor> {
        let element = section.element();
        if let Some(other) = elements(node).find(|c| !matches!(c.tag_name().name(), "Var" | "Parent" | "Parameter")) {
            return Err(ctx.error(
                other,
                format!(
                    "unknown element <{}> in <{element}> (expected <Var>, <Parent>, <Parameter>)",
                    other.tag_name().name()
                ),
            ));
        }
        let var_node = only_child(ctx, node, "Var")?;
        let var_text = text_of(ctx, var_node)?;
        let var = match var_text.split_whitespace().collect::<Vec<_>>()[..] {
            [name] => role(ctx, vars, section, var_node, name, None)?,
            _ => return Err(ctx.error(var_node, format!("<Var>{var_text}</Var> (expected one variable name)"))),
        };
        let parent_node = only_child(ctx, node, "Parent")?;
        let parent_text = text_of(ctx, parent_node)?;
        let mut dims = Vec::new();
        let tokens: Vec<&str> = parent_text.split_whitespace().collect();
        if tokens != ["null"] || section != Section::Belief {
            for name in tokens {
                let r = role(ctx, vars, section, parent_node, name, Some(var))?;
                if dims.contains(&r) || r == var {
                    return Err(ctx.error(parent_node, format!("parent {name} listed twice, or the variable itself")));
                }
                dims.push(r);
            }
        }
        if section != Section::Reward {
            dims.push(var);
        }
        let sizes: Vec<usize> = dims.iter().map(|&r| vars.var(r).map_or(1, super::vars::Var::len)).collect();
        let limit = ctx.options.max_entries;
        let total = sizes.iter().try_fold(1usize, |acc, &n| acc.checked_mul(n)).filter(|&t| t <= limit);
        let Some(total) = total else {
            return Err(ctx.error(
                node,
                format!(
                    "the table of the <{element}> of {} would have more than {limit} entries ({} values of its \
                     variables)",
                    vars.name(var),
                    sizes.iter().map(ToString::to_string).collect::<Vec<_>>().join(" x ")
                ),
            ));
        };
        let rows = if section == Section::Reward { 0 } else { total / sizes.last().copied().unwrap_or(1).max(1) };
        let what = format!("the table of a <{element}> with {total} entries");
        crate::memory::check_memory(&what, total as u64 * 12, crate::memory::available_memory())
            .map_err(|e| ctx.error(node, e.to_string()))?;
        let mut factor =
            Factor { var, dims, sizes, table: vec![0.0; total], written: vec![0; rows], section, line: ctx.line(node) };
        let parameter = only_child(ctx, node, "Parameter")?;
        match parameter.attribute("type").map(str::trim) {
            None | Some("TBL") => {}
            Some("DD") => {
                return Err(ctx.error(
                    parameter,
                    "<Parameter type=\"DD\">: decision diagrams are not supported (expected type=\"TBL\", a table \
                     of <Entry>s; APPL does not read DD either)",
                ));
            }
            Some(other) => {
                return Err(ctx.error(parameter, format!("<Parameter type=\"{other}\"> (expected type=\"TBL\")")));
            }
        }
        for entry in elements(parameter) {
            if entry.tag_name().name() != "Entry" {
                return Err(ctx.error(
                    entry,
                    format!(
                        "<{}> in <Parameter> (expected <Entry>s: decision diagrams are not supported)",
                        entry.tag_name().name()
                    ),
                ));
            }
            factor.entry(ctx, vars, entry)?;
        }
        factor.check_rows(ctx, vars)?;
        Ok(factor)
    }

    /// "the `<CondProb>` of `state_1` (line 40)".
    pub fn label(&self, vars: &Variables) -> String {
        format!("the <{}> of {} (line {})", self.section.element(), vars.name(self.var), self.line)
    }

    /// Row-major strides of the dimensions.
    pub fn strides(&self) -> Vec<usize> {
        strides(&self.sizes)
    }

    /// Whether the row `row` (a value of every parent) was written by some `<Entry>`.
    pub fn row_written(&self, row: usize) -> bool {
        self.written.get(row).is_some_and(|&w| w > 0)
    }

    /// " at a=x, b=y": the parents' values of row `row` ("" without parents).
    pub fn row_name(&self, vars: &Variables, row: usize) -> String {
        let parents = self.dims.len() - usize::from(self.section != Section::Reward);
        let mut rest = row;
        let mut parts = Vec::with_capacity(parents);
        for d in (0..parents).rev() {
            let n = self.sizes[d].max(1);
            let value = vars.var(self.dims[d]).and_then(|v| v.values.get(rest % n)).map_or("?", String::as_str);
            parts.push(format!("{}={value}", vars.name(self.dims[d])));
            rest /= n;
        }
        parts.reverse();
        if parts.is_empty() { String::new() } else { format!(" at {}", parts.join(", ")) }
    }

    fn entry(&mut self, ctx: &Ctx, vars: &Variables, entry: Node) -> Result<()> {
        let table_name = self.section.numbers();
        if let Some(other) =
            elements(entry).find(|c| !matches!(c.tag_name().name(), "Instance" | "ProbTable" | "ValueTable"))
        {
            return Err(ctx.error(
                other,
                format!(
                    "unknown element <{}> in <Entry> (expected <Instance>, <{table_name}>)",
                    other.tag_name().name()
                ),
            ));
        }
        let instance = only_child(ctx, entry, "Instance")?;
        let numbers_node = only_child(ctx, entry, table_name)?;
        let text = text_of(ctx, instance)?;
        let tokens: Vec<&str> = text.split_whitespace().collect();
        if tokens.len() != self.dims.len() {
            let names: Vec<String> = self.dims.iter().map(|&r| vars.name(r).to_string()).collect();
            return Err(ctx.error(
                instance,
                format!(
                    "<Instance>{text}</Instance> has {} values (expected {}: one of each of {})",
                    tokens.len(),
                    self.dims.len(),
                    if names.is_empty() { "none".to_string() } else { names.join(", ") }
                ),
            ));
        }
        let mut picks = Vec::with_capacity(tokens.len());
        for (&token, &r) in tokens.iter().zip(&self.dims) {
            picks.push(match token {
                "*" => Pick::Every,
                "-" => Pick::Each,
                _ => {
                    let var = vars.var(r).ok_or_else(|| ctx.error(instance, "a reward variable has no values"))?;
                    Pick::One(var.value(token).ok_or_else(|| ctx.error(instance, var.unknown(token)))?)
                }
            });
        }
        let numbers = self.numbers(ctx, &picks, numbers_node)?;
        self.fill(&picks, &numbers, entry.range().start);
        Ok(())
    }

    /// Reads the numbers of an entry whose `<Instance>` is `picks`.
    fn numbers(&self, ctx: &Ctx, picks: &[Pick], node: Node) -> Result<Numbers> {
        let name = self.section.numbers();
        let text = text_of(ctx, node)?;
        let tokens: Vec<&str> = text.split_whitespace().collect();
        let last_each = matches!(picks.last(), Some(Pick::Each)) && self.section != Section::Reward;
        match &tokens[..] {
            [word] if word.eq_ignore_ascii_case("uniform") && self.section != Section::Reward => {
                return if last_each {
                    Ok(Numbers::Uniform)
                } else {
                    Err(ctx.error(node, "'uniform' needs '-' for the variable (the last value of <Instance>)"))
                };
            }
            [word] if word.eq_ignore_ascii_case("identity") && self.section != Section::Reward => {
                let parents = &picks[..picks.len().saturating_sub(1)];
                let dashes: Vec<usize> = (0..parents.len()).filter(|&d| matches!(parents[d], Pick::Each)).collect();
                return match dashes[..] {
                    [d] if last_each && self.sizes[d] == self.sizes[self.sizes.len() - 1] => Ok(Numbers::Identity(d)),
                    _ => Err(ctx.error(
                        node,
                        "'identity' needs <Instance> to end with two '-' (one parent, then the variable) and no other \
                         '-', the two of as many values",
                    )),
                };
            }
            _ => {}
        }
        let mut list = Vec::with_capacity(tokens.len());
        for token in tokens {
            let value = token.parse::<f64>().ok().filter(|x| x.is_finite());
            match value {
                Some(x) if self.section == Section::Reward || x >= 0.0 => list.push(x),
                _ => {
                    let expected = if self.section == Section::Reward {
                        "a number"
                    } else if token.eq_ignore_ascii_case("identity") || token.eq_ignore_ascii_case("uniform") {
                        "'identity' and 'uniform' stand alone"
                    } else {
                        "a probability: a number in [0, 1]"
                    };
                    return Err(ctx.error(node, format!("'{token}' in <{name}> (expected {expected})")));
                }
            }
        }
        let expected: usize =
            picks.iter().zip(&self.sizes).filter(|(p, _)| matches!(p, Pick::Each)).map(|(_, &n)| n).product();
        if list.len() != expected {
            return Err(ctx.error(
                node,
                format!(
                    "<{name}> has {} number{} (expected {expected}: one for each combination of the values the '-' \
                     of <Instance> stand for)",
                    list.len(),
                    if list.len() == 1 { "" } else { "s" }
                ),
            ));
        }
        Ok(Numbers::List(list))
    }

    /// Writes the cells that `picks` select.
    fn fill(&mut self, picks: &[Pick], numbers: &Numbers, offset: usize) {
        let strides = self.strides();
        let var_size = self.sizes.last().copied().unwrap_or(1).max(1);
        let mut value = vec![0usize; picks.len()];
        for (v, p) in value.iter_mut().zip(picks) {
            if let Pick::One(i) = p {
                *v = *i;
            }
        }
        let uniform = 1.0 / var_size as f64;
        let mark = u32::try_from(offset + 1).unwrap_or(u32::MAX);
        loop {
            let cell: usize = value.iter().zip(&strides).map(|(v, s)| v * s).sum();
            let x = match numbers {
                Numbers::List(list) => {
                    // The table runs row-major over the `-` dimensions.
                    let k = picks
                        .iter()
                        .zip(&value)
                        .zip(&self.sizes)
                        .filter(|((p, _), _)| matches!(p, Pick::Each))
                        .fold(0, |k, ((_, v), n)| k * n + v);
                    list.get(k).copied().unwrap_or(0.0)
                }
                Numbers::Identity(d) => f64::from(u8::from(value.get(*d) == value.last())),
                Numbers::Uniform => uniform,
            };
            if let Some(slot) = self.table.get_mut(cell) {
                *slot = x;
            }
            if let Some(w) = self.written.get_mut(cell / var_size) {
                *w = mark;
            }
            // The next selected cell: the last free dimension moves fastest.
            let mut d = picks.len();
            loop {
                if d == 0 {
                    return;
                }
                d -= 1;
                if matches!(picks[d], Pick::One(_)) {
                    continue;
                }
                value[d] += 1;
                if value[d] < self.sizes[d] {
                    break;
                }
                value[d] = 0;
            }
        }
    }

    /// Of a `<CondProb>`: every row written must sum to 1 within the tolerance (renormalised
    /// and noted if off by more than rounding).
    fn check_rows(&mut self, ctx: &Ctx, vars: &Variables) -> Result<()> {
        if self.section == Section::Reward {
            return Ok(());
        }
        let tol = ctx.options.tolerance;
        let n = self.sizes.last().copied().unwrap_or(1).max(1);
        for row in 0..self.written.len() {
            let mark = self.written[row];
            if mark == 0 {
                continue;
            }
            let Some(cells) = self.table.get_mut(row * n..(row + 1) * n) else { continue };
            match normalise(cells, tol) {
                RowCheck::Exact => {}
                RowCheck::Renormalised(sum) => {
                    let note = format!(
                        "{}{} summed to {}; renormalised",
                        self.label(vars),
                        self.row_name(vars, row),
                        fmt_num(sum)
                    );
                    ctx.note(note);
                }
                RowCheck::Bad(sum) => {
                    return Err(ctx.error_at(
                        (mark - 1) as usize,
                        format!(
                            "{}: the probabilities{} sum to {} (expected 1 within {tol:e})",
                            self.label(vars),
                            self.row_name(vars, row),
                            fmt_num(sum)
                        ),
                    ));
                }
            }
        }
        Ok(())
    }
}

/// What `name` refers to, checked against where it stands: the variable of a table of
/// `section` (`of` is `None`) or a parent of the variable `of`.
fn role(ctx: &Ctx, vars: &Variables, section: Section, node: Node, name: &str, of: Option<Ref>) -> Result<Ref> {
    let place = if of.is_some() { "parent" } else { "variable" };
    let element = section.element();
    if name == "null" {
        return Err(ctx.error(
            node,
            format!(
                "null in <{}> (expected variable names: no parents is null only in <InitialStateBelief>)",
                section.container()
            ),
        ));
    }
    let Some(r) = vars.get(name) else {
        let declared = vars.names_where(|_| true);
        return Err(ctx.error(
            node,
            format!("unknown {place} '{name}' in <{element}> (expected a declared variable: {})", shown(&declared)),
        ));
    };
    let allowed = match (section, of, r) {
        (Section::Belief, _, Ref::Prev(i) | Ref::Curr(i)) => return Ok(Ref::Prev(i)),
        (Section::Transition, None, Ref::Curr(_))
        | (Section::Observation, None, Ref::Obs(_))
        | (Section::Reward, None, Ref::Reward)
        | (Section::Transition, Some(_), Ref::Action(_) | Ref::Prev(_) | Ref::Curr(_))
        | (Section::Observation, Some(_), Ref::Action(_) | Ref::Curr(_) | Ref::Obs(_))
        | (Section::Reward, Some(_), Ref::Action(_) | Ref::Prev(_) | Ref::Curr(_) | Ref::Obs(_)) => true,
        _ => false,
    };
    if allowed {
        return Ok(r);
    }
    let expected = match (section, of) {
        (Section::Belief, _) => "a state variable",
        (Section::Transition, None) => "a state variable's vnameCurr",
        (Section::Observation, None) => "an observation variable",
        (Section::Reward, None) => "a reward variable",
        (Section::Transition, Some(_)) => "an action or state variable",
        (Section::Observation, Some(_)) => {
            "an action, a state variable's vnameCurr or another observation variable (an observation that \
             depends on the previous state is not an O(o|a,s'))"
        }
        (Section::Reward, Some(_)) => "an action, state or observation variable",
    };
    Err(ctx
        .error(node, format!("{name} as a {place} in <{}>'s <{element}> (expected {expected})", section.container())))
}
