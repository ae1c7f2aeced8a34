//! Small hand-written files, one for each form of the grammar.

// The values compared are exact: copied from the text, or sums of
// binary fractions, so exact float comparison is intended.
#![allow(clippy::float_cmp)]

#[path = "cassandra/common.rs"]
mod common;

use ceworld::world::cassandra::{Options, RewardEntry, Values, parse, parse_bytes};
use common::{assert_close, brute_expected_reward, check_invariants, ok};

/// A preamble with named states s0..s2, actions a0, a1, observations o0, o1.
const PRE: &str = "discount: 0.9\nvalues: reward\nstates: s0 s1 s2\nactions: a0 a1\nobservations: o0 o1\n";

/// T and O for every action, so that the file validates; tests append
/// entries after this to override parts.
const FILL: &str = "T: * uniform\nO: * uniform\n";

fn with(body: &str) -> ceworld::world::cassandra::Pomdp {
    let p = ok(&format!("{PRE}{FILL}{body}"));
    check_invariants(&p);
    p
}

fn t(p: &ceworld::world::cassandra::Pomdp, a: usize) -> Vec<f64> {
    let n = p.num_states();
    p.transition[a * n * n..(a + 1) * n * n].to_vec()
}

const U3: f64 = 1.0 / 3.0;

#[test]
fn preamble_and_defaults() {
    let p = ok("states: 2 actions: 1 observations: 3 T: 0 identity O: 0 uniform");
    assert_eq!(p.discount, None);
    assert_eq!(p.values, Values::Reward);
    assert_eq!(p.states, ["0", "1"]);
    assert_eq!(p.actions, ["0"]);
    assert_eq!(p.observations, ["0", "1", "2"]);
    assert_eq!(p.start, None);
    assert_eq!(p.start_or_uniform(), [0.5, 0.5]);
    assert!(p.rewards.is_empty());
    assert_eq!(p.expected_reward(), [0.0, 0.0]);
    // Any order; "rewards"/"costs" accepted; whitespace is free.
    let p = ok("observations:1\nactions :\n x\n\nvalues:\ncosts states: a\n discount:1 T: x identity O: x uniform");
    assert_eq!(p.values, Values::Cost);
    assert_eq!(p.discount, Some(1.0));
    assert_eq!(p.states, ["a"]);
    let p = ok("values: rewards states: 1 actions: 1 observations: 1 T: 0 uniform O: 0 uniform");
    assert_eq!(p.values, Values::Reward);
}

#[test]
fn transition_forms() {
    // Single entries, with names and indices mixed.
    let p = with("T: a0 : s0 : s1 0.7\nT: 0 : 0 : 2 0.3\nT: a0 : 0 : s0 0\n");
    assert_close(&t(&p, 0)[0..3], &[0.0, 0.7, 0.3], 0.0);
    // A row.
    let p = with("T: a1 : s2\n0.1 0.2 0.7\n");
    assert_close(&t(&p, 1)[6..9], &[0.1, 0.2, 0.7], 0.0);
    // A row written as uniform.
    let p = with("T: a1 : s2 0 0 1\nT: a1 : s2 uniform\n");
    assert_close(&t(&p, 1)[6..9], &[U3, U3, U3], 1e-15);
    // A matrix spread over lines any way.
    let p = with("T: a1\n1 0\n0 0 1 0 0\n0 1\n");
    assert_eq!(t(&p, 1), [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0]);
    // identity and uniform.
    let p = with("T: a0 identity\n");
    assert_eq!(t(&p, 0), [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0]);
    assert_close(&t(&p, 1), &[U3; 9], 1e-15);
    let p = with("T: a0 identity T: a0 uniform\n");
    assert_close(&t(&p, 0), &[U3; 9], 1e-15);
}

#[test]
fn transition_reset_uses_the_start() {
    let text = format!("{PRE}start: s1\n{FILL}T: a0 : s2 reset\n");
    let p = ok(&text);
    assert_eq!(&t(&p, 0)[6..9], [0.0, 1.0, 0.0]);
    // Without a start line, reset is uniform.
    let p = with("T: a0 : s2 reset\n");
    assert_close(&t(&p, 0)[6..9], &[U3, U3, U3], 1e-15);
}

#[test]
fn wildcards_in_every_position() {
    let p = with("T: * : * : * 0\nT: * : * : s2 1\n");
    for a in 0..2 {
        for s in 0..3 {
            assert_eq!(p.transition_prob(a, s, 2), 1.0);
            assert_eq!(p.transition_prob(a, s, 0), 0.0);
        }
    }
    let p = with("T: a1 : * 0 1 0\n");
    assert_eq!(t(&p, 1), [0.0, 1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0]);
    let p = with("T: * : s0 1 0 0\n");
    assert_eq!(&t(&p, 0)[0..3], [1.0, 0.0, 0.0]);
    assert_eq!(&t(&p, 1)[0..3], [1.0, 0.0, 0.0]);
    let p = with("O: * : * : * 0\nO: * : * : o1 1\n");
    assert!(p.observation.chunks(2).all(|r| r == [0.0, 1.0]));
    let p = with("O: a0 : * : o0 1\nO: a0 : * : 1 0\n");
    assert_eq!(&p.observation[0..6], [1.0, 0.0, 1.0, 0.0, 1.0, 0.0]);
    let p = with(
        "R: * : * : * : * 3\nR: a1 : * : * : * 2\nR: * : s1 : * : * 1\nR: * : * : s2 : * 5\nR: * : * : * : o1 7\n",
    );
    assert_eq!(p.reward(0, 0, 0, 0), 3.0);
    assert_eq!(p.reward(1, 0, 0, 0), 2.0);
    assert_eq!(p.reward(1, 1, 0, 0), 1.0);
    assert_eq!(p.reward(1, 1, 2, 0), 5.0);
    assert_eq!(p.reward(1, 1, 2, 1), 7.0);
    assert_eq!(p.reward(0, 2, 0, 1), 7.0);
    assert!(p.reward_depends_on_next());
    assert_close(&p.expected_reward(), &brute_expected_reward(&p), 1e-12);
}

#[test]
fn observation_forms() {
    let p = with("O: a0 : s1 : o1 0.25\nO: a0 : s1 : o0 0.75\n");
    assert_eq!(p.observation_prob(0, 1, 0), 0.75);
    assert_eq!(p.observation_prob(0, 1, 1), 0.25);
    let p = with("O: a1 : s2 0.6 0.4\n");
    assert_eq!(p.observation_prob(1, 2, 0), 0.6);
    let p = with("O: a1\n1 0\n0 1\n0.5 0.5\n");
    assert_eq!(&p.observation[6..12], [1.0, 0.0, 0.0, 1.0, 0.5, 0.5]);
    let p = with("O: a1 1 0 1 0 1 0 O: a1 : s0 uniform\n");
    assert_eq!(&p.observation[6..12], [0.5, 0.5, 1.0, 0.0, 1.0, 0.0]);
    let p = with("O: a1 1 0 1 0 1 0 O: a1 uniform\n");
    assert_eq!(&p.observation[6..12], [0.5; 6]);
}

#[test]
fn reward_forms() {
    let p = with("R: a0 : s0 : s1 : o1 -4.5\n");
    assert_eq!(
        p.rewards,
        [RewardEntry { action: Some(0), state: Some(0), next_state: Some(1), observation: Some(1), value: -4.5 }]
    );
    // A row over observations.
    let p = with("R: a1 : s2 : s0 1 2\n");
    assert_eq!(p.reward(1, 2, 0, 0), 1.0);
    assert_eq!(p.reward(1, 2, 0, 1), 2.0);
    assert_eq!(p.reward(1, 2, 1, 1), 0.0);
    // A matrix over (s', o).
    let p = with("R: a1 : * \n1 2\n3 4\n5 6\n");
    assert_eq!(p.rewards.len(), 6);
    assert_eq!(p.reward(1, 0, 2, 1), 6.0);
    assert_eq!(p.reward(1, 1, 1, 0), 3.0);
    assert_eq!(p.reward(0, 1, 1, 0), 0.0);
    assert_close(&p.expected_reward(), &brute_expected_reward(&p), 1e-12);
    // Signs, separate or attached; exponents; forms of decimals.
    let p = with("R: a0 : s0 : * : * - 2\nR: a0 : s1 : * : * +1e1\nR: a0 : s2 : * : * -.5\nR: a1 : * : * : * 5.\n");
    assert_eq!(p.expected_reward(), [-2.0, 10.0, -0.5, 5.0, 5.0, 5.0]);
}

#[test]
fn later_entries_override_earlier_ones() {
    let p = with("R: * : * : * : * 1\nR: a0 : * : * : * 2\nR: * : * : * : * 3\nR: a1 : s0 : * : * 4\n");
    assert_eq!(p.expected_reward(), [3.0, 3.0, 3.0, 4.0, 3.0, 3.0]);
    // A specific entry followed by a wildcard: the wildcard wins.
    let p = with("R: a0 : s0 : s0 : o0 9\nR: a0 : s0 : * : * 1\n");
    assert_eq!(p.reward(0, 0, 0, 0), 1.0);
    assert_eq!(p.expected_reward()[0], 1.0);
    // And the other way round: only (s0, o0) differs.
    let p = with("R: a0 : s0 : * : * 1\nR: a0 : s0 : s0 : o0 9\n");
    assert_close(&p.expected_reward()[0..1], &[1.0 + U3 * 0.5 * 8.0], 1e-12);
    assert_close(&p.expected_reward(), &brute_expected_reward(&p), 1e-12);
    // T: a single entry after a matrix overrides one cell.
    let p = with("T: a0 identity\nT: a0 : s0 : s0 0.5\nT: a0 : s0 : s1 0.5\n");
    assert_eq!(&t(&p, 0)[0..3], [0.5, 0.5, 0.0]);
}

#[test]
fn start_forms() {
    let start = |line: &str| ok(&format!("{PRE}{line}\n{FILL}")).start;
    assert_eq!(start("start: 0.2 0.3 0.5"), Some(vec![0.2, 0.3, 0.5]));
    assert_close(&start("start: uniform").unwrap(), &[U3; 3], 1e-15);
    assert_eq!(start("start: s2"), Some(vec![0.0, 0.0, 1.0]));
    assert_eq!(start("start: 1"), Some(vec![0.0, 1.0, 0.0]));
    assert_eq!(start("start include: s0 2"), Some(vec![0.5, 0.0, 0.5]));
    assert_eq!(start("start include: s1"), Some(vec![0.0, 1.0, 0.0]));
    assert_eq!(start("start exclude: s1"), Some(vec![0.5, 0.0, 0.5]));
    assert_eq!(start("start exclude: s1 s1 0"), Some(vec![0.0, 0.0, 1.0]));
    assert_eq!(start("start:\n# comment\n 1 0\n 0"), Some(vec![1.0, 0.0, 0.0]));
    assert_eq!(start(""), None);
    // One state: "start: 1" is the probability vector, "start: 0" the index.
    let one = |line: &str| ok(&format!("states: 1 actions: 1 observations: 1 {line} T: 0 identity O: 0 uniform")).start;
    assert_eq!(one("start: 1"), Some(vec![1.0]));
    assert_eq!(one("start: 0"), Some(vec![1.0]));
    assert_eq!(one("start: 1.0"), Some(vec![1.0]));
}

#[test]
fn comments_anywhere() {
    let text = "# head\ndiscount:#c\n0.5#c\nstates#c\n:#c\n2 # c\nactions: a#c\nobservations: 1\n\
                T#c\n:#c\na#c\n:#c\n*#c\n0.5 # half\n0.5\nO: a uniform # end\nR:*:*:*:* 1#x";
    let p = ok(text);
    assert_eq!(p.discount, Some(0.5));
    assert_eq!(p.transition, [0.5, 0.5, 0.5, 0.5]);
    assert_eq!(p.expected_reward(), [1.0, 1.0]);
}

#[test]
fn crlf_tabs_and_keywords_glued_to_colons() {
    let p = ok(
        "discount:0.5\r\nstates:2\r\nactions:go\r\nobservations:1\r\nT:go\tidentity\r\nO:go:*:*\t1.0\r\nR:go:1:*:* 2\r\n",
    );
    assert_eq!(p.transition, [1.0, 0.0, 0.0, 1.0]);
    assert_eq!(p.expected_reward(), [0.0, 2.0]);
}

#[test]
fn names_that_look_like_keywords() {
    // Only the statement keywords are reserved; uniform, identity, reset,
    // include and exclude can be names.
    let p = ok("states: reset identity\nactions: include\nobservations: uniform exclude\n\
                T: include : reset : identity 1\nT: include : identity : reset 1\n\
                O: include : * uniform");
    assert_eq!(p.states, ["reset", "identity"]);
    assert_eq!(p.transition, [0.0, 1.0, 1.0, 0.0]);
}

#[test]
fn costs_are_kept_as_written() {
    let p = ok("values: cost states: 1 actions: 1 observations: 1 T: 0 identity O: 0 uniform R: 0 : 0 : 0 : 0 4");
    assert_eq!(p.values, Values::Cost);
    assert_eq!(p.expected_reward(), [4.0]);
}

#[test]
fn renormalisation_is_noted() {
    let p = ok(
        "states: 3 actions: 1 observations: 1 start: 0.333333 0.333333 0.333333 T: 0 : 0 0.333333 0.333333 0.333334 T: 0 : 1 0.999999 0 0 T: 0 : 2 uniform O: 0 uniform",
    );
    assert_eq!(
        p.renormalised,
        ["start summed to 0.999999; renormalised", "T: a=0 s=1 summed to 0.999999; renormalised"]
    );
    assert_eq!(p.transition[3], 1.0);
    check_invariants(&p);
}

#[test]
fn invalid_utf8_is_fine_inside_comments() {
    let mut bytes = b"# \xff\xfe caf\xc3\xa9\nstates: 1 actions: 1 observations: 1 # \x80\n".to_vec();
    bytes.extend_from_slice(b"T: 0 identity O: 0 uniform");
    let p = parse_bytes(&bytes, &Options::default()).unwrap();
    assert_eq!(p.transition, [1.0]);
}

#[test]
fn a_count_declared_model_refers_by_index() {
    let p = ok(
        "states: 3 actions: 2 observations: 2 T: 1 : 2 : 0 1 T: 1 : 0 : 0 1 T: 1 : 1 : 1 1 T: 0 identity O: * uniform",
    );
    assert_eq!(p.transition_prob(1, 2, 0), 1.0);
    assert!(parse("states: 3 actions: 2 observations: 2 T: 1 : two : 0 1", &Options::default()).is_err());
}
