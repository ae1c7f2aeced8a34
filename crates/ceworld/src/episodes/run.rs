//! One episode of world × policy (recorded compactly for counting, or visited step by step), and
//! one episode of world × deterministic controller.

use crate::policy::Hhmm;
use crate::policy::controller::Controller;
use crate::rng::EngineRng;
use crate::world::World;

/// One recorded episode: step `t` is row `t` of every table.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Rollout {
    /// Names of the numbers of one hidden state ([`World::state_labels`]).
    pub x_labels: Vec<&'static str>,
    /// The hidden state `x_t` as [`World::describe`] writes it, `T × x_labels.len()`, row-major.
    pub x: Vec<i64>,
    /// Observations `y_t`.
    pub y: Vec<i64>,
    /// Decisions `d_t`.
    pub d: Vec<i64>,
    /// Memory states `m_1[t] .. m_Λ[t]`, `T × Λ`, row-major.
    pub memory: Vec<i64>,
    /// Number of levels `Λ` (columns of `memory`).
    pub levels: usize,
    /// The episode's reward `V`.
    pub reward: f64,
}

impl Rollout {
    /// Number of steps recorded.
    pub fn len(&self) -> usize {
        self.y.len()
    }

    /// Whether no step was recorded.
    pub fn is_empty(&self) -> bool {
        self.y.is_empty()
    }
}

/// The memory `m_1..m_Λ` of one episode: on the stack up to 16 levels (no allocation per
/// episode), on the heap beyond.
struct Memory {
    inline: [u16; 16],
    heap: Vec<u16>,
    depth: usize,
}

impl Memory {
    #[inline]
    fn new(depth: usize) -> Memory {
        Memory { inline: [0; 16], heap: if depth > 16 { vec![0; depth] } else { Vec::new() }, depth }
    }

    #[inline]
    fn as_mut(&mut self) -> &mut [u16] {
        if self.depth <= 16 { &mut self.inline[..self.depth] } else { &mut self.heap }
    }
}

/// Runs one episode, writing step `t`'s `[y, d, m_1, ..., m_Λ]` at
/// `record[t * width .. (t + 1) * width]` (`width = Layout::record_width`), and returns `V` and
/// the number of steps run: the horizon, or fewer where the world ended the episode
/// ([`World::done`]); the rows after them are left as they were.
#[inline]
pub fn run_recorded<W: World>(world: &W, policy: &Hhmm, rng: &mut EngineRng, record: &mut [u16]) -> (f64, usize) {
    let width = policy.layout().record_width();
    let mut buffer = Memory::new(width - 2);
    let memory = buffer.as_mut();
    let mut state = world.reset(rng);
    let mut steps = 0;
    for (t, step) in record.chunks_exact_mut(width).take(world.horizon()).enumerate() {
        let y = world.observe(&state, rng);
        let d = policy.step(y, memory, t == 0, rng);
        step[0] = y as u16;
        step[1] = d as u16;
        // An element loop: `copy_from_slice` calls memmove for these two-to-five-element copies.
        for (slot, &m) in step[2..].iter_mut().zip(memory.iter()) {
            *slot = m;
        }
        world.step(&mut state, d, rng);
        steps = t + 1;
        if world.done(&state) {
            break;
        }
    }
    (world.reward(&state), steps)
}

/// Runs one episode and returns `V`, calling `visit(t, y_t, d_t, m[t], x_t)` at every step
/// (`t` from 0), before the world moves; the episode stops at the horizon or where the world
/// ends it ([`World::done`]).
#[inline]
pub fn run_with<W: World, F>(world: &W, policy: &Hhmm, rng: &mut EngineRng, mut visit: F) -> f64
where
    F: FnMut(usize, usize, usize, &[u16], &W::State),
{
    let mut buffer = Memory::new(policy.levels().len());
    let memory = buffer.as_mut();
    let mut state = world.reset(rng);
    for t in 0..world.horizon() {
        let y = world.observe(&state, rng);
        let d = policy.step(y, memory, t == 0, rng);
        visit(t, y, d, memory, &state);
        world.step(&mut state, d, rng);
        if world.done(&state) {
            break;
        }
    }
    world.reward(&state)
}

/// Runs episode `episode` of `controller` in `world` and returns `V` and the number of steps
/// run: the randomness of `rng` is the world's alone (an explorer's draws are its own,
/// [`Controller::walk`]).
#[inline]
pub fn run_controller<W: World>(world: &W, controller: &Controller, episode: u64, rng: &mut EngineRng) -> (f64, usize) {
    run_controller_with(world, controller, episode, rng, |_, _| {})
}

/// [`run_controller`], calling `seen(y, state)` after each step with its observation and the
/// state the step left.
#[inline]
pub fn run_controller_with<W: World>(
    world: &W,
    controller: &Controller,
    episode: u64,
    rng: &mut EngineRng,
    mut seen: impl FnMut(usize, &W::State),
) -> (f64, usize) {
    let mut walk = controller.walk(world.n_observations(), episode);
    let mut state = world.reset(rng);
    let mut steps = 0;
    for t in 0..world.horizon() {
        let y = world.observe(&state, rng);
        let (d, _) = walk.step(y);
        world.step(&mut state, d as usize, rng);
        seen(y, &state);
        steps = t + 1;
        if world.done(&state) {
            break;
        }
    }
    (world.reward(&state), steps)
}

/// [`run_controller`] keeping each step's (observation, reward), for a world whose reward is
/// the discounted sum of its steps' (`gamma`, [`World::discount`]): a step's reward is what it
/// added to the sum, over its discount.
pub fn run_controller_steps<W: World>(
    world: &W,
    controller: &Controller,
    episode: u64,
    rng: &mut EngineRng,
    gamma: f64,
) -> (f64, Vec<(usize, f64)>) {
    let (mut kept, mut sum, mut factor) = (Vec::new(), 0.0, 1.0);
    let (value, _) = run_controller_with(world, controller, episode, rng, |y, state| {
        let now = world.reward(state);
        kept.push((y, if factor > 0.0 { (now - sum) / factor } else { 0.0 }));
        (sum, factor) = (now, factor * gamma);
    });
    (value, kept)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::{Purpose, stream};

    /// Observation `t mod 2`; a step pays 1 when its decision is the observation; the value adds
    /// half a point per step run, so that where an episode stops shows; it may stop after
    /// `stop` steps.
    struct Parity {
        stop: Option<usize>,
    }

    impl World for Parity {
        type State = (usize, f64);
        fn n_observations(&self) -> usize {
            2
        }
        fn n_decisions(&self) -> usize {
            2
        }
        fn horizon(&self) -> usize {
            4
        }
        fn reset(&self, _: &mut EngineRng) -> (usize, f64) {
            (0, 0.0)
        }
        fn observe(&self, state: &(usize, f64), _: &mut EngineRng) -> usize {
            state.0 % 2
        }
        fn step(&self, state: &mut (usize, f64), decision: usize, _: &mut EngineRng) {
            state.1 += f64::from(u8::from(decision == state.0 % 2)) + 0.5;
            state.0 += 1;
        }
        fn reward(&self, state: &(usize, f64)) -> f64 {
            state.1
        }
        fn done(&self, state: &(usize, f64)) -> bool {
            self.stop.is_some_and(|s| state.0 >= s)
        }
        fn to_json(&self) -> serde_json::Value {
            serde_json::json!({"name": "parity"})
        }
    }

    #[test]
    fn a_controller_moves_on_each_observation_and_stops_where_the_world_ends() {
        let rng = &mut stream(0, Purpose::Evaluate, 0, 0);
        // Node 1 + y after observation y, whose decision is y: every step pays.
        let echo = Controller::moore(vec![1, 0, 1], vec![1, 2, 1, 2, 1, 2]);
        // Node 0 forever, deciding 1: the odd steps pay.
        let stuck = Controller::moore(vec![1, 0, 0], vec![0; 6]);
        let whole = Parity { stop: None };
        assert_eq!(run_controller(&whole, &echo, 0, rng), (4.0 + 2.0, 4));
        assert_eq!(run_controller(&whole, &stuck, 0, rng), (2.0 + 2.0, 4));
        let short = Parity { stop: Some(3) };
        assert_eq!(run_controller(&short, &echo, 0, rng), (3.0 + 1.5, 3));
        // The same as the controller's HHMM, step by step, and as a rollout.
        let rollout = crate::evaluate::rollout(&short, &echo.to_hhmm(2, 2).unwrap(), 0, 0).unwrap();
        assert_eq!((rollout.len(), rollout.is_empty(), rollout.reward), (3, false, 4.5));
        assert_eq!((&rollout.y, &rollout.d), (&vec![0, 1, 0], &vec![0, 1, 0]));
        let empty = Rollout { y: Vec::new(), ..rollout };
        assert!(empty.is_empty());
        let policy = echo.to_hhmm(2, 2).unwrap();
        assert_eq!(run_with(&short, &policy, rng, |_, _, _, _, _| {}), 4.5);
    }

    #[test]
    fn a_controller_s_steps_are_kept_with_what_each_added_over_its_discount() {
        let rng = &mut stream(0, Purpose::Evaluate, 0, 0);
        // Node 0 forever, deciding 1: the steps add 0.5, 1.5, 0.5, 1.5 (the odd ones pay).
        let stuck = Controller::moore(vec![1], vec![0; 2]);
        let whole = Parity { stop: None };
        let kept = |gamma: f64| run_controller_steps(&whole, &stuck, 0, &mut rng.clone(), gamma);
        assert_eq!(kept(1.0), (4.0, vec![(0, 0.5), (1, 1.5), (0, 0.5), (1, 1.5)]));
        // Read as a sum discounted by 1/2: step t added r_t / 2^t.
        assert_eq!(kept(0.5), (4.0, vec![(0, 0.5), (1, 3.0), (0, 2.0), (1, 12.0)]));
        // Discounted to nothing after the first step: what the later steps added is not theirs.
        assert_eq!(kept(0.0), (4.0, vec![(0, 0.5), (1, 0.0), (0, 0.0), (1, 0.0)]));
        // An episode that stops keeps the steps it ran.
        let (value, steps) = run_controller_steps(&Parity { stop: Some(3) }, &stuck, 0, rng, 1.0);
        assert_eq!((value, steps.len()), (2.5, 3));
    }
}
