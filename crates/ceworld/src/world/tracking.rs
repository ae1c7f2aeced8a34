//! The paper's example world: two slow mobiles tracking an evasive target on a grid (model §4).

use std::collections::VecDeque;

use rand::Rng;
use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::rng::EngineRng;
use crate::world::World;

/// Heading "up" (decreasing `j`).
pub const UP: u8 = 0;
/// Heading "right" (increasing `i`).
pub const RIGHT: u8 = 1;
/// Heading "down" (increasing `j`).
pub const DOWN: u8 = 2;
/// Heading "left" (decreasing `i`).
pub const LEFT: u8 = 3;

/// Mobile move: heading − 1 (mod 4).
pub const TURN_LEFT: usize = 0;
/// Mobile move: heading + 1 (mod 4).
pub const TURN_RIGHT: usize = 1;
/// Mobile move: one cell ahead, or stay put if that cell is off the grid.
pub const FORWARD: usize = 2;
/// Mobile move: nothing.
pub const NO_MOVE: usize = 3;

/// Every constant of the target-tracking world, with the defaults of model §4.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct TrackingParams {
    /// 1: fixed target; 2: moving target, no observation; 3: moving target, observed.
    pub case: u8,
    /// Grid columns (`i = 0..width`).
    pub width: i32,
    /// Grid rows (`j = 0..height`, `j = 0` at the top).
    pub height: i32,
    /// Steps per episode `T`.
    pub horizon: usize,
    /// Start cell `(i, j)` of mobile B.
    pub start_b: [i32; 2],
    /// Start cell `(i, j)` of mobile C.
    pub start_c: [i32; 2],
    /// Start heading of both mobiles (0 up, 1 right, 2 down, 3 left).
    pub start_heading: u8,
    /// A step is rewarded when `d∞(mobile, R) <= reward_radius` for some mobile.
    pub reward_radius: i32,
    /// Observation bit 1 of a mobile is `d∞(mobile, R) < observe_radius`.
    pub observe_radius: i32,
    /// The target's cell in case 1.
    pub target_cell: [i32; 2],
    /// In cases 2 and 3, `R_1` is uniform on every column and the rows `target_rows[0]..=target_rows[1]`.
    pub target_rows: [i32; 2],
}

impl Default for TrackingParams {
    fn default() -> Self {
        TrackingParams {
            case: 3,
            width: 20,
            height: 20,
            horizon: 100,
            start_b: [0, 19],
            start_c: [19, 19],
            start_heading: DOWN,
            reward_radius: 3,
            observe_radius: 3,
            target_cell: [10, 10],
            target_rows: [0, 9],
        }
    }
}

/// The target-tracking world (model §4), validated at construction.
#[derive(Clone, Debug, PartialEq)]
pub struct TargetTracking {
    params: TrackingParams,
}

/// One mobile: cell and heading.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Mobile {
    /// Column.
    pub i: i32,
    /// Row.
    pub j: i32,
    /// Heading (0 up, 1 right, 2 down, 3 left).
    pub heading: u8,
}

/// The hidden state `x_t` and the running reward.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TrackingState {
    /// Mobile B.
    pub b: Mobile,
    /// Mobile C.
    pub c: Mobile,
    /// The target's cell `(i, j)`.
    pub target: [i32; 2],
    /// Rewarded steps so far.
    pub score: u32,
}

/// Chebyshev distance `d∞`.
#[inline]
pub fn chebyshev(a: [i32; 2], b: [i32; 2]) -> i32 {
    (a[0] - b[0]).abs().max((a[1] - b[1]).abs())
}

impl Mobile {
    #[inline]
    fn cell(self) -> [i32; 2] {
        [self.i, self.j]
    }

    /// Applies one move (`TURN_LEFT`, `TURN_RIGHT`, `FORWARD`, `NO_MOVE`) on a `width × height` grid.
    #[inline]
    pub fn apply(self, action: usize, width: i32, height: i32) -> Mobile {
        // Table-driven rather than a match: the decisions are random, so branches would mispredict.
        const TURN: [u8; 4] = [3, 1, 0, 0];
        const DI: [i32; 4] = [0, 1, 0, -1];
        const DJ: [i32; 4] = [-1, 0, 1, 0];
        let action = action & 3;
        let forward = (action == FORWARD) as i32;
        let h = (self.heading & 3) as usize;
        let (i, j) = (self.i + forward * DI[h], self.j + forward * DJ[h]);
        let inside = (0..width).contains(&i) & (0..height).contains(&j);
        let heading = (self.heading + TURN[action]) & 3;
        if inside { Mobile { i, j, heading } } else { Mobile { heading, ..self } }
    }

    /// The mobile's 2-bit observation of the target: bit 0 = target strictly ahead,
    /// bit 1 = `d∞ < observe_radius`.
    #[inline]
    pub fn observe(self, target: [i32; 2], observe_radius: i32) -> usize {
        let ahead = [target[1] < self.j, target[0] > self.i, target[1] > self.j, target[0] < self.i];
        let near = chebyshev(self.cell(), target) < observe_radius;
        ahead[(self.heading & 3) as usize] as usize | ((near as usize) << 1)
    }
}

impl TargetTracking {
    /// The world of `case` with every other parameter at its model §4 default.
    pub fn new(case: u8) -> Result<Self> {
        Self::with_params(TrackingParams { case, ..TrackingParams::default() })
    }

    /// The world with the given parameters, checked.
    pub fn with_params(params: TrackingParams) -> Result<Self> {
        let p = &params;
        if !(1..=3).contains(&p.case) {
            return Err(Error::invalid("case", format!("{} (expected 1, 2 or 3)", p.case)));
        }
        for (name, v) in [("width", p.width), ("height", p.height)] {
            if !(1..=4096).contains(&v) {
                return Err(Error::invalid(name, format!("{v} (expected 1..=4096)")));
            }
        }
        if p.horizon == 0 || p.horizon > 1_000_000 {
            return Err(Error::invalid("horizon", format!("{} (expected 1..=1000000)", p.horizon)));
        }
        let inside = |c: [i32; 2]| (0..p.width).contains(&c[0]) && (0..p.height).contains(&c[1]);
        for (name, c) in [("start_b", p.start_b), ("start_c", p.start_c), ("target_cell", p.target_cell)] {
            if !inside(c) {
                return Err(Error::invalid(
                    name,
                    format!(
                        "{c:?} is off the {}×{} grid (expected i in 0..{}, j in 0..{})",
                        p.width, p.height, p.width, p.height
                    ),
                ));
            }
        }
        if p.start_heading > 3 {
            return Err(Error::invalid(
                "start_heading",
                format!("{} (expected 0 up, 1 right, 2 down or 3 left)", p.start_heading),
            ));
        }
        for (name, v) in [("reward_radius", p.reward_radius), ("observe_radius", p.observe_radius)] {
            if v < 0 {
                return Err(Error::invalid(name, format!("{v} (expected >= 0)")));
            }
        }
        let [r0, r1] = p.target_rows;
        if !(0 <= r0 && r0 <= r1 && r1 < p.height) {
            return Err(Error::invalid(
                "target_rows",
                format!("{:?} (expected [first, last] with 0 <= first <= last < {})", p.target_rows, p.height),
            ));
        }
        Ok(TargetTracking { params })
    }

    /// Rebuilds the world from the `"world"` object of a policy file.
    pub fn from_json(value: &serde_json::Value) -> Result<Self> {
        let name = value.get("name").and_then(|v| v.as_str()).unwrap_or("");
        if name != Self::NAME {
            return Err(Error::invalid("world.name", format!("{name:?} (expected {:?})", Self::NAME)));
        }
        let mut object = value.clone();
        if let Some(map) = object.as_object_mut() {
            map.remove("name");
        }
        let params: TrackingParams =
            serde_json::from_value(object).map_err(|e| Error::invalid("world", e.to_string()))?;
        Self::with_params(params)
    }

    /// The name written in policy files.
    pub const NAME: &'static str = "target-tracking";

    /// The parameters.
    pub fn params(&self) -> &TrackingParams {
        &self.params
    }

    /// Whether `d∞(mobile, R) <= reward_radius` for some mobile.
    #[inline]
    pub fn encounter(&self, s: &TrackingState) -> bool {
        let r = self.params.reward_radius;
        chebyshev(s.b.cell(), s.target) <= r || chebyshev(s.c.cell(), s.target) <= r
    }

    /// The target's next cell given the mobiles' cells at time `t` (before they move): one of
    /// the in-grid cells of its 3×3 neighbourhood, staying put included, with probability
    /// proportional to `|r' − B|² + |r' − C|²`.
    #[inline]
    pub fn move_target(&self, target: [i32; 2], b: [i32; 2], c: [i32; 2], rng: &mut EngineRng) -> [i32; 2] {
        // The weight of cell (i, j) is f(i) + g(j), with f(i) = (i − b_i)² + (i − c_i)² and g(j)
        // likewise, or 0 off the grid. Branch-free: the nine cumulated weights are compared with
        // the draw and the comparisons summed, so no mispredicted branch depends on the draw.
        let (w, h) = (self.params.width, self.params.height);
        let mut f = [0u64; 3];
        let mut g = [0u64; 3];
        for k in 0..3 {
            let (i, j) = (target[0] + k as i32 - 1, target[1] + k as i32 - 1);
            let (di, dj) = ((i - b[0]) as i64, (j - b[1]) as i64);
            let (ei, ej) = ((i - c[0]) as i64, (j - c[1]) as i64);
            let inside_i = (0..w).contains(&i) as u64;
            let inside_j = (0..h).contains(&j) as u64;
            // Bit 62 flags an off-grid column or row; a flagged cell gets weight 0 below.
            f[k] = ((di * di + ei * ei) as u64) | (u64::from(inside_i == 0) << 62);
            g[k] = ((dj * dj + ej * ej) as u64) | (u64::from(inside_j == 0) << 62);
        }
        let mut cumulative = [0u64; 9];
        let mut total = 0u64;
        for r in 0..3 {
            for k in 0..3 {
                let off_grid = (f[k] | g[r]) >> 62;
                let weight = (f[k] + g[r]) * (1 - off_grid);
                total += weight;
                cumulative[3 * r + k] = total;
            }
        }
        if total == 0 {
            return target;
        }
        // Multiply-shift maps 64 random bits onto 0..total; the bias (< total / 2^64) is nil.
        let x = ((rng.next_u64() as u128 * total as u128) >> 64) as u64;
        let index: usize = cumulative.iter().map(|&c| (x >= c) as usize).sum();
        [target[0] + (index % 3) as i32 - 1, target[1] + (index / 3) as i32 - 1]
    }

    /// The state `x_1` with the target at `target`.
    pub fn initial_state(&self, target: [i32; 2]) -> TrackingState {
        let p = &self.params;
        TrackingState {
            b: Mobile { i: p.start_b[0], j: p.start_b[1], heading: p.start_heading },
            c: Mobile { i: p.start_c[0], j: p.start_c[1], heading: p.start_heading },
            target,
            score: 0,
        }
    }

    /// The exact optimum of case 1 (fixed target): a breadth-first search over each mobile's
    /// configurations (cell × heading) finds the fewest moves `k` that bring it within the
    /// reward radius; it can then stay, so the optimum is `T − min k` (model §4: 86). The
    /// number is the score of [`case1_optimal_plan`](Self::case1_optimal_plan) replayed through
    /// the world's own `step` and `reward`, so the search and the simulator must agree.
    pub fn case1_optimum(&self) -> Result<u32> {
        let plan = self.case1_optimal_plan()?;
        let mut rng = crate::rng::stream(0, crate::rng::Purpose::Evaluate, 0, 0);
        let mut state = self.reset(&mut rng);
        for &d in &plan {
            self.step(&mut state, d, &mut rng);
        }
        Ok(self.reward(&state) as u32)
    }

    /// An optimal open-loop plan for case 1: the joint decisions `d_1..d_T` that move the
    /// mobile closer to the target (in moves) along a shortest path into the reward zone, the
    /// other mobile and then both staying put.
    pub fn case1_optimal_plan(&self) -> Result<Vec<usize>> {
        let p = &self.params;
        if p.case != 1 {
            return Err(Error::invalid("case", format!("{} (the exact optimum is known for case 1 only)", p.case)));
        }
        let start = self.initial_state(p.target_cell);
        let paths = [self.path_to_encounter(start.b), self.path_to_encounter(start.c)];
        let (mobile, path) = match paths {
            [Some(b), Some(c)] if c.len() < b.len() => (1, c),
            [Some(b), _] => (0, b),
            [None, Some(c)] => (1, c),
            [None, None] => (0, Vec::new()),
        };
        let joint = |a: usize| if mobile == 0 { 4 * a + NO_MOVE } else { 4 * NO_MOVE + a };
        let mut plan: Vec<usize> = path.into_iter().map(joint).collect();
        plan.resize(p.horizon, 4 * NO_MOVE + NO_MOVE);
        Ok(plan)
    }

    /// The moves of a shortest path for one mobile into the reward zone of the fixed target.
    fn path_to_encounter(&self, start: Mobile) -> Option<Vec<usize>> {
        let p = &self.params;
        let index = |m: Mobile| ((m.j * p.width + m.i) * 4 + m.heading as i32) as usize;
        // For each reached configuration: the configuration it was reached from and the move.
        let mut parent: Vec<Option<(Mobile, usize)>> = vec![None; (p.width * p.height * 4) as usize];
        let mut seen = vec![false; parent.len()];
        let mut queue = VecDeque::from([start]);
        seen[index(start)] = true;
        while let Some(m) = queue.pop_front() {
            if chebyshev(m.cell(), p.target_cell) <= p.reward_radius {
                let mut moves = Vec::new();
                let mut at = m;
                while let Some((from, a)) = parent[index(at)] {
                    moves.push(a);
                    at = from;
                }
                moves.reverse();
                return Some(moves);
            }
            for a in [TURN_LEFT, TURN_RIGHT, FORWARD] {
                let next = m.apply(a, p.width, p.height);
                if !seen[index(next)] {
                    seen[index(next)] = true;
                    parent[index(next)] = Some((m, a));
                    queue.push_back(next);
                }
            }
        }
        None
    }

    /// Fewest moves for one mobile to come within the reward radius of the fixed target.
    #[cfg(test)]
    fn moves_to_encounter(&self, start: Mobile) -> Option<usize> {
        self.path_to_encounter(start).map(|path| path.len())
    }
}

impl World for TargetTracking {
    type State = TrackingState;

    fn n_observations(&self) -> usize {
        if self.params.case == 2 { 1 } else { 16 }
    }

    fn n_decisions(&self) -> usize {
        16
    }

    fn horizon(&self) -> usize {
        self.params.horizon
    }

    fn reset(&self, rng: &mut EngineRng) -> TrackingState {
        let p = &self.params;
        let target = if p.case == 1 {
            p.target_cell
        } else {
            let rows = (p.target_rows[1] - p.target_rows[0] + 1) as u64;
            let cell = ((rng.next_u64() as u128 * (rows * p.width as u64) as u128) >> 64) as i32;
            [cell % p.width, p.target_rows[0] + cell / p.width]
        };
        self.initial_state(target)
    }

    #[inline]
    fn observe(&self, s: &TrackingState, _rng: &mut EngineRng) -> usize {
        if self.params.case == 2 {
            return 0;
        }
        let r = self.params.observe_radius;
        s.b.observe(s.target, r) + 4 * s.c.observe(s.target, r)
    }

    #[inline]
    fn step(&self, s: &mut TrackingState, decision: usize, rng: &mut EngineRng) {
        if self.encounter(s) {
            s.score += 1;
        }
        if self.params.case != 1 {
            s.target = self.move_target(s.target, s.b.cell(), s.c.cell(), rng);
        }
        let (w, h) = (self.params.width, self.params.height);
        s.b = s.b.apply(decision / 4, w, h);
        s.c = s.c.apply(decision % 4, w, h);
    }

    fn reward(&self, s: &TrackingState) -> f64 {
        s.score as f64
    }

    fn state_labels(&self) -> Vec<&'static str> {
        vec!["b_i", "b_j", "b_heading", "c_i", "c_j", "c_heading", "target_i", "target_j"]
    }

    fn describe(&self, s: &TrackingState, out: &mut Vec<i64>) {
        out.extend(
            [s.b.i, s.b.j, s.b.heading as i32, s.c.i, s.c.j, s.c.heading as i32, s.target[0], s.target[1]]
                .map(i64::from),
        );
    }

    /// Known for case 1 (fixed target): see [`TargetTracking::case1_optimum`].
    fn exact_optimum(&self) -> Result<f64> {
        self.case1_optimum().map(f64::from)
    }

    fn to_json(&self) -> serde_json::Value {
        let mut value = serde_json::to_value(&self.params).expect("parameters serialise");
        value.as_object_mut().expect("an object").insert("name".into(), Self::NAME.into());
        value
    }
}

#[cfg(test)]
#[path = "tests/tracking.rs"]
mod tests;
