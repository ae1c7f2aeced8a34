//! The engine through its public API: sampling, counting, the CE update, stopping rules,
//! determinism across thread counts, and policy files.

use ceworld::ce::budget::Budget;
use ceworld::ce::counting::count_episode;
use ceworld::episodes::run::{run_recorded, run_with};
use ceworld::rng::{EngineRng, Purpose, stream, stream_key};
use ceworld::{
    CeConfig, Error, Flow, Hhmm, Layout, PolicyFile, StopReason, TargetTracking, World, optimize, random_policy,
    uniform_policy,
};
use rand::Rng;

/// A tiny world: `horizon` steps, `n_obs` observations (always 0), decisions `0..n_decisions`,
/// and `V` = the sum of the decisions.
struct Sum {
    horizon: usize,
    n_obs: usize,
    n_decisions: usize,
}

impl World for Sum {
    type State = f64;
    fn n_observations(&self) -> usize {
        self.n_obs
    }
    fn n_decisions(&self) -> usize {
        self.n_decisions
    }
    fn horizon(&self) -> usize {
        self.horizon
    }
    fn reset(&self, _: &mut EngineRng) -> f64 {
        0.0
    }
    fn observe(&self, _: &f64, _: &mut EngineRng) -> usize {
        0
    }
    fn step(&self, s: &mut f64, d: usize, _: &mut EngineRng) {
        *s += d as f64;
    }
    fn reward(&self, s: &f64) -> f64 {
        *s
    }
    fn to_json(&self) -> serde_json::Value {
        serde_json::json!({"name": "sum"})
    }
}

fn small(samples: usize, max_iterations: usize) -> CeConfig {
    CeConfig { samples, max_iterations: Some(max_iterations), eval_episodes: 100, ..CeConfig::default() }
}

#[test]
fn counting_a_hand_made_trajectory() {
    // Λ = 2, |M_1| = 3, |M_2| = 2, Y = 2, D = 2; three steps of [y, d, m1, m2].
    let layout = Layout::new(2, 2, &[3, 2]).unwrap();
    let record: [u16; 12] = [1, 0, 2, 1, /* t=2 */ 0, 1, 0, 1, /* t=3 */ 1, 1, 2, 0];
    let mut counts = vec![0u32; layout.len];
    count_episode(&layout, &record, &mut counts);
    let t = &layout.tables;
    let at = |table: usize, index: &[usize]| {
        let s = &t[table];
        let mut flat = 0;
        for (k, &i) in index.iter().enumerate() {
            flat = flat * s.dims[k] + i;
        }
        counts[s.offset + flat]
    };
    // h0[m1][d]: (2,0), (0,1), (2,1)
    assert_eq!((at(0, &[2, 0]), at(0, &[0, 1]), at(0, &[2, 1])), (1, 1, 1));
    // h1[y][m2][m1]: (1,1,2), (0,1,0), (1,0,2)
    assert_eq!((at(1, &[1, 1, 2]), at(1, &[0, 1, 0]), at(1, &[1, 0, 2])), (1, 1, 1));
    // start2[u = 0][m2 = 1] at t = 1
    assert_eq!(at(2, &[0, 1]), 1);
    // step2[m1(t-1)][u = 0][m2(t)]: (2,0,1) at t = 2, (0,0,0) at t = 3
    assert_eq!((at(3, &[2, 0, 1]), at(3, &[0, 0, 0])), (1, 1));
    assert_eq!(counts.iter().sum::<u32>(), 3 + 3 + 1 + 2, "nothing else counted");
}

#[test]
fn top_down_sampling_follows_start_and_step_tables() {
    // [2, 2] with 1 observation, 2 decisions; t = 1 uses start2, t = 2 uses step2[m1(1)].
    let layout = Layout::new(1, 2, &[2, 2]).unwrap();
    let (h0, h1, start2, step2) = (vec![0.5; 4], vec![0.9, 0.1, 0.2, 0.8], vec![0.3, 0.7], vec![0.6, 0.4, 0.15, 0.85]);
    let probs: Vec<f64> = [h0, h1, start2, step2].concat();
    let policy = Hhmm::from_flat(layout, probs).unwrap();
    let world = Sum { horizon: 2, n_obs: 1, n_decisions: 2 };
    let n = 100_000;
    let (mut m2_first, mut pair) = (0u32, [[0u32; 2]; 2]);
    let mut m1_given_m2 = [[0u32; 2]; 2];
    for k in 0..n {
        let mut prev_m1 = 0;
        run_with(&world, &policy, &mut stream(11, Purpose::Evaluate, 0, k), |t, _, _, m, _| {
            if t == 0 {
                m2_first += m[1] as u32;
                prev_m1 = m[0] as usize;
            } else {
                pair[prev_m1][m[1] as usize] += 1;
            }
            m1_given_m2[m[1] as usize][m[0] as usize] += 1;
        });
    }
    let freq = |a: u32, b: u32| a as f64 / (a + b) as f64;
    let close = |got: f64, p: f64, count: u32| {
        let sd = (p * (1.0 - p) / count as f64).sqrt();
        assert!((got - p).abs() < 4.0 * sd, "frequency {got} vs probability {p} (4 sd = {})", 4.0 * sd);
    };
    close(m2_first as f64 / n as f64, 0.7, n as u32);
    close(freq(pair[0][1], pair[0][0]), 0.4, pair[0][0] + pair[0][1]);
    close(freq(pair[1][1], pair[1][0]), 0.85, pair[1][0] + pair[1][1]);
    close(freq(m1_given_m2[0][1], m1_given_m2[0][0]), 0.1, m1_given_m2[0][0] + m1_given_m2[0][1]);
    close(freq(m1_given_m2[1][1], m1_given_m2[1][0]), 0.8, m1_given_m2[1][0] + m1_given_m2[1][1]);
}

#[test]
fn one_ce_iteration_on_a_hand_checkable_world() {
    // V = d in {0, 1, 2}: about a third of 1000 episodes pick 2, so the best 10 % all have
    // d = 2, and basic CE (α = 1) sets h0 = [0, 0, 1].
    let world = Sum { horizon: 1, n_obs: 1, n_decisions: 3 };
    let config = CeConfig { rho: 0.1, ..small(1000, 1) };
    let r = optimize(&world, uniform_policy(&world, &[1]).unwrap(), &config, |_| Flow::Continue).unwrap();
    assert_eq!(r.last_policy.table(0), &[0.0, 0.0, 1.0]);
    assert_eq!(r.history[0].elite_threshold, 2.0);
    assert_eq!(r.history[0].best, 2.0);
    assert_eq!(r.policy, uniform_policy(&world, &[1]).unwrap(), "the best iteration's policy drew it");
    // With smoothing α = 0.5 the row is half new, half old.
    let config = CeConfig { smoothing: 0.5, ..config };
    let r = optimize(&world, uniform_policy(&world, &[1]).unwrap(), &config, |_| Flow::Continue).unwrap();
    let row = r.last_policy.table(0);
    for (got, want) in row.iter().zip([1.0 / 6.0, 1.0 / 6.0, 2.0 / 3.0]) {
        assert!((got - want).abs() < 1e-12, "{row:?}");
    }
}

#[test]
fn elite_is_the_best_ceil_rho_n_with_seeded_tie_breaks() {
    // V = d in {0, 1}: ties everywhere. The elite (ceil(0.3 * 10) = 3) must be 3 episodes of
    // the best reward when at least 3 have it, and the same on every run.
    let world = Sum { horizon: 1, n_obs: 1, n_decisions: 2 };
    let config = CeConfig { rho: 0.3, ..small(10, 1) };
    let run = || optimize(&world, uniform_policy(&world, &[1]).unwrap(), &config, |_| Flow::Continue).unwrap();
    let (a, b) = (run(), run());
    assert_eq!(a.last_policy, b.last_policy);
    assert_eq!(a.history[0].elite_threshold, 1.0);
    assert_eq!(a.last_policy.table(0), &[0.0, 1.0]);
}

#[test]
fn rows_without_counts_keep_their_values() {
    // Two observations, but the world only ever emits 0: h1's row for y = 1 is never counted.
    let world = Sum { horizon: 3, n_obs: 2, n_decisions: 2 };
    let initial = random_policy(&world, &[3], 9).unwrap();
    let r = optimize(&world, initial.clone(), &small(50, 2), |_| Flow::Continue).unwrap();
    let row_y1 = |h: &Hhmm| h.table(1)[3..6].to_vec();
    assert_eq!(row_y1(&r.last_policy), row_y1(&initial));
    assert_ne!(r.last_policy.table(1)[..3], initial.table(1)[..3]);
}

#[test]
fn stopping_rules() {
    let world = Sum { horizon: 2, n_obs: 1, n_decisions: 2 };
    let start = || uniform_policy(&world, &[1]).unwrap();
    // Converges at once to V = 2 every time: the mean stops improving, so patience 3 stops it.
    let config = CeConfig { patience: 3, max_iterations: None, ..small(200, 1) };
    let r = optimize(&world, start(), &config, |_| Flow::Continue).unwrap();
    assert_eq!(r.stop, StopReason::Patience);
    let last_success = r.history.iter().rposition(|h| h.successful).unwrap();
    assert_eq!(r.history.len(), last_success + 1 + 3);
    assert_eq!(r.best_iteration, last_success);
    let r = optimize(&world, start(), &small(200, 2), |_| Flow::Continue).unwrap();
    assert_eq!((r.stop, r.history.len()), (StopReason::MaxIterations, 2));
    let config = CeConfig { target: Some(1.5), max_iterations: None, ..small(200, 1) };
    let r = optimize(&world, start(), &config, |_| Flow::Continue).unwrap();
    assert_eq!(r.stop, StopReason::Target);
    assert!(r.history.last().unwrap().mean >= 1.5);
    let config = CeConfig { budget: Budget::seconds(1e-9), max_iterations: None, ..small(200, 1) };
    assert_eq!(optimize(&world, start(), &config, |_| Flow::Continue).unwrap().stop, StopReason::TimeLimit);
    let mut calls = 0;
    let r = optimize(&world, start(), &CeConfig { max_iterations: None, ..small(200, 1) }, |_| {
        calls += 1;
        if calls == 2 { Flow::Stop } else { Flow::Continue }
    })
    .unwrap();
    assert!(r.interrupted());
    assert_eq!(r.history.len(), 2);
}

#[test]
fn bad_settings_are_refused_by_name() {
    let world = TargetTracking::new(3).unwrap();
    let start = uniform_policy(&world, &[4]).unwrap();
    for (config, name) in [
        (CeConfig { rho: 0.0, ..CeConfig::default() }, "rho"),
        (CeConfig { rho: 1.0, ..CeConfig::default() }, "rho"),
        (CeConfig { rho: 1.5, ..CeConfig::default() }, "rho"),
        (CeConfig { samples: 0, ..CeConfig::default() }, "samples"),
        (CeConfig { smoothing: 0.0, ..CeConfig::default() }, "smoothing"),
        (CeConfig { patience: 0, ..CeConfig::default() }, "patience"),
        (CeConfig { threads: Some(0), ..CeConfig::default() }, "threads"),
        (CeConfig { threads: Some(1_000_000), ..CeConfig::default() }, "threads"),
    ] {
        match optimize(&world, start.clone(), &config, |_| Flow::Continue) {
            Err(Error::InvalidArgument { name: got, .. }) => assert_eq!(got, name),
            other => panic!("{name}: expected an InvalidArgument error, got {other:?}"),
        }
    }
    let blind = TargetTracking::new(2).unwrap();
    let e = optimize(&blind, start, &CeConfig::default(), |_| Flow::Continue).unwrap_err();
    assert!(matches!(e, Error::Mismatch(_)), "{e}");
}

fn tracking_run(threads: usize) -> (PolicyFile, Vec<(f64, f64, f64, f64)>) {
    let world = TargetTracking::new(3).unwrap();
    let config = CeConfig { threads: Some(threads), seed: 5, ..small(300, 4) };
    let r = optimize(&world, uniform_policy(&world, &[4, 3]).unwrap(), &config, |_| Flow::Continue).unwrap();
    let history = r.history.iter().map(|h| (h.mean, h.best, h.elite_threshold, h.elite_mean)).collect();
    (r.to_file(&world, &config), history)
}

#[test]
fn same_seed_gives_identical_files_with_1_and_2_threads() {
    let (one, h1) = tracking_run(1);
    let (two, h2) = tracking_run(2);
    assert_eq!(h1, h2);
    assert_eq!(one.to_json().to_string(), two.to_json().to_string());
    let (other_seed, ()) = {
        let world = TargetTracking::new(3).unwrap();
        let config = CeConfig { threads: Some(2), seed: 6, ..small(300, 4) };
        let r = optimize(&world, uniform_policy(&world, &[4, 3]).unwrap(), &config, |_| Flow::Continue).unwrap();
        (r.to_file(&world, &config), ())
    };
    assert_ne!(one.policy, other_seed.policy);
}

#[test]
fn policy_file_round_trip() {
    let (file, _) = tracking_run(2);
    let dir = std::env::temp_dir().join(format!("ceworld-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("p.json");
    file.save(&path).unwrap();
    let back = PolicyFile::load(&path).unwrap();
    assert!(back == file, "tables, world and provenance must come back bit-identical");
    // Streamed to disk, the file is the document's JSON text, its keys in order.
    let text = std::fs::read_to_string(&path).unwrap();
    assert_eq!(text, file.to_json().to_string());
    assert_eq!(text, file.to_text());
    assert!(
        text.starts_with(r#"{"format":"cehmm-policy","levels":[4,3],"n_actions":16,"n_obs":16,"policy":{"h0":[["#),
        "{}",
        &text[..80]
    );
    let world = TargetTracking::from_json(&back.world).unwrap();
    assert_eq!(world, TargetTracking::new(3).unwrap());
    std::fs::remove_dir_all(dir).ok();
}

fn rejection(edit: impl FnOnce(&mut serde_json::Value)) -> String {
    let world = TargetTracking::new(3).unwrap();
    let file = PolicyFile {
        policy: uniform_policy(&world, &[3, 2]).unwrap(),
        world: world.to_json(),
        provenance: serde_json::json!({}),
    };
    let mut doc = file.to_json();
    edit(&mut doc);
    PolicyFile::from_json(&doc).unwrap_err().to_string()
}

#[test]
fn bad_policy_files_are_refused_clearly() {
    let e = rejection(|d| d["policy"]["h0"][1] = serde_json::json!([0.5, 0.5]));
    assert!(e.contains("policy.h0[1] has length 2 (expected 16)"), "{e}");
    let e = rejection(|d| {
        d["policy"]["upper"][0]["step"][2][0] = serde_json::json!([1.5, -0.5]);
    });
    assert!(e.contains("upper[0].step[2][0][1] = -0.5"), "{e}");
    let e = rejection(|d| d["policy"]["h1"][4][1][0] = serde_json::json!(0.9));
    assert!(e.contains("h1[4][1]") && e.contains("sums to"), "{e}");
    let e = rejection(|d| d["format"] = serde_json::json!("other"));
    assert!(e.contains("format"), "{e}");
    let e = rejection(|d| d["policy"]["upper"] = serde_json::json!([]));
    assert!(e.contains("policy.upper has 0 entries (expected 1"), "{e}");
    let e = rejection(|d| d["levels"] = serde_json::json!([3, 0]));
    assert!(e.contains("size 0"), "{e}");
    // unknown keys are ignored
    let world = TargetTracking::new(3).unwrap();
    let file = PolicyFile {
        policy: uniform_policy(&world, &[2]).unwrap(),
        world: world.to_json(),
        provenance: serde_json::json!({}),
    };
    let mut doc = file.to_json();
    doc["comment"] = serde_json::json!("hello");
    doc["policy"]["extra"] = serde_json::json!(1);
    assert_eq!(PolicyFile::from_json(&doc).unwrap(), file);
}

#[test]
fn a_clock_policy_counts_the_steps_and_survives_ce_updates() {
    let world = Sum { horizon: 7, n_obs: 2, n_decisions: 3 };
    let clock = ceworld::clock_policy(&world, &[5, 5]).unwrap();
    let check = |policy: &Hhmm| {
        run_with(&world, policy, &mut stream(3, Purpose::Evaluate, 0, 0), |t, _, _, m, _| {
            assert_eq!((m[0] as usize, m[1] as usize), (t % 5, t % 5), "step {t}");
        });
    };
    check(&clock);
    // V = sum of decisions: CE learns "always 2" in h0 while the clock stays a clock.
    let r = optimize(&world, clock, &small(500, 5), |_| Flow::Continue).unwrap();
    check(&r.last_policy);
    assert!(r.last_policy.table(0).chunks(3).all(|row| row[2] > 0.9), "{:?}", r.last_policy.table(0));
    assert!(ceworld::clock_policy(&world, &[5, 4]).is_err());
    assert!(ceworld::clock_policy(&world, &[5]).is_err());
}

#[test]
fn forward_backward_update_is_thread_count_independent_and_refused_above_two_levels() {
    let world = TargetTracking::new(3).unwrap();
    let run = |threads| {
        let config =
            CeConfig { threads: Some(threads), memory_update: ceworld::MemoryUpdate::ForwardBackward, ..small(200, 3) };
        optimize(&world, random_policy(&world, &[4, 3], 1).unwrap(), &config, |_| Flow::Continue).unwrap()
    };
    assert!(run(1).last_policy == run(2).last_policy);
    let config = CeConfig { memory_update: ceworld::MemoryUpdate::ForwardBackward, ..small(200, 3) };
    let e = optimize(&world, uniform_policy(&world, &[4, 2, 2]).unwrap(), &config, |_| Flow::Continue).unwrap_err();
    assert!(e.to_string().contains("at most 2 levels"), "{e}");
}

#[test]
fn restarts_return_the_best_run_on_selection_episodes() {
    let world = TargetTracking::new(3).unwrap();
    let start = || uniform_policy(&world, &[4]).unwrap();
    let one = optimize(&world, start(), &small(200, 3), |_| Flow::Continue).unwrap();
    let config = CeConfig { restarts: 3, ..small(200, 3) };
    let mut runs = 0;
    let best = optimize(&world, start(), &config, |r| {
        runs += (r.iteration == 0) as usize;
        Flow::Continue
    })
    .unwrap();
    assert_eq!(runs, 3);
    assert!(best.restart < 3);
    if best.restart == 0 {
        assert!(best.policy == one.policy, "restart 0 is the run with the given seed");
    }
    let score = |p: &Hhmm| ceworld::evaluate::selection_mean(&world, p, 100, 0).unwrap();
    // The chosen run scores at least as well as the plain run on the selection episodes.
    assert!(score(&best.policy) >= score(&one.policy));
    let two_threads = optimize(&world, start(), &CeConfig { threads: Some(2), ..config.clone() }, |_| Flow::Continue);
    let one_thread = optimize(&world, start(), &CeConfig { threads: Some(1), ..config }, |_| Flow::Continue);
    assert!(two_threads.unwrap().policy == one_thread.unwrap().policy);
    let e = optimize(&world, start(), &CeConfig { restarts: 0, ..small(200, 3) }, |_| Flow::Continue).unwrap_err();
    assert!(e.to_string().contains("restarts"), "{e}");
}

/// A world whose reward is one uniform draw in [0, 1) made at reset: N episodes give N
/// distinct rewards, whatever the policy, and the test can recompute them.
struct Noise;

impl World for Noise {
    type State = f64;
    fn n_observations(&self) -> usize {
        1
    }
    fn n_decisions(&self) -> usize {
        2
    }
    fn horizon(&self) -> usize {
        1
    }
    fn reset(&self, rng: &mut EngineRng) -> f64 {
        (rng.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }
    fn observe(&self, _: &f64, _: &mut EngineRng) -> usize {
        0
    }
    fn step(&self, _: &mut f64, _: usize, _: &mut EngineRng) {}
    fn reward(&self, s: &f64) -> f64 {
        *s
    }
    fn to_json(&self) -> serde_json::Value {
        serde_json::json!({"name": "noise"})
    }
}

#[test]
fn elite_size_is_ceil_rho_n() {
    for (samples, rho, elite) in [(10, 0.5, 5), (10, 0.25, 3), (8, 0.5, 4), (7, 0.1, 1), (10, 0.9, 9), (1000, 0.1, 100)]
    {
        let config = CeConfig { rho, ..small(samples, 1) };
        assert_eq!(config.elite_count(), elite, "N = {samples}, rho = {rho}");
        // The first iteration's elite, recomputed from the same episode streams.
        let policy = uniform_policy(&Noise, &[1]).unwrap();
        let r = optimize(&Noise, policy.clone(), &config, |_| Flow::Continue).unwrap();
        let mut rewards: Vec<f64> = (0..samples as u64)
            .map(|k| run_with(&Noise, &policy, &mut stream(config.seed, Purpose::Optimise, 0, k), |_, _, _, _, _| {}))
            .collect();
        // The iteration's mean sums the rewards in episode order.
        let mean = rewards.iter().sum::<f64>() / samples as f64;
        rewards.sort_by(|a, b| b.total_cmp(a));
        let h = &r.history[0];
        assert_eq!(h.elite_threshold, rewards[elite - 1], "N = {samples}, rho = {rho}");
        let elite_mean = rewards[..elite].iter().sum::<f64>() / elite as f64;
        assert!((h.elite_mean - elite_mean).abs() < 1e-12, "N = {samples}, rho = {rho}");
        assert_eq!(h.best, rewards[0]);
        assert_eq!(h.mean, mean);
    }
}

/// The count at `index` (one index per axis) of table `table`.
fn count_at(layout: &Layout, counts: &[u32], table: usize, index: &[usize]) -> u32 {
    let s = &layout.tables[table];
    assert_eq!(index.len(), s.dims.len());
    let flat = index.iter().zip(&s.dims).fold(0, |flat, (&i, &d)| {
        assert!(i < d);
        flat * d + i
    });
    counts[s.offset + flat]
}

#[test]
fn counting_three_levels_by_hand() {
    // Λ = 3, levels [2, 3, 2], Y = 2, D = 2. Level 2 is conditioned on m3 (its upper level),
    // level 3 (the top) on nothing above it.
    let layout = Layout::new(2, 2, &[2, 3, 2]).unwrap();
    // [y, d, m1, m2, m3] at t = 1, 2, 3
    let record: [u16; 15] = [1, 0, 1, 2, 1, /* t=2 */ 0, 1, 0, 1, 0, /* t=3 */ 1, 1, 1, 0, 1];
    let mut counts = vec![0u32; layout.len];
    count_episode(&layout, &record, &mut counts);
    let at = |table, index: &[usize]| count_at(&layout, &counts, table, index);
    // h0[m1][d]
    assert_eq!([at(0, &[1, 0]), at(0, &[0, 1]), at(0, &[1, 1])], [1, 1, 1]);
    // h1[y][m2][m1]
    assert_eq!([at(1, &[1, 2, 1]), at(1, &[0, 1, 0]), at(1, &[1, 0, 1])], [1, 1, 1]);
    // upper[0].start[m3][m2] at t = 1: conditioned on m3 = 1
    assert_eq!(at(2, &[1, 2]), 1);
    // upper[0].step[m1(t-1)][m3(t)][m2(t)]: (1, 0, 1) at t = 2, (0, 1, 0) at t = 3
    assert_eq!([at(3, &[1, 0, 1]), at(3, &[0, 1, 0])], [1, 1]);
    // upper[1].start[0][m3] at t = 1
    assert_eq!(at(4, &[0, 1]), 1);
    // upper[1].step[m2(t-1)][0][m3(t)]: (2, 0, 0) at t = 2, (1, 0, 1) at t = 3
    assert_eq!([at(5, &[2, 0, 0]), at(5, &[1, 0, 1])], [1, 1]);
    assert_eq!(counts.iter().sum::<u32>(), 3 + 3 + 1 + 2 + 1 + 2, "nothing else counted");
}

#[test]
fn counting_four_levels_by_hand() {
    // Λ = 4, levels [2, 3, 2, 2], Y = 1, D = 2: level l is conditioned on m_{l+1} below the top.
    let layout = Layout::new(1, 2, &[2, 3, 2, 2]).unwrap();
    // [y, d, m1, m2, m3, m4] at t = 1, 2
    let record: [u16; 12] = [0, 1, 1, 2, 0, 1, /* t=2 */ 0, 0, 0, 1, 1, 0];
    let mut counts = vec![0u32; layout.len];
    count_episode(&layout, &record, &mut counts);
    let at = |table, index: &[usize]| count_at(&layout, &counts, table, index);
    assert_eq!([at(0, &[1, 1]), at(0, &[0, 0])], [1, 1]);
    assert_eq!([at(1, &[0, 2, 1]), at(1, &[0, 1, 0])], [1, 1]);
    // level 2 on m3: start[m3 = 0][m2 = 2]; step[m1(1) = 1][m3(2) = 1][m2(2) = 1]
    assert_eq!([at(2, &[0, 2]), at(3, &[1, 1, 1])], [1, 1]);
    // level 3 on m4: start[m4 = 1][m3 = 0]; step[m2(1) = 2][m4(2) = 0][m3(2) = 1]
    assert_eq!([at(4, &[1, 0]), at(5, &[2, 0, 1])], [1, 1]);
    // level 4, the top: start[0][m4 = 1]; step[m3(1) = 0][0][m4(2) = 0]
    assert_eq!([at(6, &[0, 1]), at(7, &[0, 0, 0])], [1, 1]);
    assert_eq!(counts.iter().sum::<u32>(), 2 + 2 + 3 * 2, "nothing else counted");
}

/// `close(got, p, n)`: a frequency over `n` draws within 4 standard deviations of `p`.
fn close(got: u32, n: u32, p: f64) {
    let f = got as f64 / n as f64;
    let sd = (p * (1.0 - p) / n as f64).sqrt();
    assert!((f - p).abs() < 4.0 * sd, "frequency {f} over {n} vs probability {p} (4 sd = {})", 4.0 * sd);
}

#[test]
fn three_level_sampling_follows_the_upper_condition() {
    // Λ = 3, levels [2, 2, 2], Y = 1, D = 2, two steps. Level 2's rows depend strongly on m3.
    let layout = Layout::new(1, 2, &[2, 2, 2]).unwrap();
    let h0 = vec![0.5; 4];
    let h1 = vec![0.8, 0.2, 0.35, 0.65]; // h1[0][m2][m1]
    let start2 = vec![0.9, 0.1, 0.2, 0.8]; // upper[0].start[m3][m2]
    let step2 = vec![0.7, 0.3, 0.1, 0.9, 0.6, 0.4, 0.25, 0.75]; // upper[0].step[m1][m3][m2]
    let start3 = vec![0.4, 0.6]; // upper[1].start[0][m3]
    let step3 = vec![0.5, 0.5, 0.3, 0.7]; // upper[1].step[m2][0][m3]
    let policy = Hhmm::from_flat(layout, [h0, h1, start2, step2, start3, step3].concat()).unwrap();
    let world = Sum { horizon: 2, n_obs: 1, n_decisions: 2 };
    // [condition][outcome] tallies
    let (mut m3_first, mut m2_first) = ([0u32; 2], [[0u32; 2]; 2]);
    let (mut m3_next, mut m2_next) = ([[0u32; 2]; 2], [[[0u32; 2]; 2]; 2]);
    let mut m1_given_m2 = [[0u32; 2]; 2];
    for k in 0..100_000 {
        let mut previous = [0usize; 3];
        run_with(&world, &policy, &mut stream(12, Purpose::Evaluate, 0, k), |t, _, _, m, _| {
            let (m1, m2, m3) = (m[0] as usize, m[1] as usize, m[2] as usize);
            if t == 0 {
                m3_first[m3] += 1;
                m2_first[m3][m2] += 1;
            } else {
                m3_next[previous[1]][m3] += 1;
                m2_next[previous[0]][m3][m2] += 1;
            }
            m1_given_m2[m2][m1] += 1;
            previous = [m1, m2, m3];
        });
    }
    let total = |row: [u32; 2]| row[0] + row[1];
    close(m3_first[1], total(m3_first), 0.6);
    close(m2_first[0][1], total(m2_first[0]), 0.1);
    close(m2_first[1][1], total(m2_first[1]), 0.8);
    close(m3_next[0][1], total(m3_next[0]), 0.5);
    close(m3_next[1][1], total(m3_next[1]), 0.7);
    for (m1, m3, p) in [(0, 0, 0.3), (0, 1, 0.9), (1, 0, 0.4), (1, 1, 0.75)] {
        close(m2_next[m1][m3][1], total(m2_next[m1][m3]), p);
    }
    close(m1_given_m2[0][1], total(m1_given_m2[0]), 0.2);
    close(m1_given_m2[1][1], total(m1_given_m2[1]), 0.65);
}

/// Rewards the plan "decision `t mod D` at step `t`": `V` counts the steps that follow it. No
/// observation helps, so only a memory that counts time can follow it.
struct Plan {
    horizon: usize,
    n_decisions: usize,
}

impl World for Plan {
    type State = (usize, u32);
    fn n_observations(&self) -> usize {
        1
    }
    fn n_decisions(&self) -> usize {
        self.n_decisions
    }
    fn horizon(&self) -> usize {
        self.horizon
    }
    fn reset(&self, _: &mut EngineRng) -> (usize, u32) {
        (0, 0)
    }
    fn observe(&self, _: &(usize, u32), _: &mut EngineRng) -> usize {
        0
    }
    fn step(&self, s: &mut (usize, u32), d: usize, _: &mut EngineRng) {
        s.1 += (d == s.0 % self.n_decisions) as u32;
        s.0 += 1;
    }
    fn reward(&self, s: &(usize, u32)) -> f64 {
        s.1 as f64
    }
    fn to_json(&self) -> serde_json::Value {
        serde_json::json!({"name": "plan"})
    }
}

#[test]
fn a_clock_policy_learns_a_time_indexed_plan() {
    let world = Plan { horizon: 6, n_decisions: 3 };
    let config = CeConfig { rho: 0.1, ..small(1000, 10) };
    let r = optimize(&world, ceworld::clock_policy(&world, &[6, 6]).unwrap(), &config, |_| Flow::Continue).unwrap();
    // h0[t] puts (almost) all its mass on decision t mod 3, and the plan is followed.
    for (t, row) in r.policy.table(0).chunks(3).enumerate() {
        assert!(row[t % 3] > 0.9, "h0[{t}] = {row:?}");
    }
    assert!(r.evaluation.mean > 5.5, "{}", r.evaluation.mean);
    // Without memory the best is 2 of 6 (one decision for every step).
    let memoryless = optimize(&world, uniform_policy(&world, &[1]).unwrap(), &config, |_| Flow::Continue).unwrap();
    assert!(memoryless.evaluation.mean <= 2.0 + 1e-9, "{}", memoryless.evaluation.mean);
}

#[test]
fn restarts_choose_the_run_that_scores_best_on_selection_episodes() {
    // Each restart reconstructed by hand from its documented seed: the returned policy is the
    // one of the run with the highest selection mean.
    let world = TargetTracking::new(3).unwrap();
    let start = || uniform_policy(&world, &[4]).unwrap();
    let base = small(200, 3);
    let runs: Vec<(f64, Hhmm)> = (0..4u64)
        .map(|restart| {
            let seed = if restart == 0 { base.seed } else { stream_key(base.seed, Purpose::Restart, restart, 0) };
            let r = optimize(&world, start(), &CeConfig { seed, ..base.clone() }, |_| Flow::Continue).unwrap();
            (ceworld::evaluate::selection_mean(&world, &r.policy, base.eval_episodes, base.seed).unwrap(), r.policy)
        })
        .collect();
    let best = (0..4).max_by(|&a, &b| runs[a].0.total_cmp(&runs[b].0)).unwrap();
    let worst = (0..4).min_by(|&a, &b| runs[a].0.total_cmp(&runs[b].0)).unwrap();
    assert!(runs[best].0 > runs[worst].0, "the runs must differ for the test to mean anything");
    let chosen = optimize(&world, start(), &CeConfig { restarts: 4, ..base.clone() }, |_| Flow::Continue).unwrap();
    assert_eq!(chosen.restart, best);
    assert_eq!(chosen.restart_scores, runs.iter().map(|r| r.0).collect::<Vec<_>>());
    assert!(chosen.policy == runs[best].1);
}

#[test]
fn recorded_episodes_match_visited_episodes_at_every_depth() {
    // The optimiser samples through `run_recorded`, evaluation and rollouts through `run_with`:
    // the same stream must give the same episode, step by step, whatever the number of levels.
    let world = TargetTracking::with_params(ceworld::TrackingParams { horizon: 30, ..Default::default() }).unwrap();
    for levels in [vec![3], vec![3, 2], vec![3, 2, 2], vec![2, 3, 2, 2]] {
        let policy = random_policy(&world, &levels, 4).unwrap();
        let width = policy.layout().record_width();
        for k in 0..20 {
            let mut record = vec![0u16; 30 * width];
            let recorded = run_recorded(&world, &policy, &mut stream(2, Purpose::Optimise, 0, k), &mut record);
            let mut visited = Vec::new();
            let reward = run_with(&world, &policy, &mut stream(2, Purpose::Optimise, 0, k), |_, y, d, m, _| {
                visited.extend([y as u16, d as u16]);
                visited.extend_from_slice(m);
            });
            assert_eq!((recorded, &record), ((reward, 30), &visited), "levels {levels:?}, episode {k}");
        }
    }
}

#[test]
fn restarts_share_the_time_limit_stop_on_interruption_and_keep_the_first_of_equal_scores() {
    let world = Sum { horizon: 2, n_obs: 1, n_decisions: 2 };
    let start = || uniform_policy(&world, &[1]).unwrap();
    let runs_of = |config: &CeConfig, stop_at: Option<usize>| {
        let (mut runs, mut calls) = (0, 0);
        let r = optimize(&world, start(), config, |record| {
            runs += (record.iteration == 0) as usize;
            calls += 1;
            if Some(calls) == stop_at { Flow::Stop } else { Flow::Continue }
        })
        .unwrap();
        (r, runs)
    };
    let config = CeConfig { restarts: 3, ..small(200, 3) };
    // A generous limit lets every run happen; a spent one stops after the first.
    let (_, runs) = runs_of(&CeConfig { budget: Budget::seconds(600.0), ..config.clone() }, None);
    assert_eq!(runs, 3);
    let (r, runs) = runs_of(&CeConfig { budget: Budget::seconds(1e-9), max_iterations: None, ..config.clone() }, None);
    assert_eq!((runs, r.history.len(), r.stop), (1, 1, StopReason::TimeLimit));
    // Ctrl-C during the second run: no third run, and the result says interrupted.
    let (r, runs) = runs_of(&config, Some(4));
    assert_eq!(runs, 2);
    assert!(r.interrupted());
    // Every run converges to "always 1" (V = 2): equal scores, so the first run is kept.
    let (r, _) = runs_of(&CeConfig { max_iterations: Some(5), ..config }, None);
    assert_eq!(r.restart_scores, vec![2.0; 3]);
    assert_eq!(r.restart, 0);
}

#[test]
fn forward_backward_counts_equal_sampled_counts_when_the_memory_is_determined() {
    // A clock's memory is one-hot given the step, so its posterior is the sampled memory: one
    // forward–backward iteration (elite of 250 episodes, several blocks of 32) must give the
    // tables of one sampled iteration, whatever the thread count.
    let world = Plan { horizon: 6, n_decisions: 3 };
    let run = |memory_update, threads| {
        let config = CeConfig { memory_update, threads: Some(threads), ..small(500, 1) };
        optimize(&world, ceworld::clock_policy(&world, &[6, 6]).unwrap(), &config, |_| Flow::Continue).unwrap()
    };
    let sampled = run(ceworld::MemoryUpdate::Sampled, 1).last_policy;
    for threads in [1, 2] {
        let posterior = run(ceworld::MemoryUpdate::ForwardBackward, threads).last_policy;
        for (a, b) in sampled.probs().iter().zip(posterior.probs()) {
            assert!((a - b).abs() < 1e-12, "{a} vs {b}");
        }
    }
    assert_ne!(sampled.table(0), ceworld::clock_policy(&world, &[6, 6]).unwrap().table(0), "the update changed h0");
}

#[test]
fn a_world_describes_nothing_unless_it_says_so() {
    let world = Sum { horizon: 1, n_obs: 1, n_decisions: 2 };
    assert!(world.state_labels().is_empty());
    let mut out = vec![7];
    world.describe(&1.0, &mut out);
    assert_eq!(out, [7]);
}

#[test]
fn the_time_limit_holds_the_final_evaluation_too() {
    // Ten million evaluation episodes of 300 steps take minutes: inside a 1 s time limit the
    // iterations stop early enough for an evaluation cut at the limit, with fewer episodes,
    // and the run is not marked interrupted (with restarts too: each run's score as well).
    let world = Sum { horizon: 300, n_obs: 1, n_decisions: 2 };
    for restarts in [1, 2] {
        let config = CeConfig {
            samples: 100,
            budget: Budget::seconds(1.0),
            max_iterations: None,
            patience: 1_000_000,
            eval_episodes: 10_000_000,
            restarts,
            ..CeConfig::default()
        };
        let clock = std::time::Instant::now();
        let r = optimize(&world, uniform_policy(&world, &[2]).unwrap(), &config, |_| Flow::Continue).unwrap();
        let wall = clock.elapsed().as_secs_f64();
        assert_eq!(r.stop, StopReason::TimeLimit, "restarts {restarts}");
        assert!(r.evaluation.episodes > 0 && r.evaluation.episodes < 10_000_000, "{:?}", r.evaluation);
        // The limit, and what one slice of the evaluation past it takes on a loaded machine.
        assert!(wall < 1.5 && r.seconds < 1.5, "restarts {restarts}: {wall} s, {} s", r.seconds);
    }
}
