//! Helpers shared by the integration tests.
#![allow(dead_code)] // each test crate uses a different subset

use std::path::{Path, PathBuf};

use ceworld::world::cassandra::{Options, Pomdp, parse};

/// The folder with the real benchmark files.
pub const DIR: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../data/pomdp");

pub fn path(name: &str) -> PathBuf {
    Path::new(DIR).join(name)
}

/// Every `.POMDP` / `.pomdp` file in [`DIR`], sorted by name.
pub fn real_files() -> Vec<PathBuf> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(DIR)
        .expect("the benchmark folder is readable")
        .filter_map(Result::ok)
        .map(|e| e.path())
        .filter(|p| p.extension().and_then(|e| e.to_str()).is_some_and(|e| e.eq_ignore_ascii_case("pomdp")))
        .collect();
    files.sort();
    files
}

/// Parses with the default options, panicking with the error on failure.
pub fn ok(text: &str) -> Pomdp {
    match parse(text, &Options::default()) {
        Ok(p) => p,
        Err(e) => panic!("unexpected error: {e}\n--- input ---\n{text}"),
    }
}

/// `Σ_{s',o} T O R` computed the slow way, through `Pomdp::reward`.
pub fn brute_expected_reward(p: &Pomdp) -> Vec<f64> {
    let (na, ns, no) = (p.num_actions(), p.num_states(), p.num_observations());
    let mut out = vec![0.0; na * ns];
    for a in 0..na {
        for s in 0..ns {
            let mut total = 0.0;
            for s2 in 0..ns {
                let t = p.transition_prob(a, s, s2);
                if t == 0.0 {
                    continue;
                }
                for o in 0..no {
                    total += t * p.observation_prob(a, s2, o) * p.reward(a, s, s2, o);
                }
            }
            out[a * ns + s] = total;
        }
    }
    out
}

/// Asserts two slices are equal within `eps` (relative, for large values).
pub fn assert_close(got: &[f64], want: &[f64], eps: f64) {
    assert_eq!(got.len(), want.len(), "lengths differ");
    for (i, (g, w)) in got.iter().zip(want).enumerate() {
        assert!((g - w).abs() <= eps * w.abs().max(1.0), "index {i}: got {g}, want {w}");
    }
}

/// Checks the invariants every successful parse must satisfy.
pub fn check_invariants(p: &Pomdp) {
    let (na, ns, no) = (p.num_actions(), p.num_states(), p.num_observations());
    assert!(na > 0 && ns > 0 && no > 0);
    assert_eq!(p.transition.len(), na * ns * ns);
    assert_eq!(p.observation.len(), na * ns * no);
    for row in p.transition.chunks(ns).chain(p.observation.chunks(no)) {
        let sum: f64 = row.iter().sum();
        assert!((sum - 1.0).abs() < 1e-9, "row sums to {sum}");
        assert!(row.iter().all(|&x| x >= 0.0 && x.is_finite()));
    }
    if let Some(b) = &p.start {
        assert_eq!(b.len(), ns);
        let sum: f64 = b.iter().sum();
        assert!((sum - 1.0).abs() < 1e-9, "start sums to {sum}");
    }
    for e in &p.rewards {
        assert!(e.value.is_finite());
        assert!(e.action.is_none_or(|a| a < na));
        assert!(e.state.is_none_or(|s| s < ns));
        assert!(e.next_state.is_none_or(|s| s < ns));
        assert!(e.observation.is_none_or(|o| o < no));
    }
    if let Some(d) = p.discount {
        assert!((0.0..=1.0).contains(&d));
    }
}
