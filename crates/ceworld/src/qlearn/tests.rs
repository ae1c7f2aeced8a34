//! Unit tests of Q-learning.

#[path = "../../tests/common/temp.rs"]
mod temp;

use crate::error::Result;
use rand::Rng;
use serde_json::json;

use super::AnyLearner;
use super::CHUNK;
use super::ContinuingWorld;
use super::FORMAT;
use super::GAMMA;
use super::Greedy;
use super::KnownState;
use super::QConfig;
use super::QLearner;
use super::QTable;
use super::Ties;
use super::WindowConfig;
use super::check_memory;
use super::epsilon;
use super::evaluate_windows;
use super::percent;
use super::read_header;
use super::table_bytes;
use crate::control::Flow;
use crate::error::Error;
use crate::evaluate::Evaluation;
use crate::policy::Hhmm;
use crate::rng::EngineRng;
use crate::rng::Purpose;
use crate::rng::stream;
use crate::world::World;
use crate::world::tracking::Mobile;
use crate::world::tracking::TargetTracking;
use crate::world::tracking::TrackingParams;
use crate::world::tracking::TrackingState;
use serde_json::Value;

/// A two-state cycle 0 → 1 → 0 → ... with one observation, `D` decisions that do not
/// matter, and reward 1 for every step taken from state 1: the Q-learning updates can be
/// worked out by hand.
struct Cycle {
    decisions: usize,
}

impl World for Cycle {
    type State = u8;
    fn n_observations(&self) -> usize {
        1
    }
    fn n_decisions(&self) -> usize {
        self.decisions
    }
    fn horizon(&self) -> usize {
        4
    }
    fn reset(&self, _: &mut EngineRng) -> u8 {
        0
    }
    fn observe(&self, _: &u8, _: &mut EngineRng) -> usize {
        0
    }
    fn step(&self, s: &mut u8, _: usize, _: &mut EngineRng) {
        *s = 1 - *s;
    }
    fn reward(&self, _: &u8) -> f64 {
        0.0
    }
    fn describe(&self, s: &u8, out: &mut Vec<i64>) {
        out.push(*s as i64);
    }
    fn to_json(&self) -> Value {
        json!({ "name": "cycle", "decisions": self.decisions })
    }
}

impl ContinuingWorld for Cycle {
    fn step_reward(&self, s: &mut u8, d: usize, rng: &mut EngineRng) -> f64 {
        let reward = *s as f64;
        self.step(s, d, rng);
        reward
    }
}

impl KnownState for Cycle {
    fn n_states(&self) -> Result<usize> {
        Ok(2)
    }
    fn known_state(&self, s: &u8, _: usize) -> usize {
        *s as usize
    }
    fn restore(&self, v: &[i64]) -> Result<u8> {
        Ok(v[0] as u8)
    }
}

/// A 5 × 5 tracking world small enough to learn in a test (also the run spine's tests').
pub(crate) fn small_world() -> TargetTracking {
    TargetTracking::with_params(TrackingParams {
        width: 5,
        height: 5,
        start_b: [0, 4],
        start_c: [4, 4],
        target_rows: [0, 2],
        target_cell: [2, 2],
        ..TrackingParams::default()
    })
    .unwrap()
}

fn temp(name: &str) -> temp::TempPath {
    temp::TempPath::new("ceworld-qlearn", name)
}

#[test]
fn update_rule_by_hand_on_a_two_state_cycle() {
    // One decision: ε does not matter. With α = 0.1, γ = 0.99, from Q = 0:
    // t=1, s=0 → 1, r=0: Q(0) = 0 + 0.1 (0 + 0.99·0 − 0)            = 0
    // t=2, s=1 → 0, r=1: Q(1) = 0 + 0.1 (1 + 0.99·0 − 0)            = 0.1
    // t=3, s=0 → 1, r=0: Q(0) = 0 + 0.1 (0 + 0.99·0.1 − 0)          = 0.0099
    // t=4, s=1 → 0, r=1: Q(1) = 0.1 + 0.1 (1 + 0.99·0.0099 − 0.1)   = 0.1909801
    let mut learner = QLearner::new(Cycle { decisions: 1 }, QConfig::default()).unwrap();
    let expected = [[0.0, 0.0], [0.0, 0.1], [0.0099, 0.1], [0.0099, 0.190_980_1]];
    for (t, want) in expected.iter().enumerate() {
        let stats = learner.run(1);
        assert_eq!(stats.reward, (t % 2) as f64);
        let q = learner.table().values();
        assert!((q[0] as f64 - want[0]).abs() < 1e-7 && (q[1] as f64 - want[1]).abs() < 1e-7, "t={}: {q:?}", t + 1);
    }
    assert_eq!(learner.updates(), 4);
    assert_eq!(learner.reward_total(), 2.0);
}

#[test]
fn update_rule_on_given_values() {
    let mut table = QTable::zeros(3, 4).unwrap();
    table.values_mut().copy_from_slice(&[
        1.0, 2.0, 3.0, 4.0, //
        0.5, 2.0, 2.0, -1.0, //
        0.0, 0.0, 0.0, 0.0,
    ]);
    // Q(0, 2) = 3 + 0.5 (1 + 0.9·2 − 3) = 2.9; max of row 1 is 2, first reached at action 1.
    let max = table.update(0, 2, 1.0, 1, 0.5, 0.9);
    assert_eq!(max, 2.0);
    assert!((table.row(0)[2] - 2.9).abs() < 1e-6);
    assert_eq!(table.row(1), &[0.5, 2.0, 2.0, -1.0], "only Q(s, a) changes");
    assert_eq!(table.greedy(2), 0, "ties go to the lowest index");
    assert_eq!(table.greedy(0), 3);
    assert_eq!(table.greedy_with(1, Ties::Lowest, || panic!("no draw")), 1);
    assert_eq!(table.greedy_with(0, Ties::Random, || panic!("no draw without a tie")), 3);
    // Row 1 ties actions 1 and 2: the high half of the 32 bits picks the second.
    assert_eq!(table.greedy_with(1, Ties::Random, || 0x7fff_ffff), 1);
    assert_eq!(table.greedy_with(1, Ties::Random, || 0x8000_0000), 2);
    let mut counts = [0usize; 4];
    let mut rng = stream(0, Purpose::Evaluate, 0, 0);
    for _ in 0..40_000 {
        counts[table.greedy_with(2, Ties::Random, || (rng.next_u64() >> 32) as u32)] += 1;
    }
    assert!(counts.iter().all(|&c| (9_400..10_600).contains(&c)), "uniform among the four ties: {counts:?}");
}

#[test]
fn epsilon_schedule() {
    assert_eq!(epsilon(1), 1.0);
    assert_eq!(epsilon(2), 1.0, "1/ln 2 = 1.44 is capped at 1");
    assert!((epsilon(3) - 1.0 / 3f64.ln()).abs() < 1e-15);
    assert!((epsilon(1_000_000_000) - 0.048_254).abs() < 1e-6);
    let mut previous = 1.0;
    for t in (1..2_000_000u64).step_by(997) {
        let e = epsilon(t);
        assert!(e <= previous && e > 0.0 && e <= 1.0);
        assert!((e - (1.0 / (t as f64).ln()).min(1.0)).abs() < 1e-15);
        previous = e;
    }
}

/// One state, no reward, four decisions: Q stays 0, so with lowest-index ties the greedy
/// decision is always 0 and every other one comes from exploration, with probability (`3/4)·ε_t`.
struct Explorer {
    explored: std::sync::atomic::AtomicU64,
}

impl World for Explorer {
    type State = ();
    fn n_observations(&self) -> usize {
        1
    }
    fn n_decisions(&self) -> usize {
        4
    }
    fn horizon(&self) -> usize {
        1
    }
    fn reset(&self, _: &mut EngineRng) {}
    fn observe(&self, (): &(), _: &mut EngineRng) -> usize {
        0
    }
    fn step(&self, (): &mut (), d: usize, _: &mut EngineRng) {
        if d != 0 {
            self.explored.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        }
    }
    fn reward(&self, (): &()) -> f64 {
        0.0
    }
    fn to_json(&self) -> Value {
        json!({ "name": "explorer" })
    }
}

impl ContinuingWorld for Explorer {
    fn step_reward(&self, s: &mut (), d: usize, rng: &mut EngineRng) -> f64 {
        self.step(s, d, rng);
        0.0
    }
}

impl KnownState for Explorer {
    fn n_states(&self) -> Result<usize> {
        Ok(1)
    }
    fn known_state(&self, (): &(), _: usize) -> usize {
        0
    }
    fn restore(&self, _: &[i64]) -> Result<()> {
        Ok(())
    }
}

#[test]
fn exploration_frequency_follows_epsilon() {
    let world = Explorer { explored: std::sync::atomic::AtomicU64::default() };
    let mut learner = QLearner::new(world, QConfig { seed: 3, ties: Ties::Lowest, ..QConfig::default() }).unwrap();
    let n = 1_000_000u64;
    learner.run(n);
    let p: Vec<f64> = (1..=n).map(|t| 0.75 * epsilon(t)).collect();
    let mean: f64 = p.iter().sum();
    let sd = p.iter().map(|p| p * (1.0 - p)).sum::<f64>().sqrt();
    let explored = learner.world().explored.load(std::sync::atomic::Ordering::Relaxed) as f64;
    assert!((explored - mean).abs() < 5.0 * sd, "{explored} explorations, expected {mean:.0} ± {sd:.0}");
    assert!(learner.table().values().iter().all(|&v| v == 0.0));
}

#[test]
fn learning_on_a_small_grid_keeps_values_in_range() {
    let mut learner = QLearner::new(small_world(), QConfig { seed: 3, ..QConfig::default() }).unwrap();
    learner.run(100_000);
    assert_eq!(learner.updates(), 100_000);
    let bound = (1.0 / (1.0 - GAMMA)) as f32;
    assert!(learner.table().values().iter().all(|v| v.is_finite() && *v >= 0.0 && *v <= bound));
    assert!(learner.table().values().iter().any(|v| *v > 0.0), "some rewarded pairs were learnt");
}

#[test]
fn known_state_is_a_bijection_with_the_papers_index() {
    let world = TargetTracking::new(3).unwrap();
    assert_eq!(world.n_states().unwrap(), 16 * 1600 * 1600);
    let s = TrackingState {
        b: Mobile { i: 3, j: 7, heading: 2 },
        c: Mobile { i: 19, j: 19, heading: 3 },
        target: [0, 0],
        score: 0,
    };
    let b = (7 * 20 + 3) * 4 + 2;
    let c = (19 * 20 + 19) * 4 + 3;
    assert_eq!(world.known_state(&s, 5), (5 * 1600 + b) * 1600 + c);
    let last = TrackingState { b: Mobile { i: 19, j: 19, heading: 3 }, ..s };
    assert_eq!(world.known_state(&last, 15), world.n_states().unwrap() - 1);
    let small = small_world();
    let mut seen = vec![false; small.n_states().unwrap()];
    let mobiles: Vec<Mobile> =
        (0..5).flat_map(|j| (0..5).flat_map(move |i| (0..4).map(move |heading| Mobile { i, j, heading }))).collect();
    for y in 0..16 {
        for &b in &mobiles {
            for &c in &mobiles {
                let k = small.known_state(&TrackingState { b, c, target: [0, 0], score: 0 }, y);
                assert!(!seen[k], "index {k} twice");
                seen[k] = true;
            }
        }
    }
    assert!(seen.iter().all(|&v| v));
}

#[test]
fn step_reward_is_the_encounter_and_keeps_no_running_score() {
    let world = TargetTracking::new(3).unwrap();
    let mut rng = stream(0, Purpose::Evaluate, 0, 0);
    let mut s = world.initial_state([1, 17]);
    assert!(world.encounter(&s));
    assert_eq!(world.step_reward(&mut s, 15, &mut rng), 1.0);
    assert_eq!(s.score, 0);
    let mut far = world.initial_state([10, 0]);
    assert_eq!(world.step_reward(&mut far, 15, &mut rng), 0.0);
}

#[test]
fn a_table_that_does_not_fit_is_refused_before_allocating() {
    let e = check_memory("a Q table", 2_621_440_064, Some(1 << 30)).unwrap_err();
    let text = e.to_string();
    assert!(text.contains("2621440064") && text.contains("1073741824"), "{text}");
    assert!(check_memory("a Q table", 10, None).is_ok());
    // A 1000 × 1000 grid needs 16 · 4e6² · 16 · 4 bytes ≈ 1.6e16: refused, never allocated.
    let huge =
        TargetTracking::with_params(TrackingParams { width: 1000, height: 1000, ..TrackingParams::default() }).unwrap();
    match QLearner::new(huge, QConfig::default()) {
        Err(Error::Memory { needed, .. }) => assert_eq!(needed, 16 * 4_000_000u64 * 4_000_000 * 16 * 4 + 64),
        Err(other) => panic!("unexpected error {other}"),
        Ok(_) => panic!("a 16-petabyte table was allocated"),
    }
    assert_eq!(table_bytes(16 * 1600 * 1600, 16).unwrap(), 2_621_440_064);
}

#[test]
fn bad_settings_are_refused_by_name() {
    for (config, name) in [
        (QConfig { gamma: 1.0, ..QConfig::default() }, "gamma"),
        (QConfig { alpha: 0.0, ..QConfig::default() }, "alpha"),
        (QConfig { alpha: f64::NAN, ..QConfig::default() }, "alpha"),
    ] {
        let e = QLearner::new(Cycle { decisions: 2 }, config).err().unwrap().to_string();
        assert!(e.contains(name), "{e}");
    }
    let bad = WindowConfig { episodes: 0, ..WindowConfig::default() };
    assert!(
        evaluate_windows(
            &Cycle { decisions: 2 },
            &Greedy { table: &QTable::zeros(2, 2).unwrap(), ties: Ties::Random },
            &bad,
            0
        )
        .is_err()
    );
}

#[test]
fn table_rows_are_cache_line_aligned() {
    let table = QTable::zeros(1000, 16).unwrap();
    assert_eq!(table.values().as_ptr() as usize % 64, 0);
    assert_eq!(table.values().len(), 16_000);
}

#[test]
fn resume_from_a_checkpoint_continues_exactly() {
    let world = small_world();
    let config = QConfig { seed: 11, ..QConfig::default() };
    let mut straight = QLearner::new(world.clone(), config.clone()).unwrap();
    straight.run(2000);
    let mut first = QLearner::new(world.clone(), config).unwrap();
    first.run(1000);
    let path = temp("resume.qtable");
    first.save(&path).unwrap();
    drop(first);
    let mut resumed = QLearner::load(&path, world.clone()).unwrap();
    assert_eq!(resumed.updates(), 1000);
    resumed.run(1000);
    assert_eq!(resumed.updates(), straight.updates());
    assert!(straight.table() == resumed.table(), "the tables differ");
    assert_eq!(straight.current(), resumed.current());
    assert_eq!(straight.reward_total(), resumed.reward_total());
    assert_eq!(straight.rng, resumed.rng);
    // And a chunked `train` is the same run as one `run`.
    let mut trained = QLearner::new(world, QConfig { seed: 11, ..QConfig::default() }).unwrap();
    let outcome = trained.train(2000, None, None, |_| Flow::Continue).unwrap();
    assert_eq!((outcome.updates, outcome.interrupted, outcome.checkpoints), (2000, false, 0));
    assert!(trained.table() == straight.table());
}

#[test]
fn train_checkpoints_and_stops_when_asked() {
    let path = temp("train.qtable");
    let mut learner = QLearner::new(small_world(), QConfig::default()).unwrap();
    let mut calls = 0;
    let outcome = learner
        .train(3 * CHUNK, Some(&path), Some(1e9), |p| {
            calls += 1;
            assert!(p.updates <= p.until && p.epsilon < 1.0);
            if calls == 2 { Flow::Stop } else { Flow::Continue }
        })
        .unwrap();
    assert!(outcome.interrupted);
    assert_eq!((outcome.updates, outcome.checkpoints), (2 * CHUNK, 1));
    let header = read_header(&path).unwrap();
    assert_eq!(header["updates"], 2 * CHUNK);
    assert_eq!(header["format"], FORMAT);
    let AnyLearner::TargetTracking(loaded) = AnyLearner::load(&path).unwrap();
    assert!(loaded.table() == learner.table() && loaded.world() == learner.world());
}

#[test]
fn a_checkpoint_that_cannot_be_written_does_not_stop_training() {
    // Every save fails (the folder is gone): the training runs to the end and says why.
    let path = std::env::temp_dir().join(format!("ceworld-no-folder-{}", std::process::id())).join("q.qtable");
    let mut learner = QLearner::new(small_world(), QConfig::default()).unwrap();
    let outcome = learner.train(3 * CHUNK, Some(&path), Some(1e-9), |_| Flow::Continue).unwrap();
    assert_eq!((outcome.updates, outcome.checkpoints, outcome.interrupted), (3 * CHUNK, 0, false));
    let error = outcome.checkpoint_error.expect("the failure is told");
    assert!(error.contains("q.qtable") && !error.contains(".tmp"), "{error}");
}

#[test]
fn loading_checks_the_file() {
    let world = small_world();
    let learner = QLearner::new(world.clone(), QConfig::default()).unwrap();
    let path = temp("check.qtable");
    learner.save(&path).unwrap();
    let other = TargetTracking::with_params(TrackingParams { reward_radius: 2, ..world.params().clone() }).unwrap();
    assert!(matches!(QLearner::load(&path, other), Err(Error::Mismatch(_))));
    let mut bytes = std::fs::read(&path).unwrap();
    bytes.pop();
    let cut = temp("cut.qtable");
    std::fs::write(&cut, &bytes).unwrap();
    let e = QLearner::load(&cut, world.clone()).err().unwrap().to_string();
    assert!(e.contains("bytes (expected"), "{e}");
    let junk = temp("junk.qtable");
    std::fs::write(&junk, b"{\"format\": \"cehmm-policy\"}").unwrap();
    let e = QLearner::load(&junk, world).err().unwrap().to_string();
    assert!(e.contains("not a cehmm Q table"), "{e}");
}

#[test]
fn windows_of_a_deterministic_world_by_hand() {
    // Cycle pays 1 for every step from state 1, and the windows start in state 0 (a) or
    // after an odd burn-in in state 1 (b): a window of 5 steps gets 2 or 3.
    let config = WindowConfig { window: 5, episodes: 7, chains: 3, burn_in: 1, windows_per_chain: 4 };
    let table = QTable::zeros(2, 2).unwrap();
    let report =
        evaluate_windows(&Cycle { decisions: 2 }, &Greedy { table: &table, ties: Ties::Random }, &config, 0).unwrap();
    assert_eq!((report.from_start.episodes, report.from_start.min, report.from_start.max), (7, 2.0, 2.0));
    // From state 1: windows of steps 1..6 (3), 6..11 (2: states 0,1,0,1,0), 11..16 (3), 16..21 (2).
    assert_eq!(report.continuing.episodes, 12);
    assert_eq!((report.continuing.min, report.continuing.mean, report.continuing.max), (2.0, 2.5, 3.0));
    assert!((percent(report.continuing.mean, 5.0) - 50.0).abs() < 1e-12);
}

#[test]
fn hhmm_windows_from_start_are_the_episodes_of_evaluate() {
    let world = small_world();
    let policy = Hhmm::random(16, 16, &[4, 2], &mut stream(1, Purpose::Init, 0, 0)).unwrap();
    let config =
        WindowConfig { window: world.horizon(), episodes: 300, chains: 2, burn_in: 500, windows_per_chain: 10 };
    let report = evaluate_windows(&world, &policy, &config, 9).unwrap();
    let rewards = crate::evaluate::rewards(&world, &policy, 300, 9).unwrap();
    assert_eq!(report.from_start, Evaluation::from_rewards(&rewards));
    assert_eq!(report.continuing.episodes, 20);
    assert!(report.continuing.max <= 100.0);
}

#[test]
fn greedy_q_policy_windows_are_reproducible_and_thread_independent() {
    let mut learner = QLearner::new(small_world(), QConfig::default()).unwrap();
    learner.run(200_000);
    let config =
        WindowConfig { episodes: 200, chains: 4, burn_in: 1000, windows_per_chain: 50, ..WindowConfig::default() };
    let one = crate::control::thread_pool(Some(1))
        .unwrap()
        .install(|| evaluate_windows(learner.world(), &learner.greedy_policy(), &config, 5))
        .unwrap();
    let two = crate::control::thread_pool(Some(2))
        .unwrap()
        .install(|| evaluate_windows(learner.world(), &learner.greedy_policy(), &config, 5))
        .unwrap();
    assert_eq!(one, two);
    assert!(one.from_start.mean > 0.0, "a learnt policy meets the target sometimes on a 5×5 grid");
}
