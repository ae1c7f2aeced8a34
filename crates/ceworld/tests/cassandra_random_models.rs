//! Differential test: random small models are written out in random forms
//! of the grammar (names or indices, wildcards, rows, matrices, uniform,
//! identity, reset, overrides, comments, odd layout) while an independent
//! oracle paints the dense T, O and R. The parser must agree with the
//! oracle, or refuse exactly the files whose rows do not sum to 1.

// The values compared are exact: copied from the text, or sums of
// binary fractions, so exact float comparison is intended.
#![allow(clippy::float_cmp)]
// Sizes here are below 10: converting them to f64 is exact.
#![allow(clippy::cast_precision_loss)]

#[path = "cassandra/common.rs"]
mod common;
#[path = "cassandra/rng.rs"]
mod rng;

use std::fmt::Write as _;

use ceworld::world::cassandra::{Options, parse};
use common::check_invariants;
use rng::Rng;

struct Gen<'r> {
    rng: &'r mut Rng,
    ns: usize,
    na: usize,
    no: usize,
    /// Whether states, actions, observations are named.
    named: [bool; 3],
    text: String,
    t: Vec<f64>,
    o: Vec<f64>,
    r: Vec<f64>,
    t_written: Vec<bool>,
    o_written: Vec<bool>,
    start: Option<Vec<f64>>,
}

const PREFIX: [&str; 3] = ["st", "ac", "ob"];

impl Gen<'_> {
    fn sep(&mut self) {
        let s = *self.rng.pick(&[" ", " ", " ", "\n", "\t ", "  # note: T: 1 2\n", "\r\n"]);
        self.text.push_str(s);
    }

    fn word(&mut self, w: &str) {
        self.text.push_str(w);
        self.sep();
    }

    fn count(&self, kind: usize) -> usize {
        [self.ns, self.na, self.no][kind]
    }

    /// A reference to element `i` of `kind`, by name or index.
    fn reference(&mut self, kind: usize, i: usize) -> String {
        if self.named[kind] && self.rng.chance(2, 3) { format!("{}{i}", PREFIX[kind]) } else { i.to_string() }
    }

    /// A selector, `*` (None) or an index, followed by a colon unless last.
    fn pick_sel(&mut self, kind: usize, colon: bool) -> Option<usize> {
        let sel = if self.rng.chance(1, 3) {
            self.word("*");
            None
        } else {
            let i = self.rng.below(self.count(kind));
            let r = self.reference(kind, i);
            self.word(&r);
            Some(i)
        };
        if colon {
            self.word(":");
        }
        sel
    }

    fn select(&mut self, kind: usize) -> Option<usize> {
        self.pick_sel(kind, true)
    }

    fn select_last(&mut self, kind: usize) -> Option<usize> {
        self.pick_sel(kind, false)
    }

    /// A random distribution over `n` in eighths (exact in binary).
    fn eighths(&mut self, n: usize) -> Vec<f64> {
        let mut v = vec![0.0; n];
        for _ in 0..8 {
            v[self.rng.below(n)] += 0.125;
        }
        v
    }

    fn numbers(&mut self, values: &[f64]) {
        for v in values {
            self.word(&format!("{v}"));
        }
    }

    fn range(sel: Option<usize>, n: usize) -> std::ops::Range<usize> {
        sel.map_or(0..n, |i| i..i + 1)
    }

    fn paint_rows(&mut self, is_t: bool, a: Option<usize>, s: Option<usize>, row: &[f64]) {
        let len = row.len();
        for a in Self::range(a, self.na) {
            for s in Self::range(s, self.ns) {
                let r = a * self.ns + s;
                let (table, written) =
                    if is_t { (&mut self.t, &mut self.t_written) } else { (&mut self.o, &mut self.o_written) };
                table[r * len..(r + 1) * len].copy_from_slice(row);
                written[r] = true;
            }
        }
    }

    fn preamble(&mut self) {
        let mut lines = vec![0, 1, 2, 3, 4];
        for i in (1..lines.len()).rev() {
            lines.swap(i, self.rng.below(i + 1));
        }
        for l in lines {
            match l {
                0 if self.rng.chance(3, 4) => {
                    self.word("discount:");
                    self.word("0.95");
                }
                1 if self.rng.chance(3, 4) => {
                    self.word("values:");
                    let v = *self.rng.pick(&["reward", "cost"]);
                    self.word(v);
                }
                2..=4 => {
                    let kind = l - 2;
                    self.word(["states:", "actions:", "observations:"][kind]);
                    if self.named[kind] {
                        for i in 0..self.count(kind) {
                            self.word(&format!("{}{i}", PREFIX[kind]));
                        }
                    } else {
                        self.word(&self.count(kind).to_string());
                    }
                }
                _ => {}
            }
        }
    }

    fn start_line(&mut self) {
        let ns = self.ns;
        let uniform = vec![1.0 / ns as f64; ns];
        let start = match self.rng.below(6) {
            0 => return,
            1 => {
                self.word("start:");
                let d = self.eighths(ns);
                self.numbers(&d);
                d
            }
            2 => {
                self.word("start:");
                self.word("uniform");
                uniform
            }
            3 => {
                self.word("start:");
                let i = self.rng.below(ns);
                let r = self.reference(0, i);
                self.word(&r);
                (0..ns).map(|s| f64::from(u8::from(s == i))).collect()
            }
            k => {
                let include = k == 4;
                self.word(if include { "start include:" } else { "start exclude:" });
                let mut listed = vec![false; ns];
                let n = 1 + self.rng.below(if include { ns } else { ns.max(2) - 1 });
                for _ in 0..n {
                    let i = self.rng.below(ns);
                    listed[i] = true;
                    let r = self.reference(0, i);
                    self.word(&r);
                }
                if !include && listed.iter().all(|&x| x) {
                    // Excluding everything is an error; keep this one valid.
                    self.text.truncate(self.text.rfind("start").unwrap());
                    return;
                }
                let k = listed.iter().filter(|&&x| x == include).count();
                listed.iter().map(|&x| if x == include { 1.0 / k as f64 } else { 0.0 }).collect()
            }
        };
        self.start = Some(start);
    }

    fn transition(&mut self) {
        let ns = self.ns;
        let uniform = vec![1.0 / ns as f64; ns];
        self.word("T:");
        match self.rng.below(8) {
            0 => {
                let a = self.select(1);
                let s = self.select(0);
                let s2 = self.select_last(0);
                let v = *self.rng.pick(&[0.0, 0.125, 0.5, 1.0]);
                self.numbers(&[v]);
                for a in Self::range(a, self.na) {
                    for s in Self::range(s, ns) {
                        for s2 in Self::range(s2, ns) {
                            self.t[(a * ns + s) * ns + s2] = v;
                        }
                        self.t_written[a * ns + s] = true;
                    }
                }
            }
            1 | 2 => {
                let a = self.select(1);
                let s = self.select_last(0);
                let row = match self.rng.below(4) {
                    0 => {
                        self.word("uniform");
                        uniform
                    }
                    1 => {
                        self.word("reset");
                        self.start.clone().unwrap_or(uniform)
                    }
                    _ => {
                        let d = self.eighths(ns);
                        self.numbers(&d);
                        d
                    }
                };
                self.paint_rows(true, a, s, &row);
            }
            k => {
                let a = self.select_last(1);
                for s in 0..ns {
                    let row = match k {
                        3 => uniform.clone(),
                        4 => (0..ns).map(|c| f64::from(u8::from(c == s))).collect(),
                        _ => self.eighths(ns),
                    };
                    if k > 4 {
                        self.numbers(&row);
                    }
                    self.paint_rows(true, a, Some(s), &row);
                }
                match k {
                    3 => self.word("uniform"),
                    4 => self.word("identity"),
                    _ => {}
                }
            }
        }
    }

    fn observation(&mut self) {
        let no = self.no;
        let uniform = vec![1.0 / no as f64; no];
        self.word("O:");
        match self.rng.below(6) {
            0 => {
                let a = self.select(1);
                let s2 = self.select(0);
                let o = self.select_last(2);
                let v = *self.rng.pick(&[0.0, 0.125, 0.5, 1.0]);
                self.numbers(&[v]);
                for a in Self::range(a, self.na) {
                    for s2 in Self::range(s2, self.ns) {
                        for o in Self::range(o, no) {
                            self.o[(a * self.ns + s2) * no + o] = v;
                        }
                        self.o_written[a * self.ns + s2] = true;
                    }
                }
            }
            1 | 2 => {
                let a = self.select(1);
                let s2 = self.select_last(0);
                let row = if self.rng.chance(1, 3) {
                    self.word("uniform");
                    uniform
                } else {
                    let d = self.eighths(no);
                    self.numbers(&d);
                    d
                };
                self.paint_rows(false, a, s2, &row);
            }
            k => {
                let a = self.select_last(1);
                for s in 0..self.ns {
                    let row = if k == 3 { uniform.clone() } else { self.eighths(no) };
                    if k != 3 {
                        self.numbers(&row);
                    }
                    self.paint_rows(false, a, Some(s), &row);
                }
                if k == 3 {
                    self.word("uniform");
                }
            }
        }
    }

    fn reward(&mut self) {
        let (ns, no) = (self.ns, self.no);
        self.word("R:");
        let a = self.select(1);
        let form = self.rng.below(4);
        let s = if form == 3 { self.select_last(0) } else { self.select(0) };
        let value = |g: &mut Self| {
            let v = g.rng.below(11) as f64 - 5.0;
            if v < 0.0 && g.rng.chance(1, 2) {
                g.word("-");
                g.word(&format!("{}", -v));
            } else {
                g.word(&format!("{v}"));
            }
            v
        };
        let mut cells: Vec<(Option<usize>, Option<usize>, f64)> = Vec::new();
        match form {
            0 | 1 => {
                let s2 = self.select(0);
                let o = self.select_last(2);
                cells.push((s2, o, value(self)));
            }
            2 => {
                let s2 = self.select_last(0);
                for o in 0..no {
                    cells.push((s2, Some(o), value(self)));
                }
            }
            _ => {
                for s2 in 0..ns {
                    for o in 0..no {
                        cells.push((Some(s2), Some(o), value(self)));
                    }
                }
            }
        }
        for (s2, o, v) in cells {
            for a in Self::range(a, self.na) {
                for s in Self::range(s, ns) {
                    for s2 in Self::range(s2, ns) {
                        for o in Self::range(o, no) {
                            self.r[((a * ns + s) * ns + s2) * no + o] = v;
                        }
                    }
                }
            }
        }
    }
}

#[test]
fn random_models_match_the_oracle() {
    let mut rng = Rng::new(7);
    let (mut accepted, mut refused) = (0, 0);
    for case in 0..4000 {
        let (ns, na, no) = (1 + rng.below(4), 1 + rng.below(3), 1 + rng.below(3));
        let named = [rng.chance(1, 2), rng.chance(1, 2), rng.chance(1, 2)];
        let mut g = Gen {
            rng: &mut rng,
            ns,
            na,
            no,
            named,
            text: String::new(),
            t: vec![0.0; na * ns * ns],
            o: vec![0.0; na * ns * no],
            r: vec![0.0; na * ns * ns * no],
            t_written: vec![false; na * ns],
            o_written: vec![false; na * ns],
            start: None,
        };
        g.preamble();
        g.start_line();
        if g.rng.chance(4, 5) {
            g.word("T: * uniform");
            g.paint_rows(true, None, None, &vec![1.0 / ns as f64; ns]);
        }
        if g.rng.chance(4, 5) {
            g.word("O: * uniform");
            g.paint_rows(false, None, None, &vec![1.0 / no as f64; no]);
        }
        for _ in 0..g.rng.below(14) {
            match g.rng.below(3) {
                0 => g.transition(),
                1 => g.observation(),
                _ => g.reward(),
            }
        }
        let valid_rows = |table: &[f64], written: &[bool], len: usize| {
            table.chunks(len).zip(written).all(|(row, &w)| w && (row.iter().sum::<f64>() - 1.0).abs() < 1e-9)
        };
        let valid = valid_rows(&g.t, &g.t_written, ns) && valid_rows(&g.o, &g.o_written, no);
        let mut text = g.text.clone();
        let _ = write!(text, "# case {case}");
        match parse(&text, &Options::default()) {
            Ok(p) => {
                assert!(valid, "case {case}: accepted an invalid model:\n{text}");
                accepted += 1;
                check_invariants(&p);
                assert_eq!(p.start, g.start, "case {case}:\n{text}");
                for (x, y) in p.transition.iter().zip(&g.t).chain(p.observation.iter().zip(&g.o)) {
                    assert!((x - y).abs() < 1e-12, "case {case}: {x} vs {y}\n{text}");
                }
                let mut want = vec![0.0; na * ns];
                // The indexed lookup of the world's outcomes gives the oracle's rewards too.
                let mut outcomes = p.outcome_rewards();
                for a in 0..na {
                    for s in 0..ns {
                        outcomes.select(a, s);
                        for s2 in 0..ns {
                            let row = outcomes.row(s2).to_vec();
                            for (o, &from_row) in row.iter().enumerate() {
                                let rv = g.r[((a * ns + s) * ns + s2) * no + o];
                                assert_eq!(p.reward(a, s, s2, o), rv, "case {case}:\n{text}");
                                assert_eq!(from_row, rv, "case {case}: outcome reward\n{text}");
                                want[a * ns + s] += g.t[(a * ns + s) * ns + s2] * g.o[(a * ns + s2) * no + o] * rv;
                            }
                        }
                    }
                }
                let got = p.expected_reward();
                for (x, y) in got.iter().zip(&want) {
                    assert!((x - y).abs() < 1e-9, "case {case}: r {x} vs {y}\n{text}");
                }
            }
            Err(e) => {
                assert!(!valid, "case {case}: refused a valid model: {e}\n{text}");
                refused += 1;
            }
        }
    }
    println!("{accepted} accepted, {refused} refused");
    assert!(accepted > 1000 && refused > 100, "{accepted} accepted, {refused} refused");
}
