//! The `<Variable>` section: the state, observation, action and reward variables.

use std::collections::HashMap;

use roxmltree::Node;

use super::{Ctx, Result, elements, shown, text_of};

/// A state, observation or action variable's values.
pub(crate) struct Var {
    /// Its name in messages (a state variable's `vnameCurr`).
    pub name: String,
    pub values: Vec<String>,
    index: HashMap<String, usize>,
}

impl Var {
    /// The number of values.
    pub fn len(&self) -> usize {
        self.values.len()
    }

    /// The value a token of an `<Instance>` names: a value's name, else its index.
    pub fn value(&self, token: &str) -> Option<usize> {
        self.index.get(token).copied().or_else(|| {
            let digits = !token.is_empty() && token.bytes().all(|b| b.is_ascii_digit());
            token.parse::<usize>().ok().filter(|&i| digits && i < self.len())
        })
    }

    /// "unknown value 'x' of variable v (expected one of: ...; an index below N; '*' or '-')".
    pub fn unknown(&self, token: &str) -> String {
        format!(
            "unknown value '{token}' of variable {} (expected one of: {}; an index below {}; '*' or '-')",
            self.name,
            shown(&self.values),
            self.len()
        )
    }
}

/// A state variable: its name before a step, and its values (named after the step). Whether
/// the agent sees it is in [`Variables::observed`].
pub(crate) struct StateVar {
    pub prev: String,
    pub var: Var,
}

/// What a name in a `<Var>` or `<Parent>` refers to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Ref {
    /// A state variable before the step (`vnamePrev`).
    Prev(usize),
    /// A state variable after the step (`vnameCurr`).
    Curr(usize),
    Obs(usize),
    Action(usize),
    Reward,
}

/// A part of the flat observation, in declaration order.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Observed {
    /// A fully observed state variable's new value.
    State(usize),
    Obs(usize),
}

/// Every declared variable.
pub(crate) struct Variables {
    pub states: Vec<StateVar>,
    pub observations: Vec<Var>,
    pub actions: Vec<Var>,
    pub observed: Vec<Observed>,
    names: HashMap<String, (Ref, usize)>,
}

impl Variables {
    /// Reads a `<Variable>` element.
    pub fn read(ctx: &Ctx, node: Node) -> Result<Variables> {
        let mut v = Variables {
            states: Vec::new(),
            observations: Vec::new(),
            actions: Vec::new(),
            observed: Vec::new(),
            names: HashMap::new(),
        };
        for child in elements(node) {
            match child.tag_name().name() {
                "StateVar" => {
                    let prev = attribute(ctx, child, "vnamePrev")?;
                    let curr = attribute(ctx, child, "vnameCurr")?;
                    let fully_observed = match child.attribute("fullyObs").map(str::trim) {
                        None | Some("false" | "0") => false,
                        Some("true" | "1") => true,
                        Some(other) => {
                            return Err(
                                ctx.error(child, format!("fullyObs=\"{other}\" (expected \"true\" or \"false\")"))
                            );
                        }
                    };
                    let i = v.states.len();
                    v.declare(ctx, child, &prev, Ref::Prev(i))?;
                    v.declare(ctx, child, &curr, Ref::Curr(i))?;
                    let var = values(ctx, child, curr, 's')?;
                    if fully_observed {
                        v.observed.push(Observed::State(i));
                    }
                    v.states.push(StateVar { prev, var });
                }
                "ObsVar" => {
                    let name = attribute(ctx, child, "vname")?;
                    v.declare(ctx, child, &name, Ref::Obs(v.observations.len()))?;
                    v.observed.push(Observed::Obs(v.observations.len()));
                    v.observations.push(values(ctx, child, name, 'o')?);
                }
                "ActionVar" => {
                    let name = attribute(ctx, child, "vname")?;
                    v.declare(ctx, child, &name, Ref::Action(v.actions.len()))?;
                    v.actions.push(values(ctx, child, name, 'a')?);
                }
                "RewardVar" => {
                    let name = attribute(ctx, child, "vname")?;
                    v.declare(ctx, child, &name, Ref::Reward)?;
                }
                other => {
                    return Err(ctx.error(
                        child,
                        format!(
                            "unknown element <{other}> in <Variable> (expected <StateVar>, <ObsVar>, <ActionVar> \
                             or <RewardVar>)"
                        ),
                    ));
                }
            }
        }
        if v.states.is_empty() || v.actions.is_empty() {
            let what = if v.states.is_empty() { "<StateVar>" } else { "<ActionVar>" };
            return Err(ctx.error(node, format!("<Variable> declares no {what} (expected at least one)")));
        }
        Ok(v)
    }

    fn declare(&mut self, ctx: &Ctx, node: Node, name: &str, r: Ref) -> Result<()> {
        if name.is_empty() || name.chars().any(char::is_whitespace) || matches!(name, "null" | "*" | "-") {
            return Err(ctx.error(node, format!("variable name '{name}' (expected a name without spaces, not null)")));
        }
        if let Some((_, line)) = self.names.get(name) {
            return Err(ctx.error(node, format!("variable name '{name}' declared twice (first on line {line})")));
        }
        self.names.insert(name.to_string(), (r, ctx.line(node)));
        Ok(())
    }

    /// What `name` refers to.
    pub fn get(&self, name: &str) -> Option<Ref> {
        self.names.get(name).map(|&(r, _)| r)
    }

    /// The values of the variable `r` refers to (`None` for a reward variable).
    pub fn var(&self, r: Ref) -> Option<&Var> {
        match r {
            Ref::Prev(i) | Ref::Curr(i) => self.states.get(i).map(|s| &s.var),
            Ref::Obs(j) => self.observations.get(j),
            Ref::Action(k) => self.actions.get(k),
            Ref::Reward => None,
        }
    }

    /// The name `r` is written with.
    pub fn name(&self, r: Ref) -> &str {
        match r {
            Ref::Prev(i) => self.states.get(i).map_or("", |s| &s.prev),
            Ref::Reward => "reward",
            _ => self.var(r).map_or("", |v| &v.name),
        }
    }

    /// The names of the variables of a kind, for messages.
    pub fn names_where(&self, keep: impl Fn(Ref) -> bool) -> Vec<String> {
        let mut found: Vec<(usize, String)> =
            self.names.iter().filter(|(_, (r, _))| keep(*r)).map(|(n, (_, line))| (*line, n.clone())).collect();
        found.sort();
        found.into_iter().map(|(_, n)| n).collect()
    }
}

fn attribute(ctx: &Ctx, node: Node, name: &str) -> Result<String> {
    node.attribute(name)
        .map(|s| s.trim().to_string())
        .ok_or_else(|| ctx.error(node, format!("<{}> has no {name} attribute", node.tag_name().name())))
}

/// The values of `node` (`<ValueEnum>` or `<NumValues>`); a count N names them `{prefix}0` ..
/// `{prefix}{N-1}`, as APPL does.
fn values(ctx: &Ctx, node: Node, name: String, prefix: char) -> Result<Var> {
    let listed: Vec<Node> =
        elements(node).filter(|c| matches!(c.tag_name().name(), "ValueEnum" | "NumValues")).collect();
    if let Some(other) = elements(node).find(|c| !matches!(c.tag_name().name(), "ValueEnum" | "NumValues")) {
        return Err(ctx.error(
            other,
            format!(
                "unknown element <{}> in a variable (expected <ValueEnum> or <NumValues>)",
                other.tag_name().name()
            ),
        ));
    }
    let [child] = listed[..] else {
        return Err(ctx.error(
            node,
            format!("variable {name} has {} <ValueEnum>/<NumValues> (expected exactly one)", listed.len()),
        ));
    };
    let text = text_of(ctx, child)?;
    let values: Vec<String> = if child.tag_name().name() == "NumValues" {
        let limit = ctx.options.max_entries;
        let count = text.trim().parse::<usize>().ok().filter(|&n| n >= 1 && n <= limit).ok_or_else(|| {
            ctx.error(child, format!("<NumValues>{}</NumValues> of {name} (expected a count 1..={limit})", text.trim()))
        })?;
        (0..count).map(|i| format!("{prefix}{i}")).collect()
    } else {
        text.split_whitespace().map(str::to_string).collect()
    };
    if values.is_empty() {
        return Err(ctx.error(child, format!("<ValueEnum> of {name} is empty (expected at least one value)")));
    }
    let mut index = HashMap::with_capacity(values.len());
    for (i, value) in values.iter().enumerate() {
        if matches!(value.as_str(), "*" | "-") {
            return Err(ctx.error(child, format!("value '{value}' of {name} (a keyword: expected a name)")));
        }
        if index.insert(value.clone(), i).is_some() {
            return Err(ctx.error(child, format!("value '{value}' of {name} is listed twice")));
        }
    }
    Ok(Var { name, values, index })
}
