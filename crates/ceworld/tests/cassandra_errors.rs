//! Each kind of error: its line:column and its message.

// The values compared are exact: copied from the text, or sums of
// binary fractions, so exact float comparison is intended.
#![allow(clippy::float_cmp)]

use std::path::Path;

use ceworld::world::cassandra::{Options, ParseError, parse, parse_bytes, parse_file};

const PRE: &str = "states: left right\nactions: go\nobservations: o1 o2\n";

fn err(text: &str) -> ParseError {
    match parse(text, &Options::default()) {
        Ok(_) => panic!("expected an error for:\n{text}"),
        Err(e) => e,
    }
}

/// Asserts the error is at `line:col` and its message contains `part`.
#[track_caller]
fn check(text: &str, line: usize, col: usize, part: &str) {
    let e = err(text);
    assert_eq!((e.line, e.column), (line, col), "{e}");
    assert!(e.message.contains(part), "message {:?} lacks {part:?}", e.message);
    assert_eq!(e.to_string(), format!("{line}:{col}: {}", e.message));
}

#[test]
fn unknown_names() {
    check(
        &format!("{PRE}T: go : middle : left 1"),
        4,
        9,
        "unknown state 'middle' (expected one of: left, right; an index; or '*')",
    );
    check(&format!("{PRE}T: stay identity"), 4, 4, "unknown action 'stay'");
    check(&format!("{PRE}O: go : left : o3 1"), 4, 16, "unknown observation 'o3'");
    // Long lists are truncated.
    let names: Vec<String> = (0..50).map(|i| format!("s{i}")).collect();
    let text = format!("states: {}\nactions: 1 observations: 1\nT: 0 : zz uniform", names.join(" "));
    let e = err(&text);
    assert!(e.message.contains("s0, s1, s2, s3, s4, s5, s6, s7, ... (50 in all)"), "{e}");
    // A model declared by count has no names.
    check(
        "states: 3 actions: 1 observations: 1\nT: 0 : a uniform",
        2,
        8,
        "unknown state 'a' (states are declared by count: expected an index 0..2 or '*')",
    );
}

#[test]
fn index_out_of_range() {
    check(&format!("{PRE}T: go : 2 uniform"), 4, 9, "state index 2 is out of range (there are 2 states: 0..1)");
    check(&format!("{PRE}T: 1 identity"), 4, 4, "action index 1 is out of range (there is 1 action: 0..0)");
    check(&format!("{PRE}T: 99999999999999999999999 identity"), 4, 4, "out of range");
    check(&format!("{PRE}start: 7\n"), 4, 8, "start state index 7 is out of range (there are 2 states: 0..1)");
    check(
        &format!("{PRE}start: 0.5\n"),
        5,
        1,
        "expected 2 probabilities after 'start:' (or one state index), found 1, then end of file",
    );
    check(
        &format!("{PRE}start: 0.5 0.25 0.25\n"),
        4,
        17,
        "too many numbers after 'start:': expected 2 probabilities, found another: number 0.25",
    );
}

#[test]
fn wrong_row_lengths() {
    // Too few, running into the next entry.
    check(
        &format!("{PRE}T: go : left 0.5\nT: go : right 0 1"),
        5,
        1,
        "expected 2 probabilities after 'T: go : left', found 1, then name 'T'",
    );
    // Too many.
    check(
        &format!("{PRE}T: go : left 0.5 0.25 0.25"),
        4,
        23,
        "too many numbers after 'T: go : left': expected 2 probabilities, found another: number 0.25",
    );
    // A matrix that stops short.
    check(
        &format!("{PRE}T: go\n1 0\n0\nO: go uniform"),
        7,
        1,
        "expected 4 probabilities (a 2x2 matrix) after 'T: go', found 3, then name 'O'",
    );
    // Nothing where a row should be.
    check(
        &format!("{PRE}O: go : left\nR: go : * : * : * 1"),
        5,
        1,
        "expected 2 probabilities or 'uniform' after 'O: go : left', found name 'R'",
    );
    check(
        &format!("{PRE}T: go reset"),
        4,
        7,
        "expected 4 probabilities (a 2x2 matrix), 'uniform' or 'identity' after 'T: go', found name 'reset'",
    );
    check(
        &format!("{PRE}R: go : left : right 1"),
        4,
        23,
        "expected 2 numbers after 'R: go : left : right', found 1, then end of file",
    );
    check(
        &format!("{PRE}R: go : left 1 2 3 4 5"),
        4,
        22,
        "too many numbers after 'R: go : left': expected 4 numbers (a 2x2 matrix)",
    );
}

#[test]
fn truncated_files() {
    check(&format!("{PRE}T: go : left : "), 4, 16, "expected state (a name, an index or '*'), found end of file");
    check(
        &format!("{PRE}T: go : left : right"),
        4,
        21,
        "expected 1 probability after 'T: go : left : right', found end of file",
    );
    check(&format!("{PRE}T"), 4, 2, "expected ':' after 'T', found end of file");
    check(
        "states: a b\nactions:",
        2,
        9,
        "expected a count or a list of action names after 'actions:', found end of file",
    );
    check("discount:", 1, 10, "expected a number after 'discount:', found end of file");
    check(&format!("{PRE}start include:"), 4, 15, "expected a state after 'start include:', found end of file");
}

#[test]
fn non_numeric_probabilities() {
    check(
        &format!("{PRE}T: go : left : right x"),
        4,
        22,
        "expected 1 probability after 'T: go : left : right', found name 'x'",
    );
    check(&format!("{PRE}T: go : left nan 1"), 4, 14, "found name 'nan'");
    check(&format!("{PRE}T: go : left inf 1"), 4, 14, "found name 'inf'");
    check(&format!("{PRE}T: go : left 1e999 0"), 4, 14, "number '1e999' is out of range (expected a finite number)");
    check(&format!("{PRE}T: go : left 0.5, 0.5"), 4, 14, "unexpected '0.5,' (expected a name, a number, '*' or ':')");
    check(&format!("{PRE}T: go : left 1 - x"), 4, 18, "expected a number after '-', found name 'x'");
    check(&format!("{PRE}T: go : left 0.5 -0.5"), 4, 18, "negative probability -0.5 after 'T: go : left'");
    check(&format!("{PRE}O: go : left : o1 - 1"), 4, 19, "negative probability -1 after 'O: go : left : o1'");
    check(&format!("{PRE}start: -0.5 1.5"), 4, 8, "negative probability -0.5 in 'start:'");
}

#[test]
fn bad_characters_and_utf8() {
    check("states: 2\nactions: caf\u{e9}", 2, 10, "unexpected non-ASCII text 'caf\u{e9}'");
    let e = parse_bytes(b"states: 2\n  \xff\xfe 3", &Options::default()).unwrap_err();
    assert_eq!((e.line, e.column), (2, 3), "{e}");
    assert!(e.message.contains("non-ASCII"), "{e}");
    check("states: 2 ; actions: 2", 1, 11, "unexpected ';'");
    check("states: 2\n1d", 2, 1, "unexpected '1d'");
}

#[test]
fn missing_and_duplicate_preamble_lines() {
    check(
        "states: 2\nactions: 2\nT: 0 identity",
        3,
        1,
        "missing 'observations:' line (expected in the preamble, before this first T: entry)",
    );
    check(
        "states: 2\nobservations: 2\n",
        3,
        1,
        "missing 'actions:' line (expected in the preamble, before the end of the file)",
    );
    check("", 1, 1, "missing 'states:' line");
    check("# only a comment\n", 2, 1, "missing 'states:' line");
    check(&format!("{PRE}states: 3"), 4, 1, "duplicate 'states' line (first given at 1:1)");
    check("discount: 0.5\ndiscount: 0.5", 2, 1, "duplicate 'discount' line (first given at 1:1)");
    check(
        &format!("{PRE}T: go identity\ndiscount: 0.5"),
        5,
        1,
        "'discount' must come before the first T:, O: or R: entry (which is at 4:1)",
    );
    check("start: uniform\nstates: 2", 1, 1, "'start' must come after 'states:'");
    check(&format!("{PRE}start: uniform start: uniform"), 4, 16, "duplicate 'start' line (first given at 4:1)");
    check("values: rewardz", 1, 9, "expected 'reward' or 'cost' after 'values:', found name 'rewardz'");
    check("discount: 1.5", 1, 11, "discount 1.5 is out of range (expected a number from 0 to 1)");
    check("discount: - 0.5", 1, 11, "discount -0.5 is out of range");
    check("states 2", 1, 8, "expected ':' after 'states', found number 2");
    check(
        "foo: 2",
        1,
        1,
        "expected a preamble line (discount:, values:, states:, actions:, observations:, start:) or an entry (T:, O:, R:), found name 'foo'",
    );
    check("states: a b a", 1, 13, "duplicate state name 'a' (first at 1:9)");
    // Statement keywords are reserved: they end a list of names.
    check("states: a T b", 1, 11, "missing 'actions:' line (expected in the preamble, before this first T: entry)");
    check("states: T O", 1, 9, "expected a count or a list of state names after 'states:', found name 'T'");
    check(&format!("{PRE}R: go 1"), 4, 7, "expected ':' after 'R: go', found number 1");
}

#[test]
fn sizes_zero_and_huge() {
    check("states: 0", 1, 9, "'states: 0': there must be at least one state");
    check("states: 2 actions: 0", 1, 20, "'actions: 0': there must be at least one action");
    check("states: 99999999999", 1, 9, "'states:' gives too many states (number 99999999999)");
    check("states: 2 observations: 999999999999999999999999999", 1, 25, "too many observations");
    check("states: 2 actions: 99999999999", 1, 20, "too many actions");
    // Each size fits but the product does not: refused before allocating.
    check(
        "states: 10000 actions: 5 observations: 2\nT: 0 identity",
        2,
        1,
        "the model is too large: with 10000 states, 5 actions and 2 observations the transition table T (A x S x S) would have more than 268435456 entries",
    );
    let small = Options { max_entries: 100, ..Options::default() };
    let e = parse("states: 11 actions: 1 observations: 1", &small).unwrap_err();
    assert!(e.message.contains("too many states"), "{e}");
    let e = parse("states: 5 actions: 5 observations: 1", &small).unwrap_err();
    assert!(e.message.contains("would have more than 100 entries"), "{e}");
}

#[test]
fn rows_that_do_not_sum_to_one() {
    // The row's last write is where the error points.
    check(
        &format!("{PRE}T: go identity\nO: go uniform\nT: go : right : left 0.1\n"),
        6,
        22,
        "T: a=go s=right sums to 1.1 (expected 1 within 1e-5)",
    );
    check(
        &format!("{PRE}T: go identity\nO: go\n0.5 0.5\n0.4 0.7\n"),
        7,
        1,
        "O: a=go s'=right sums to 1.1 (expected 1 within 1e-5)",
    );
    check(
        &format!("{PRE}T: go identity\nO: go : left 0.5 0.49\nO: go : right uniform"),
        5,
        14,
        "O: a=go s'=left sums to 0.99 (expected 1 within 1e-5)",
    );
    // The earliest bad row in the file is reported, T or O.
    check(
        &format!("{PRE}O: go : left 0.5 0.4\nT: go : left 0.5 0.4\nT: go : right uniform\nO: go : right uniform"),
        4,
        14,
        "O: a=go s'=left sums to 0.9",
    );
    check(&format!("{PRE}start: 0.5 0.6"), 4, 1, "start sums to 1.1 (expected 1 within 1e-5)");
    check(&format!("{PRE}start exclude: left right"), 4, 1, "'start exclude:' excludes every state");
    // Zero rows: written as zeros, or never written.
    check(
        &format!("{PRE}T: go identity\nT: go : left 0 0\nO: go uniform"),
        5,
        14,
        "T: a=go s=left sums to 0 (expected 1 within 1e-5)",
    );
    check(
        &format!("{PRE}T: go : left uniform\nO: go uniform\n"),
        6,
        1,
        "T: a=go s=right was never written (expected a row of 2 probabilities summing to 1)",
    );
    check(&format!("{PRE}T: go identity\n"), 5, 1, "O: a=go s'=left was never written");
}

#[test]
fn file_names_in_errors() {
    let e = parse_file(Path::new("/nonexistent/x.pomdp"), &Options::default()).unwrap_err();
    assert_eq!((e.line, e.column), (0, 0));
    assert_eq!(e.file.as_deref(), Some("/nonexistent/x.pomdp"));
    assert!(e.to_string().starts_with("/nonexistent/x.pomdp: cannot read the file: "), "{e}");

    let dir = std::env::temp_dir().join(format!("pomdp-parser-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("bad.pomdp");
    std::fs::write(&file, "states: 2\nactions: 1\nobservations: 1\nT: 0 : 5 uniform\n").unwrap();
    let e = parse_file(&file, &Options::default()).unwrap_err();
    let shown = e.to_string();
    std::fs::remove_dir_all(&dir).unwrap();
    assert_eq!(shown, format!("{}:4:8: state index 5 is out of range (there are 2 states: 0..1)", file.display()));
    // ParseError is a std error.
    let boxed: Box<dyn std::error::Error> = Box::new(e);
    assert!(boxed.to_string().contains("bad.pomdp:4:8"));
}
