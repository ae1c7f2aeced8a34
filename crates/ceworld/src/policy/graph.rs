//! A policy as a finite-state controller (a policy graph): its nodes are the memories `m[t]`
//! (all levels) reachable from the start; a node takes its decision from `h0[m_1]`, and the
//! observation that follows moves it to the next node. Printed in a world's own names, saved
//! as JSON, or, when every law is deterministic, as a pomdp-solve policy graph (`.pg`).

use std::collections::HashMap;
use std::fmt::Write;

use serde::Serialize;
use serde_json::{Value, json};

use crate::error::{Error, Result};
use crate::policy::Hhmm;

/// Laws below this are left out of every graph (they are rounding noise of refitted tables).
pub const NEGLIGIBLE: f64 = 1e-12;
/// Laws below this are left out of the graphs shown by default (`show`, `Policy.graph`): a
/// learned policy's tables keep small probabilities everywhere, which would draw every memory.
pub const PRUNE: f64 = 1e-3;
/// The most nodes a graph may have.
pub const MAX_NODES: usize = 100_000;

/// A pruning threshold, named `name` where it is refused: a probability `0 <= p < 1`.
pub fn check_prune(name: &str, prune: f64) -> Result<()> {
    if !(0.0..1.0).contains(&prune) {
        return Err(Error::invalid(name, format!("{prune} (expected a probability 0 <= p < 1)")));
    }
    Ok(())
}

/// One node of a [`Graph`].
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Node {
    /// The memory `m_1 .. m_Λ` of the node.
    pub memory: Vec<u16>,
    /// `(decision, probability)`, positive probabilities only.
    pub decision: Vec<(usize, f64)>,
    /// For each observation: `(next node, probability)`.
    pub next: Vec<Vec<(usize, f64)>>,
}

/// A policy as a policy graph.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Graph {
    /// `(node, probability)` at `t = 1` (after the start symbol).
    pub initial: Vec<(usize, f64)>,
    /// The nodes reachable from the initial ones, in the order they were found.
    pub nodes: Vec<Node>,
}

impl Graph {
    /// The graph of `policy` for a world whose observations are `0..n_obs` after a first
    /// observation `start` (the start symbol of a tabular world), laws of probability `least` or
    /// less left out (at least [`NEGLIGIBLE`]; the nodes only they reach with them).
    pub fn of(policy: &Hhmm, n_obs: usize, start: usize, least: f64) -> Result<Graph> {
        let least = least.max(NEGLIGIBLE);
        let mut index: HashMap<Vec<u16>, usize> = HashMap::new();
        let mut memories: Vec<Vec<u16>> = Vec::new();
        let mut find = |memory: Vec<u16>, memories: &mut Vec<Vec<u16>>| -> Result<usize> {
            if let Some(&k) = index.get(&memory) {
                return Ok(k);
            }
            if memories.len() >= MAX_NODES {
                return Err(Error::invalid("policy", format!("more than {MAX_NODES} reachable memories")));
            }
            index.insert(memory.clone(), memories.len());
            memories.push(memory);
            Ok(memories.len() - 1)
        };
        let mut initial = Vec::new();
        for (memory, p) in policy.memory_law(start, &[], true) {
            if p > least {
                initial.push((find(memory, &mut memories)?, p));
            }
        }
        let mut nodes = Vec::new();
        while nodes.len() < memories.len() {
            let memory = memories[nodes.len()].clone();
            let decision = above(policy.decision_law(memory[0] as usize).iter().copied().enumerate(), least);
            let mut next = Vec::with_capacity(n_obs);
            for y in 0..n_obs {
                let mut law = Vec::new();
                for (m, p) in policy.memory_law(y, &memory, false) {
                    if p > least {
                        law.push((find(m, &mut memories)?, p));
                    }
                }
                next.push(law);
            }
            nodes.push(Node { memory, decision, next });
        }
        Ok(Graph { initial, nodes })
    }

    /// Whether every law is a single outcome (a deterministic controller).
    pub fn is_deterministic(&self) -> bool {
        self.initial.len() == 1
            && self.nodes.iter().all(|n| n.decision.len() == 1 && n.next.iter().all(|law| law.len() == 1))
    }

    /// A deterministic graph with equivalent nodes merged (same decision, and next nodes
    /// equivalent on every observation: Moore's partition refinement); the first node of each
    /// class stands for it. A graph that is not deterministic comes back unchanged.
    pub fn minimized(&self) -> Graph {
        if !self.is_deterministic() {
            return self.clone();
        }
        let n = self.nodes.len();
        let mut class: Vec<usize> = self.nodes.iter().map(|node| node.decision[0].0).collect();
        loop {
            let mut ids: HashMap<(usize, Vec<usize>), usize> = HashMap::new();
            let refined: Vec<usize> = (0..n)
                .map(|k| {
                    let signature = (class[k], self.nodes[k].next.iter().map(|law| class[law[0].0]).collect());
                    let next = ids.len();
                    *ids.entry(signature).or_insert(next)
                })
                .collect();
            let count = |c: &[usize]| c.iter().collect::<std::collections::HashSet<_>>().len();
            let done = count(&refined) == count(&class);
            class = refined;
            if done {
                break;
            }
        }
        // Keep the first node of each class, in order; map every node to its representative.
        let mut representative: HashMap<usize, usize> = HashMap::new();
        let mut kept = Vec::new();
        for (k, &c) in class.iter().enumerate() {
            representative.entry(c).or_insert_with(|| {
                kept.push(k);
                kept.len() - 1
            });
        }
        let new_id = |k: usize| representative[&class[k]];
        let nodes = kept
            .iter()
            .map(|&k| {
                let node = &self.nodes[k];
                let next = node.next.iter().map(|law| vec![(new_id(law[0].0), 1.0)]).collect();
                Node { memory: node.memory.clone(), decision: node.decision.clone(), next }
            })
            .collect();
        Graph { initial: vec![(new_id(self.initial[0].0), 1.0)], nodes }
    }

    /// The pomdp-solve policy graph: one line `N A Z1 Z2 ...` per node (node 0 the initial
    /// one), or an error when some law is not deterministic.
    pub fn to_pg(&self) -> Result<String> {
        if !self.is_deterministic() {
            return Err(Error::invalid(
                "policy",
                "not deterministic (some decision or memory law has several outcomes): save it as JSON instead",
            ));
        }
        // Node 0 is the initial node: renumber so.
        let first = self.initial[0].0;
        let id = |k: usize| match k {
            k if k == first => 0,
            k if k < first => k + 1,
            k => k,
        };
        let mut order: Vec<usize> = (0..self.nodes.len()).collect();
        order.sort_by_key(|&k| id(k));
        let mut text = String::new();
        for k in order {
            let node = &self.nodes[k];
            let _ = write!(text, "{} {}", id(k), node.decision[0].0);
            for law in &node.next {
                let _ = write!(text, " {}", id(law[0].0));
            }
            text.push('\n');
        }
        Ok(text)
    }

    /// The graph as text in the world's names: each node's decision law and, per observation,
    /// its next nodes.
    pub fn describe(&self, decisions: &[String], observations: &[String]) -> String {
        let mut text = String::from("initial:");
        for &(k, p) in &self.initial {
            let _ = write!(text, " node {k} ({})", probability(p));
        }
        text.push('\n');
        for (k, node) in self.nodes.iter().enumerate() {
            let laws: Vec<String> =
                node.decision.iter().map(|&(d, p)| format!("{} {}", name(decisions, d), probability(p))).collect();
            let _ = writeln!(text, "node {k} (memory {:?}): {}", node.memory, laws.join(", "));
            for (y, law) in node.next.iter().enumerate() {
                let next: Vec<String> = law.iter().map(|&(n, p)| format!("node {n} ({})", probability(p))).collect();
                let _ = writeln!(text, "  on {} -> {}", name(observations, y), next.join(", "));
            }
        }
        text
    }

    /// The graph as JSON in the world's names.
    pub fn to_json(&self, decisions: &[String], observations: &[String]) -> Value {
        let nodes: Vec<Value> = self
            .nodes
            .iter()
            .map(|node| {
                let decision: serde_json::Map<String, Value> =
                    node.decision.iter().map(|&(d, p)| (name(decisions, d), json!(p))).collect();
                let next: serde_json::Map<String, Value> =
                    node.next.iter().enumerate().map(|(y, law)| (name(observations, y), json!(law))).collect();
                json!({"memory": node.memory, "decision": decision, "next": next})
            })
            .collect();
        json!({"format": "cehmm-policy-graph", "initial": self.initial, "nodes": nodes})
    }

    /// The graph in the form named `form`: `"text"` ([`Graph::describe`]), `"json"`
    /// ([`Graph::to_json`]), `"dot"` ([`Graph::to_dot`]) or `"pg"` ([`Graph::to_pg`]); all but
    /// `"json"` as a JSON string.
    pub fn render(&self, form: &str, decisions: &[String], observations: &[String]) -> Result<Value> {
        Ok(match form {
            "text" => Value::String(self.describe(decisions, observations)),
            "json" => self.to_json(decisions, observations),
            "dot" => Value::String(self.to_dot(decisions, observations)),
            "pg" => Value::String(self.to_pg()?),
            other => {
                return Err(Error::invalid(
                    "form",
                    format!("{other:?} (expected \"text\", \"json\", \"dot\" or \"pg\")"),
                ));
            }
        })
    }

    /// The graph in Graphviz's DOT language, in the world's names (`dot -Tpng FILE.dot`): a
    /// node per memory labelled with its decisions, one edge per pair of nodes labelled with
    /// the observations that take it (with their probability where it is below 1), and the
    /// start drawn as a point.
    pub fn to_dot(&self, decisions: &[String], observations: &[String]) -> String {
        let with = |label: String, p: f64| if p < 1.0 { format!("{label} ({})", probability(p)) } else { label };
        let mut text = String::from("digraph policy {\n  rankdir=LR;\n  node [shape=box, style=rounded];\n");
        text.push_str("  start [shape=point, width=0.12];\n");
        for &(k, p) in &self.initial {
            let label = if p < 1.0 { format!(" [label=\"{}\"]", probability(p)) } else { String::new() };
            let _ = writeln!(text, "  start -> n{k}{label};");
        }
        for (k, node) in self.nodes.iter().enumerate() {
            let laws: Vec<String> = node.decision.iter().map(|&(d, p)| with(name(decisions, d), p)).collect();
            let _ = writeln!(text, "  n{k} [label=\"{k}: {}\"];", escape(&laws.join("\n")));
            // One edge per next node, labelled with every observation that leads there.
            let mut edges: Vec<(usize, Vec<String>)> = Vec::new();
            for (y, law) in node.next.iter().enumerate() {
                for &(n, p) in law {
                    let label = with(name(observations, y), p);
                    match edges.iter_mut().find(|(to, _)| *to == n) {
                        Some((_, labels)) => labels.push(label),
                        None => edges.push((n, vec![label])),
                    }
                }
            }
            for (n, labels) in edges {
                let _ = writeln!(text, "  n{k} -> n{n} [label=\"{}\"];", escape(&labels.join("\n")));
            }
        }
        text.push_str("}\n");
        text
    }
}

/// `0.250`, or `2.1e-5` for what three decimals would show as zero.
fn probability(p: f64) -> String {
    if p < 0.0005 { format!("{p:.1e}") } else { format!("{p:.3}") }
}

fn above(law: impl Iterator<Item = (usize, f64)>, least: f64) -> Vec<(usize, f64)> {
    law.filter(|&(_, p)| p > least).collect()
}

/// `text` inside a DOT string: quotes and backslashes escaped, line breaks as `\\n`.
fn escape(text: &str) -> String {
    text.replace('\\', "\\\\").replace('"', "\\\"").replace('\n', "\\n")
}

fn name(names: &[String], k: usize) -> String {
    names.get(k).cloned().unwrap_or_else(|| k.to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn names(v: &[&str]) -> Vec<String> {
        v.iter().map(|s| (*s).to_string()).collect()
    }

    #[test]
    fn dot_draws_one_edge_per_pair_of_nodes_labelled_with_its_observations() {
        // Node 0 listens; "left" goes to node 1 for sure, "right" stays or moves, 0.5 each;
        // node 1 opens a door (named with a quote, which DOT must see escaped).
        let graph = Graph {
            initial: vec![(0, 1.0)],
            nodes: vec![
                Node {
                    memory: vec![0],
                    decision: vec![(0, 1.0)],
                    next: vec![vec![(1, 1.0)], vec![(0, 0.5), (1, 0.5)]],
                },
                Node {
                    memory: vec![1],
                    decision: vec![(1, 0.75), (0, 0.25)],
                    next: vec![vec![(0, 1.0)], vec![(0, 1.0)]],
                },
            ],
        };
        let dot = graph.to_dot(&names(&["listen", "open \"x\""]), &names(&["left", "right"]));
        let expected = "digraph policy {\n  rankdir=LR;\n  node [shape=box, style=rounded];\n  start [shape=point, width=0.12];\n  \
                        start -> n0;\n  n0 [label=\"0: listen\"];\n  n0 -> n1 [label=\"left\\nright (0.500)\"];\n  \
                        n0 -> n0 [label=\"right (0.500)\"];\n  n1 [label=\"1: open \\\"x\\\" (0.750)\\nlisten (0.250)\"];\n  \
                        n1 -> n0 [label=\"left\\nright\"];\n}\n";
        assert_eq!(dot, expected);
    }
}
