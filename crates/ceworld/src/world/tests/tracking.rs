//! Unit tests of `world::tracking`.

use super::*;
use crate::rng::{Purpose, stream};

fn world(case: u8) -> TargetTracking {
    TargetTracking::new(case).unwrap()
}

fn rng() -> EngineRng {
    stream(7, Purpose::Optimise, 0, 0)
}

fn state(b: (i32, i32, u8), c: (i32, i32, u8), target: [i32; 2]) -> TrackingState {
    TrackingState {
        b: Mobile { i: b.0, j: b.1, heading: b.2 },
        c: Mobile { i: c.0, j: c.1, heading: c.2 },
        target,
        score: 0,
    }
}

#[test]
fn mobiles_start_in_the_down_corners_facing_down() {
    let s = world(3).reset(&mut rng());
    assert_eq!(s.b, Mobile { i: 0, j: 19, heading: DOWN });
    assert_eq!(s.c, Mobile { i: 19, j: 19, heading: DOWN });
    assert_eq!(s.score, 0);
}

#[test]
fn turns_change_the_heading_modulo_4() {
    let m = Mobile { i: 5, j: 5, heading: UP };
    assert_eq!(m.apply(TURN_LEFT, 20, 20).heading, LEFT);
    assert_eq!(m.apply(TURN_RIGHT, 20, 20).heading, RIGHT);
    let m = Mobile { heading: LEFT, ..m };
    assert_eq!(m.apply(TURN_RIGHT, 20, 20).heading, UP);
    assert_eq!(m.apply(TURN_LEFT, 20, 20).heading, DOWN);
    assert_eq!((m.apply(TURN_LEFT, 20, 20).i, m.apply(TURN_LEFT, 20, 20).j), (5, 5), "turning does not move");
}

#[test]
fn forward_moves_one_cell_along_the_heading() {
    for (heading, cell) in [(UP, (5, 4)), (RIGHT, (6, 5)), (DOWN, (5, 6)), (LEFT, (4, 5))] {
        let m = Mobile { i: 5, j: 5, heading }.apply(FORWARD, 20, 20);
        assert_eq!((m.i, m.j, m.heading), (cell.0, cell.1, heading));
    }
}

#[test]
fn forward_off_the_grid_stays_put() {
    for (i, j, heading) in [(0, 0, UP), (19, 3, RIGHT), (4, 19, DOWN), (0, 7, LEFT)] {
        let m = Mobile { i, j, heading };
        assert_eq!(m.apply(FORWARD, 20, 20), m);
    }
}

#[test]
fn no_move_changes_nothing() {
    let m = Mobile { i: 3, j: 8, heading: RIGHT };
    assert_eq!(m.apply(NO_MOVE, 20, 20), m);
}

#[test]
fn joint_decision_is_4_a_b_plus_a_c() {
    let w = world(1);
    let mut s = w.reset(&mut rng());
    // a_B = FORWARD (2) is useless facing down at the bottom row, so turn first: a_B = TURN_LEFT, a_C = TURN_RIGHT.
    w.step(&mut s, 4 * TURN_LEFT + TURN_RIGHT, &mut rng());
    assert_eq!((s.b.heading, s.c.heading), (RIGHT, LEFT));
    w.step(&mut s, 4 * FORWARD + NO_MOVE, &mut rng());
    assert_eq!((s.b.i, s.b.j, s.c.i, s.c.j), (1, 19, 19, 19));
    w.step(&mut s, 4 * NO_MOVE + FORWARD, &mut rng());
    assert_eq!((s.b.i, s.c.i), (1, 18));
}

#[test]
fn ahead_bit_is_strict_and_follows_the_heading() {
    let at = |heading| Mobile { i: 10, j: 10, heading };
    // target straight above, at the same row, and below
    assert_eq!(at(UP).observe([10, 5], 3) & 1, 1);
    assert_eq!(at(UP).observe([2, 10], 3) & 1, 0, "same row is not ahead");
    assert_eq!(at(UP).observe([10, 15], 3) & 1, 0);
    assert_eq!(at(RIGHT).observe([11, 0], 3) & 1, 1);
    assert_eq!(at(RIGHT).observe([10, 0], 3) & 1, 0);
    assert_eq!(at(DOWN).observe([0, 11], 3) & 1, 1);
    assert_eq!(at(DOWN).observe([0, 10], 3) & 1, 0);
    assert_eq!(at(LEFT).observe([9, 19], 3) & 1, 1);
    assert_eq!(at(LEFT).observe([10, 19], 3) & 1, 0);
}

#[test]
fn near_bit_is_chebyshev_distance_below_3() {
    let m = Mobile { i: 10, j: 10, heading: UP };
    assert_eq!(m.observe([12, 8], 3) >> 1, 1, "d∞ = 2");
    assert_eq!(m.observe([13, 10], 3) >> 1, 0, "d∞ = 3 is not near");
    assert_eq!(m.observe([10, 10], 3) >> 1, 1, "same cell");
}

#[test]
fn joint_observation_is_obs_b_plus_4_obs_c() {
    let w = world(3);
    // B faces up with the target ahead and near (3); C faces up, target behind and far (0).
    let s = state((10, 12, UP), (10, 0, UP), [10, 10]);
    assert_eq!(w.observe(&s, &mut rng()), 3);
    // C sees it ahead and near, B neither.
    let s = state((0, 0, UP), (11, 9, DOWN), [10, 10]);
    assert_eq!(w.observe(&s, &mut rng()), 4 * 3);
    assert_eq!(w.n_observations(), 16);
}

#[test]
fn case_2_hides_the_observation() {
    let w = world(2);
    assert_eq!(w.n_observations(), 1);
    let s = state((10, 12, UP), (10, 8, DOWN), [10, 10]);
    assert_eq!(w.observe(&s, &mut rng()), 0);
}

#[test]
fn reward_counts_chebyshev_3_inclusive_for_either_mobile() {
    let w = world(1);
    let near_b = state((7, 13, UP), (19, 19, UP), [10, 10]);
    let near_c = state((0, 19, UP), (13, 7, UP), [10, 10]);
    let far = state((6, 10, UP), (14, 10, UP), [10, 10]);
    assert!(w.encounter(&near_b) && w.encounter(&near_c));
    assert!(!w.encounter(&far), "d∞ = 4 for both");
}

#[test]
fn reward_is_counted_before_the_mobiles_move() {
    let w = world(1);
    // B is at d∞ = 3 and steps away this turn: step t is still rewarded, t + 1 is not.
    let mut s = state((7, 10, LEFT), (19, 19, DOWN), [10, 10]);
    w.step(&mut s, 4 * FORWARD + NO_MOVE, &mut rng());
    assert_eq!((s.score, s.b.i), (1, 6));
    w.step(&mut s, 4 * NO_MOVE + NO_MOVE, &mut rng());
    assert_eq!(s.score, 1);
}

#[test]
fn case_1_target_is_fixed_at_10_10() {
    let w = world(1);
    let mut r = rng();
    let mut s = w.reset(&mut r);
    assert_eq!(s.target, [10, 10]);
    for t in 0..50 {
        w.step(&mut s, t % 16, &mut r);
        assert_eq!(s.target, [10, 10]);
    }
}

#[test]
fn moving_target_starts_uniform_on_the_upper_half() {
    let w = world(3);
    let mut counts = vec![0u32; 400];
    let n = 200_000;
    for k in 0..n {
        let s = w.reset(&mut stream(1, Purpose::Optimise, 0, k));
        assert!((0..20).contains(&s.target[0]) && (0..=9).contains(&s.target[1]), "{:?}", s.target);
        counts[(s.target[1] * 20 + s.target[0]) as usize] += 1;
    }
    let expected = n as f64 / 200.0;
    let chi2: f64 = counts[..200].iter().map(|&c| (c as f64 - expected).powi(2) / expected).sum();
    assert!(chi2 < 270.0, "chi2 = {chi2} on 199 degrees of freedom (0.9995 quantile ~ 270)");
}

#[test]
fn moving_target_starts_on_the_rows_asked_for() {
    // Rows 2..=5 of an 8-column grid: 32 cells, each drawn about 1/32 of the time.
    let p = TrackingParams {
        width: 8,
        height: 8,
        start_b: [0, 7],
        start_c: [7, 7],
        target_cell: [4, 4],
        target_rows: [2, 5],
        ..TrackingParams::default()
    };
    let w = TargetTracking::with_params(p).unwrap();
    let mut counts = [0u32; 32];
    let n = 64_000;
    for k in 0..n {
        let s = w.reset(&mut stream(2, Purpose::Optimise, 0, k));
        assert!((0..8).contains(&s.target[0]) && (2..=5).contains(&s.target[1]), "{:?}", s.target);
        counts[((s.target[1] - 2) * 8 + s.target[0]) as usize] += 1;
    }
    let expected = f64::from(n as u32) / 32.0;
    let chi2: f64 = counts.iter().map(|&c| (f64::from(c) - expected).powi(2) / expected).sum();
    assert!(chi2 < 61.1, "chi2 = {chi2} on 31 degrees of freedom (0.999 quantile 61.1)");
}

/// Expected move probabilities of the target, from the rule of model §4.
fn move_law(target: [i32; 2], b: [i32; 2], c: [i32; 2]) -> Vec<([i32; 2], f64)> {
    let mut cells = Vec::new();
    for j in target[1] - 1..=target[1] + 1 {
        for i in target[0] - 1..=target[0] + 1 {
            if (0..20).contains(&i) && (0..20).contains(&j) {
                let d2 = |m: [i32; 2]| ((i - m[0]).pow(2) + (j - m[1]).pow(2)) as f64;
                cells.push(([i, j], d2(b) + d2(c)));
            }
        }
    }
    let total: f64 = cells.iter().map(|c| c.1).sum();
    cells.into_iter().map(|(c, w)| (c, w / total)).collect()
}

#[test]
fn target_moves_in_its_neighbourhood_proportionally_to_squared_distances() {
    let w = world(3);
    // interior (9 cells, staying put included) and a corner (4 cells)
    for (target, b, c, limit) in [([5, 5], [0, 0], [9, 9], 26.12), ([0, 0], [3, 1], [19, 19], 16.27)] {
        let law = move_law(target, b, c);
        let mut r = stream(3, Purpose::Optimise, 0, 0);
        let n = 200_000;
        let mut counts = vec![0u32; law.len()];
        for _ in 0..n {
            let next = w.move_target(target, b, c, &mut r);
            let k = law.iter().position(|(cell, _)| *cell == next).expect("a neighbour in the grid");
            counts[k] += 1;
        }
        let chi2: f64 =
            law.iter().zip(&counts).map(|((_, p), &c)| (c as f64 - p * n as f64).powi(2) / (p * n as f64)).sum();
        assert!(chi2 < limit, "chi2 = {chi2} for {} cells", law.len());
    }
}

#[test]
fn target_moves_from_the_mobiles_positions_before_they_move() {
    let w = world(3);
    let s0 = state((9, 9, RIGHT), (0, 19, UP), [10, 10]);
    // Same random stream: stepping B away must not change where the target goes.
    let mut a = s0;
    w.step(&mut a, 4 * FORWARD + NO_MOVE, &mut stream(5, Purpose::Optimise, 0, 0));
    let expected = w.move_target([10, 10], [9, 9], [0, 19], &mut stream(5, Purpose::Optimise, 0, 0));
    assert_eq!(a.target, expected);
}

#[test]
fn an_episode_has_t_steps_and_a_reward_in_0_to_t() {
    let w = world(3);
    assert_eq!(w.horizon(), 100);
    let mut r = rng();
    let mut s = w.reset(&mut r);
    for t in 0..w.horizon() {
        let _ = w.observe(&s, &mut r);
        w.step(&mut s, (t * 7) % 16, &mut r);
    }
    assert!((0.0..=100.0).contains(&w.reward(&s)));
}

/// Pearson's chi-square of `n` draws of the target's next cell against `law`.
fn move_chi2(law: &[([i32; 2], f64)], n: usize, mut draw: impl FnMut() -> [i32; 2]) -> f64 {
    let mut counts = vec![0u32; law.len()];
    for _ in 0..n {
        let next = draw();
        let k = law.iter().position(|(cell, _)| *cell == next).unwrap_or_else(|| panic!("{next:?} not allowed"));
        counts[k] += 1;
    }
    law.iter().zip(&counts).map(|((_, p), &c)| (c as f64 - p * n as f64).powi(2) / (p * n as f64)).sum()
}

#[test]
fn target_move_law_by_hand_on_an_asymmetric_corner() {
    // Target in the corner (0, 0), B at (2, 0), C at (0, 1). Weights |r' − B|² + |r' − C|²:
    // (0,0): 4 + 1 = 5, (1,0): 1 + 2 = 3, (0,1): 5 + 0 = 5, (1,1): 2 + 1 = 3; total 16.
    // Swapping i and j in the weights gives 5, 5, 3, 3, and so does transposing the drawn
    // cell: both are far outside the test's tolerance.
    let law = [([0, 0], 5.0 / 16.0), ([1, 0], 3.0 / 16.0), ([0, 1], 5.0 / 16.0), ([1, 1], 3.0 / 16.0)];
    for (cell, p) in move_law([0, 0], [2, 0], [0, 1]) {
        let hand = law.iter().find(|(c, _)| *c == cell).unwrap().1;
        assert!((p - hand).abs() < 1e-12, "{cell:?}: {p} vs {hand}");
    }
    let w = world(3);
    let mut r = stream(8, Purpose::Optimise, 0, 0);
    let chi2 = move_chi2(&law, 100_000, || w.move_target([0, 0], [2, 0], [0, 1], &mut r));
    assert!(chi2 < 16.27, "chi2 = {chi2} on 3 degrees of freedom (0.999 quantile 16.27)");
}

#[test]
fn target_moves_by_the_law_through_world_step() {
    // An interior cell with B and C near it and placed asymmetrically in i and j (the mobiles
    // do not move, so each step draws from the same law). Swapping i and j in the weights
    // gives a chi-square near 48,000 here, transposing the drawn cell near 9,700.
    let w = world(3);
    let (b, c, target) = ((8, 4, UP), (6, 5, LEFT), [6, 4]);
    let law = move_law(target, [b.0, b.1], [c.0, c.1]);
    let transposed = |cell: [i32; 2]| [target[0] + cell[1] - target[1], target[1] + cell[0] - target[0]];
    let p = |cell: [i32; 2]| law.iter().find(|(c, _)| *c == cell).unwrap().1;
    assert!(law.iter().any(|&(cell, q)| (q - p(transposed(cell))).abs() > 0.05), "the case must be asymmetric");
    let mut r = stream(9, Purpose::Optimise, 0, 0);
    let chi2 = move_chi2(&law, 100_000, || {
        let mut s = state(b, c, target);
        w.step(&mut s, 4 * NO_MOVE + NO_MOVE, &mut r);
        s.target
    });
    assert!(chi2 < 26.12, "chi2 = {chi2} on 8 degrees of freedom (0.999 quantile 26.12)");
}

#[test]
fn case_1_optimal_plan_replayed_through_the_world_scores_86() {
    let w = world(1);
    let plan = w.case1_optimal_plan().unwrap();
    assert_eq!(plan.len(), 100);
    let mut r = rng();
    let mut s = w.reset(&mut r);
    let mut first_reward = None;
    for (t, &d) in plan.iter().enumerate() {
        if first_reward.is_none() && w.encounter(&s) {
            first_reward = Some(t);
        }
        w.step(&mut s, d, &mut r);
    }
    assert_eq!(w.reward(&s), 86.0);
    assert_eq!(first_reward, Some(14), "14 moves, then every step is rewarded");
    assert!(w.encounter(&s), "the mobile stays in the zone");
    assert!(plan[14..].iter().all(|&d| d == 4 * NO_MOVE + NO_MOVE), "then both mobiles stay put");
    // A target on the top row, to be reached exactly (radius 0): B turns left (to face right),
    // goes 5 cells right, turns left (up) and climbs 19 rows: 26 moves, so 74 rewarded steps.
    let p = TrackingParams { case: 1, target_cell: [5, 0], reward_radius: 0, ..TrackingParams::default() };
    let top = TargetTracking::with_params(p).unwrap();
    assert_eq!(top.case1_optimum().unwrap(), 74);
    let plan = top.case1_optimal_plan().unwrap();
    assert_eq!(plan[..2], [4 * TURN_LEFT + NO_MOVE, 4 * FORWARD + NO_MOVE]);
}

#[test]
fn case_1_optimum_is_86() {
    assert_eq!(world(1).case1_optimum().unwrap(), 86);
    // A target next to C's start is reached with no move at all.
    let p = TrackingParams { case: 1, target_cell: [17, 17], ..TrackingParams::default() };
    assert_eq!(TargetTracking::with_params(p).unwrap().case1_optimum().unwrap(), 100);
    assert!(world(3).case1_optimum().is_err());
}

/// Best reward of a deterministic memoryless policy (a map y -> d) in case 1, by exhaustive
/// depth-first search over the maps along the (deterministic) trajectory, pruned by the
/// BFS bound of `case1_optimum`.
#[allow(clippy::items_after_statements)] // the search reads best beside its caller
fn best_memoryless_case1(w: &TargetTracking) -> u32 {
    let p = w.params().clone();
    let to_zone = |m: Mobile| w.moves_to_encounter(m).unwrap_or(usize::MAX / 2);
    fn search(
        w: &TargetTracking,
        s: TrackingState,
        t: usize,
        map: &mut [Option<usize>; 16],
        best: &mut u32,
        to_zone: &dyn Fn(Mobile) -> usize,
    ) {
        let horizon = w.horizon();
        let (mut s, mut t) = (s, t);
        let mut rng = stream(0, Purpose::Optimise, 0, 0);
        loop {
            let reachable = horizon.saturating_sub(t + to_zone(s.b).min(to_zone(s.c)));
            if s.score + reachable as u32 <= *best {
                return;
            }
            if t == horizon {
                *best = s.score;
                return;
            }
            let y = w.observe(&s, &mut rng);
            if let Some(d) = map[y] {
                w.step(&mut s, d, &mut rng);
                t += 1;
            } else {
                for d in 0..16 {
                    map[y] = Some(d);
                    let mut next = s;
                    w.step(&mut next, d, &mut rng);
                    search(w, next, t + 1, map, best, to_zone);
                }
                map[y] = None;
                return;
            }
        }
    }
    let mut best = 0;
    search(w, w.initial_state(p.target_cell), 0, &mut [None; 16], &mut best, &to_zone);
    best
}

#[test]
fn case_1_deterministic_memoryless_optimum_is_83() {
    // Without memory, a mobile can only turn where its observation changes: C turns up
    // when it passes the target's column (17 moves), not after the 6 moves of the optimum.
    assert_eq!(best_memoryless_case1(&world(1)), 83);
}

#[test]
fn bad_parameters_are_refused_by_name() {
    let e = TargetTracking::new(4).unwrap_err().to_string();
    assert!(e.contains("case") && e.contains('4'), "{e}");
    let bad = TrackingParams { start_b: [20, 0], ..TrackingParams::default() };
    let e = TargetTracking::with_params(bad).unwrap_err().to_string();
    assert!(e.contains("start_b") && e.contains("[20, 0]"), "{e}");
    let bad = TrackingParams { target_rows: [5, 2], ..TrackingParams::default() };
    assert!(TargetTracking::with_params(bad).is_err());
    let bad = TrackingParams { horizon: 0, ..TrackingParams::default() };
    assert!(TargetTracking::with_params(bad).is_err());
}

#[test]
fn parameters_are_checked_at_their_bounds() {
    let ok = |p: TrackingParams| TargetTracking::with_params(p).is_ok();
    let d = TrackingParams::default;
    assert!(ok(TrackingParams { horizon: 1_000_000, ..d() }));
    assert!(!ok(TrackingParams { horizon: 1_000_001, ..d() }));
    assert!(ok(TrackingParams { horizon: 1, ..d() }));
    assert!(ok(TrackingParams { start_heading: 3, ..d() }));
    assert!(!ok(TrackingParams { start_heading: 4, ..d() }));
    for radius in ["reward_radius", "observe_radius"] {
        let with = |v: i32| {
            let mut p = d();
            if radius == "reward_radius" {
                p.reward_radius = v;
            } else {
                p.observe_radius = v;
            }
            p
        };
        assert!(ok(with(0)), "{radius} 0");
        assert!(!ok(with(-1)), "{radius} -1");
    }
    assert!(ok(TrackingParams {
        width: 4096,
        height: 1,
        start_b: [0, 0],
        start_c: [1, 0],
        target_cell: [2, 0],
        target_rows: [0, 0],
        ..d()
    }));
    assert!(!ok(TrackingParams { width: 4097, ..d() }));
    assert!(!ok(TrackingParams { height: 0, ..d() }));
    assert!(ok(TrackingParams { target_rows: [19, 19], ..d() }));
    assert!(!ok(TrackingParams { target_rows: [0, 20], ..d() }));
    assert!(!ok(TrackingParams { target_rows: [-1, 3], ..d() }));
}

#[test]
fn world_json_round_trips() {
    let p = TrackingParams { case: 2, horizon: 50, target_rows: [0, 4], ..TrackingParams::default() };
    let w = TargetTracking::with_params(p).unwrap();
    let v = w.to_json();
    assert_eq!(v["name"], "target-tracking");
    assert_eq!(TargetTracking::from_json(&v).unwrap(), w);
}

#[test]
fn with_equally_near_mobiles_the_plan_moves_b() {
    // A 21-wide grid, the target in the middle column: B and C are mirror images, equally near.
    let p = TrackingParams {
        case: 1,
        width: 21,
        height: 21,
        start_b: [0, 20],
        start_c: [20, 20],
        target_cell: [10, 10],
        ..TrackingParams::default()
    };
    let plan = TargetTracking::with_params(p).unwrap().case1_optimal_plan().unwrap();
    assert_eq!(plan[0] % 4, NO_MOVE, "C stays put: {:?}", &plan[..4]);
    assert_ne!(plan[0] / 4, NO_MOVE, "B moves: {:?}", &plan[..4]);
}

#[test]
fn state_labels_name_what_describe_writes() {
    let w = world(3);
    let mut out = Vec::new();
    let s = state((1, 2, UP), (3, 4, LEFT), [5, 6]);
    w.describe(&s, &mut out);
    assert_eq!(w.state_labels(), ["b_i", "b_j", "b_heading", "c_i", "c_j", "c_heading", "target_i", "target_j"]);
    assert_eq!(out, [1, 2, i64::from(UP), 3, 4, i64::from(LEFT), 5, 6]);
}
