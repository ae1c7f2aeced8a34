//! Mutation fuzzing with a fixed seed: for every real file, thousands of
//! random mutations (byte and bit flips, truncations, deleted, duplicated
//! and inserted tokens and lines, stray bytes including invalid UTF-8).
//! The parser must return `Ok` or `Err` and never panic; a successful parse
//! must satisfy the model's invariants.
//!
//! Set `POMDP_FUZZ_ITERS` to change the number of mutations per file
//! (default 1000; a quarter of that for the big files), and
//! `POMDP_FUZZ_SEED` to explore other mutations (default a fixed seed).

// The values compared are exact: copied from the text, or sums of
// binary fractions, so exact float comparison is intended.
#![allow(clippy::float_cmp)]

#[path = "cassandra/common.rs"]
mod common;
#[path = "cassandra/rng.rs"]
mod rng;

use std::panic::{AssertUnwindSafe, catch_unwind};

use ceworld::world::cassandra::{Options, parse, parse_bytes};
use common::{assert_close, brute_expected_reward, check_invariants, real_files};
use rng::Rng;

/// Tokens that are likely to reach interesting corners of the grammar.
const INTERESTING: &[&str] = &[
    "*",
    ":",
    "-",
    "+",
    "#",
    "\n",
    "T:",
    "O:",
    "R:",
    "T",
    "uniform",
    "identity",
    "reset",
    "start:",
    "start include:",
    "start exclude:",
    "states:",
    "actions:",
    "observations:",
    "discount:",
    "values:",
    "cost",
    "reward",
    "0",
    "1",
    "2",
    "-1",
    "0.5",
    "-0.5",
    "1e999",
    "1e-400",
    "nan",
    "inf",
    ".5",
    "5.",
    "1e",
    "99999999999",
    "18446744073709551616",
    "4294967296",
    "65536",
    "1.5",
    "include",
    "exclude",
    "\u{e9}",
    "s0",
    "0x10",
    "--1",
];

/// What mutations start from: the whole file if small; otherwise its
/// preamble (all lines before the first entry) and a random window of 40
/// entry lines, so that each parse stays fast while still reaching the
/// entries of the big files.
struct Base {
    whole: Option<Vec<u8>>,
    preamble: Vec<u8>,
    entry_lines: Vec<Vec<u8>>,
}

impl Base {
    fn new(file: &[u8]) -> Self {
        if file.len() <= 12_000 {
            return Base { whole: Some(file.to_vec()), preamble: Vec::new(), entry_lines: Vec::new() };
        }
        let lines: Vec<&[u8]> = file.split(|&b| b == b'\n').collect();
        let is_entry = |l: &&[u8]| {
            let t = l.trim_ascii_start();
            matches!(t.first(), Some(b'T' | b'O' | b'R'))
                && t.get(1..).is_some_and(|r| r.trim_ascii_start().starts_with(b":"))
        };
        let first = lines.iter().position(is_entry).unwrap_or(lines.len());
        let mut preamble = Vec::new();
        for l in &lines[..first] {
            preamble.extend_from_slice(l);
            preamble.push(b'\n');
        }
        Base { whole: None, preamble, entry_lines: lines[first..].iter().map(|l| l.to_vec()).collect() }
    }

    fn sample(&self, rng: &mut Rng) -> Vec<u8> {
        if let Some(w) = &self.whole {
            return w.clone();
        }
        let n = self.entry_lines.len();
        let start = rng.below(n.saturating_sub(40).max(1));
        let mut out = self.preamble.clone();
        for l in &self.entry_lines[start..(start + 40).min(n)] {
            out.extend_from_slice(l);
            out.push(b'\n');
        }
        out
    }
}

/// Byte ranges of the whitespace-separated words of `text`.
fn words(text: &[u8]) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    let mut i = 0;
    while i < text.len() {
        if text[i].is_ascii_whitespace() {
            i += 1;
            continue;
        }
        let s = i;
        while i < text.len() && !text[i].is_ascii_whitespace() {
            i += 1;
        }
        out.push((s, i));
    }
    out
}

fn line_ranges(text: &[u8]) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    let mut s = 0;
    for (i, &b) in text.iter().enumerate() {
        if b == b'\n' {
            out.push((s, i + 1));
            s = i + 1;
        }
    }
    if s < text.len() {
        out.push((s, text.len()));
    }
    out
}

fn mutate(text: &mut Vec<u8>, rng: &mut Rng) {
    let len = text.len();
    match rng.below(11) {
        0 if len > 0 => {
            let i = rng.below(len);
            text[i] = rng.byte();
        }
        1 if len > 0 => {
            let i = rng.below(len);
            text[i] ^= 1 << rng.below(8);
        }
        2 => text.truncate(rng.below(len + 1)),
        3 => {
            let w = words(text);
            if !w.is_empty() {
                let (s, e) = *rng.pick(&w);
                text.drain(s..e);
            }
        }
        4 => {
            let w = words(text);
            if !w.is_empty() {
                let (s, e) = *rng.pick(&w);
                let word = text[s..e].to_vec();
                let at = if rng.chance(1, 2) { e } else { rng.pick(&w).1 };
                text.splice(at..at, [b" ".as_slice(), &word].concat());
            }
        }
        5 => {
            let tok = rng.pick(INTERESTING).as_bytes();
            let w = words(text);
            let at = if w.is_empty() { 0 } else { rng.pick(&w).1 };
            text.splice(at..at, [b" ", tok, b" "].concat());
        }
        6 => {
            let l = line_ranges(text);
            if !l.is_empty() {
                let (s, e) = *rng.pick(&l);
                text.drain(s..e);
            }
        }
        7 => {
            let l = line_ranges(text);
            if !l.is_empty() {
                let (s, e) = *rng.pick(&l);
                let line = text[s..e].to_vec();
                let at = rng.pick(&l).0;
                text.splice(at..at, line);
            }
        }
        8 => {
            let w = words(text);
            if !w.is_empty() {
                let (s, e) = *rng.pick(&w);
                let tok = rng.pick(INTERESTING).as_bytes();
                text.splice(s..e, tok.iter().copied());
            }
        }
        9 => {
            // Swap two lines.
            let l = line_ranges(text);
            if l.len() >= 2 {
                let (a, b) = (rng.below(l.len()), rng.below(l.len()));
                let (a, b) = (a.min(b), a.max(b));
                if a != b {
                    let (la, lb) = (l[a], l[b]);
                    let first = text[la.0..la.1].to_vec();
                    let second = text[lb.0..lb.1].to_vec();
                    text.splice(lb.0..lb.1, first);
                    text.splice(la.0..la.1, second);
                }
            }
        }
        _ => {
            let at = rng.below(len + 1);
            let n = 1 + rng.below(4);
            let bytes: Vec<u8> = (0..n).map(|_| rng.byte()).collect();
            text.splice(at..at, bytes);
        }
    }
}

/// Parses `input` both as bytes and as lossy text; fails the test on a panic
/// (saving the input) or on a malformed result. Returns whether the bytes
/// parsed.
fn run_one(input: &[u8], options: &Options, what: &str) -> bool {
    let result = catch_unwind(AssertUnwindSafe(|| {
        let a = parse_bytes(input, options);
        // The lossy text differs from the bytes only if they are not UTF-8.
        let b = match std::str::from_utf8(input) {
            Ok(_) => None,
            Err(_) => Some(parse(&String::from_utf8_lossy(input), options)),
        };
        (a, b)
    }));
    let Ok((a, b)) = result else {
        let file = std::env::temp_dir().join("pomdp-fuzz-failure.pomdp");
        let _ = std::fs::write(&file, input);
        panic!("{what}: the parser panicked; input saved to {}", file.display());
    };
    let parsed = a.is_ok();
    for r in std::iter::once(a).chain(b) {
        match r {
            Ok(p) => {
                check_invariants(&p);
                let r = p.expected_reward();
                assert!(r.iter().all(|x| x.is_finite()), "{what}");
                let size = p.num_actions() * p.num_states().pow(2) * p.num_observations();
                if size <= 20_000 && p.rewards.len() <= 2_000 {
                    assert_close(&r, &brute_expected_reward(&p), 1e-6);
                }
            }
            Err(e) => {
                assert!(e.line >= 1 && e.column >= 1, "{what}: {e}");
                assert!(!e.message.is_empty(), "{what}");
                assert!(!e.to_string().is_empty());
            }
        }
    }
    parsed
}

#[test]
fn mutated_real_files_never_panic() {
    let iters: usize = std::env::var("POMDP_FUZZ_ITERS").ok().and_then(|v| v.parse().ok()).unwrap_or(1000);
    // Keep allocations small: a mutated size can make a legal but huge model.
    let options = Options { max_entries: 1 << 23, ..Options::default() };
    let seed = std::env::var("POMDP_FUZZ_SEED").ok().and_then(|v| v.parse().ok()).unwrap_or(0x5EED_2024);
    let mut rng = Rng::new(seed);
    let (mut ok, mut err) = (0usize, 0usize);
    for path in real_files() {
        let t0 = std::time::Instant::now();
        let name = path.file_name().unwrap().to_string_lossy().to_string();
        let file = std::fs::read(&path).unwrap();
        let n = if file.len() > 12_000 { iters / 4 } else { iters };
        let base = Base::new(&file);
        for i in 0..n {
            let mut text = base.sample(&mut rng);
            for _ in 0..=rng.below(3) {
                mutate(&mut text, &mut rng);
            }
            if run_one(&text, &options, &format!("{name} mutation {i}")) {
                ok += 1;
            } else {
                err += 1;
            }
        }
        println!("{name}: {n} mutations in {:.2} s", t0.elapsed().as_secs_f64());
    }
    println!("mutations: {ok} parsed, {err} refused");
    assert!(ok > 0 && err > 0);
}

#[test]
fn random_bytes_never_panic() {
    let options = Options { max_entries: 1 << 20, ..Options::default() };
    let mut rng = Rng::new(42);
    let alphabet: &[u8] = b"TOR:*-+.#0123456789 \n\tse uniform identity";
    for i in 0..3000 {
        let n = rng.below(200);
        let bytes: Vec<u8> = (0..n).map(|_| if rng.chance(3, 4) { *rng.pick(alphabet) } else { rng.byte() }).collect();
        let _ = run_one(&bytes, &options, &format!("random bytes {i}"));
    }
}
