//! The real benchmark files in data/pomdp (copies of ../shared/pomdp), checked against the
//! sizes and facts listed in SOURCES.md.

// The values compared are exact: copied from the text, or sums of
// binary fractions, so exact float comparison is intended.
#![allow(clippy::float_cmp)]

#[path = "cassandra/common.rs"]
mod common;

use ceworld::world::cassandra::{Options, Values, parse_file};
use common::{assert_close, brute_expected_reward, check_invariants, path, real_files};

/// (file, |S|, |A|, |O|, discount, values, has a start line) from SOURCES.md.
type Row = (&'static str, usize, usize, usize, Option<f64>, Values, bool);

const TABLE: &[Row] = &[
    ("tiger.95.POMDP", 2, 3, 2, Some(0.95), Values::Reward, true),
    ("tiger.aaai.POMDP", 2, 3, 2, Some(0.75), Values::Reward, false),
    ("4x3.95.POMDP", 11, 4, 6, Some(0.95), Values::Reward, true),
    ("cheese.95.POMDP", 11, 4, 7, Some(0.95), Values::Reward, true),
    ("shuttle.95.POMDP", 8, 3, 5, Some(0.95), Values::Reward, true),
    ("parr95.95.POMDP", 7, 3, 6, Some(0.95), Values::Reward, true),
    ("1d.POMDP", 4, 2, 2, Some(0.75), Values::Reward, false),
    ("bridge-repair.POMDP", 5, 12, 5, Some(1.0), Values::Cost, false),
    ("aloha.10.POMDP", 30, 9, 3, Some(0.999), Values::Reward, true),
    ("concert.POMDP", 2, 3, 2, Some(1.0), Values::Reward, false),
    ("ejs1.POMDP", 3, 4, 2, Some(1.0), Values::Reward, false),
    ("ejs2.POMDP", 2, 2, 2, Some(1.0), Values::Reward, false),
    ("ejs3.POMDP", 2, 2, 2, Some(1.0), Values::Cost, false),
    ("ejs4.POMDP", 3, 2, 2, None, Values::Reward, false),
    ("ejs5.POMDP", 2, 2, 2, None, Values::Reward, false),
    ("ejs6.POMDP", 2, 2, 2, None, Values::Reward, false),
    ("hallway.POMDP", 60, 5, 21, Some(0.95), Values::Reward, true),
    ("hallway2.POMDP", 92, 5, 17, Some(0.95), Values::Reward, true),
    ("tiger-grid.POMDP", 36, 5, 17, Some(0.95), Values::Reward, true),
    ("mit.POMDP", 204, 4, 28, Some(0.99), Values::Reward, true),
    ("network.POMDP", 7, 4, 2, Some(0.95), Values::Reward, false),
    ("paint.95.POMDP", 4, 4, 2, Some(0.95), Values::Reward, true),
    ("4x4.95.POMDP", 16, 4, 2, Some(0.95), Values::Reward, true),
    ("mini-hall2.POMDP", 13, 3, 9, Some(0.95), Values::Reward, true),
    ("1d.noisy.POMDP", 4, 2, 2, Some(0.75), Values::Reward, true),
    ("line4-2goals.POMDP", 4, 2, 1, Some(1.0), Values::Reward, false),
    ("machine.POMDP", 256, 4, 16, Some(0.999), Values::Reward, true),
    ("query.s2.POMDP", 9, 2, 3, Some(0.99), Values::Reward, false),
    ("TagAvoid.pomdp", 870, 5, 30, Some(0.95), Values::Reward, true),
    ("tag.pomdp", 870, 5, 30, Some(0.95), Values::Reward, true),
];

/// Files SOURCES.md says are broken, and must be refused.
const BROKEN: &[&str] = &["ejs7.POMDP"];

#[test]
fn table_covers_every_file() {
    let names: Vec<String> = real_files().iter().filter_map(|p| p.file_name()?.to_str().map(str::to_string)).collect();
    // 31 files: the table of SOURCES.md lists ejs4..ejs7 on one row.
    assert_eq!(names.len(), TABLE.len() + BROKEN.len(), "{names:?}");
    for n in &names {
        assert!(TABLE.iter().any(|r| r.0 == n) || BROKEN.contains(&n.as_str()), "{n} is in neither list");
    }
}

#[test]
fn every_good_file_parses_with_the_published_sizes() {
    for &(name, ns, na, no, discount, values, has_start) in TABLE {
        let p = parse_file(&path(name), &Options::default()).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!((p.num_states(), p.num_actions(), p.num_observations()), (ns, na, no), "{name}");
        assert_eq!(p.discount, discount, "{name}");
        assert_eq!(p.values, values, "{name}");
        assert_eq!(p.start.is_some(), has_start, "{name}");
        check_invariants(&p);
        let r = p.expected_reward();
        assert_eq!(r.len(), na * ns);
        assert!(r.iter().all(|x| x.is_finite()), "{name}");
    }
}

#[test]
fn ejs7_is_refused_at_its_bad_row() {
    let e = parse_file(&path("ejs7.POMDP"), &Options::default()).unwrap_err();
    assert_eq!((e.line, e.column), (22, 1), "{e}");
    assert_eq!(e.message, "O: a=1 s'=1 sums to 1.1 (expected 1 within 1e-5)");
    assert!(e.file.as_deref().is_some_and(|f| f.ends_with("ejs7.POMDP")));
    assert!(e.to_string().ends_with("ejs7.POMDP:22:1: O: a=1 s'=1 sums to 1.1 (expected 1 within 1e-5)"));
    // A looser tolerance accepts it, renormalising the row.
    let loose = Options { tolerance: 0.2, ..Options::default() };
    let p = parse_file(&path("ejs7.POMDP"), &loose).unwrap();
    assert_eq!(p.renormalised.len(), 1, "{:?}", p.renormalised);
    assert!((p.observation_prob(1, 1, 1) - 0.7 / 1.1).abs() < 1e-12);
}

#[test]
fn renormalised_rows_are_the_known_ones() {
    // Files whose rows are written with six decimals and miss 1 by up to 5e-6.
    let expect = [
        ("1d.POMDP", 2),
        ("1d.noisy.POMDP", 3),
        ("4x4.95.POMDP", 5),
        ("aloha.10.POMDP", 192),
        ("machine.POMDP", 15),
        ("TagAvoid.pomdp", 5),
    ];
    for &(name, ..) in TABLE {
        let p = parse_file(&path(name), &Options::default()).unwrap();
        let want = expect.iter().find(|e| e.0 == name).map_or(0, |e| e.1);
        assert_eq!(p.renormalised.len(), want, "{name}: {:?}", p.renormalised);
    }
    let p = parse_file(&path("1d.noisy.POMDP"), &Options::default()).unwrap();
    assert_eq!(p.renormalised[0], "start summed to 0.999999; renormalised");
    assert_eq!(p.renormalised[1], "T: a=w0 s=goal summed to 0.999999; renormalised");
    // With a tolerance of 1e-6 the six-decimal files are refused.
    let strict = Options { tolerance: 1e-6, ..Options::default() };
    let e = parse_file(&path("4x4.95.POMDP"), &strict).unwrap_err();
    assert!(e.message.starts_with("start sums to 1.000005"), "{e}");
}

#[test]
fn tiger_95_in_detail() {
    let p = parse_file(&path("tiger.95.POMDP"), &Options::default()).unwrap();
    assert_eq!(p.discount, Some(0.95));
    assert_eq!(p.values, Values::Reward);
    assert_eq!(p.states, ["tiger-left", "tiger-right"]);
    assert_eq!(p.actions, ["listen", "open-left", "open-right"]);
    assert_eq!(p.observations, ["tiger-left", "tiger-right"]);
    assert_eq!(p.start, Some(vec![0.5, 0.5]));
    // T: listen identity; open-left and open-right uniform.
    assert_eq!(p.transition, [1.0, 0.0, 0.0, 1.0, 0.5, 0.5, 0.5, 0.5, 0.5, 0.5, 0.5, 0.5]);
    // O: listen 0.85/0.15; the open actions uniform.
    assert_eq!(p.observation, [0.85, 0.15, 0.15, 0.85, 0.5, 0.5, 0.5, 0.5, 0.5, 0.5, 0.5, 0.5]);
    assert_eq!(p.rewards.len(), 5);
    for s in 0..2 {
        for s2 in 0..2 {
            for o in 0..2 {
                assert_eq!(p.reward(0, s, s2, o), -1.0);
            }
        }
    }
    assert_eq!(p.reward(1, 0, 1, 0), -100.0);
    assert_eq!(p.reward(1, 1, 0, 1), 10.0);
    assert_eq!(p.reward(2, 0, 0, 0), 10.0);
    assert_eq!(p.reward(2, 1, 1, 1), -100.0);
    assert!(!p.reward_depends_on_next());
    assert_eq!(p.expected_reward(), [-1.0, -1.0, -100.0, 10.0, 10.0, -100.0]);
    assert!(p.renormalised.is_empty());
}

#[test]
fn start_beliefs_of_the_tag_files() {
    let tag = parse_file(&path("tag.pomdp"), &Options::default()).unwrap();
    let b = tag.start.as_ref().unwrap();
    let tagged: Vec<usize> = (0..870).filter(|&s| tag.states[s].ends_with("tagged")).collect();
    assert_eq!(tagged.len(), 29);
    for (s, &p) in b.iter().enumerate() {
        let want = if tagged.contains(&s) { 0.0 } else { 1.0 / 841.0 };
        assert!((p - want).abs() < 1e-15, "{s}: {p}");
    }
    let avoid = parse_file(&path("TagAvoid.pomdp"), &Options::default()).unwrap();
    let b = avoid.start.as_ref().unwrap();
    assert_eq!(b.iter().filter(|&&p| p > 0.0).count(), 841);
    for s in (29..870).step_by(30) {
        assert_eq!(b[s], 0.0, "s{s} is a tagged state");
    }
    // Tagged states are absorbing in tag.pomdp.
    for &s in &tagged {
        for a in 0..5 {
            assert_eq!(tag.transition_prob(a, s, s), 1.0);
        }
    }
}

#[test]
fn expected_reward_matches_brute_force_on_the_small_files() {
    for &(name, ns, na, no, ..) in TABLE {
        if ns * ns * na * no > 200_000 {
            continue;
        }
        let p = parse_file(&path(name), &Options::default()).unwrap();
        assert_close(&p.expected_reward(), &brute_expected_reward(&p), 1e-9);
    }
}

#[test]
fn expected_reward_spot_checks_on_the_big_files() {
    // tag: moves cost 1 everywhere except in tagged states (0); Catch gives
    // +10 when co-located, -10 otherwise, 0 when already tagged.
    let tag = parse_file(&path("tag.pomdp"), &Options::default()).unwrap();
    let r = tag.expected_reward();
    let catch = 4;
    for (s, name) in tag.states.iter().enumerate() {
        let want = if name.ends_with("tagged") { 0.0 } else { -1.0 };
        assert_eq!(r[s], want, "North in {name}");
        let c = r[catch * 870 + s];
        assert!([10.0, -10.0, 0.0].contains(&c), "Catch in {name}: {c}");
    }
    // Same by brute force on a sample of (a, s) pairs, for each big file.
    for name in ["tag.pomdp", "TagAvoid.pomdp", "mit.POMDP", "machine.POMDP"] {
        let p = parse_file(&path(name), &Options::default()).unwrap();
        let r = p.expected_reward();
        let (ns, no) = (p.num_states(), p.num_observations());
        for a in 0..p.num_actions() {
            for s in (0..ns).step_by(97) {
                let mut want = 0.0;
                for s2 in 0..ns {
                    let t = p.transition_prob(a, s, s2);
                    if t > 0.0 {
                        for o in 0..no {
                            want += t * p.observation_prob(a, s2, o) * p.reward(a, s, s2, o);
                        }
                    }
                }
                assert!((r[a * ns + s] - want).abs() < 1e-9, "{name} a={a} s={s}");
            }
        }
    }
}

#[test]
fn later_r_lines_win_in_ejs5() {
    // "R : 0 : 0 : * : * 0.0" is overridden by "R : 0 : 0 : * : * -1.0".
    let p = parse_file(&path("ejs5.POMDP"), &Options::default()).unwrap();
    assert_eq!(p.reward(0, 0, 1, 1), -1.0);
    assert_eq!(p.reward(0, 1, 0, 0), -1.0);
    assert_eq!(p.reward(1, 0, 0, 0), 0.0);
}
