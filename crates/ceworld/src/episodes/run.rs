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

/// Runs one episode of `world` under the deterministic `controller` and returns `V`: the
/// randomness of `rng` is the world's alone.
#[inline]
pub fn run_controller<W: World>(world: &W, controller: &Controller, rng: &mut EngineRng) -> f64 {
    let n_obs = world.n_observations();
    let mut state = world.reset(rng);
    let mut node = 0u32;
    for _ in 0..world.horizon() {
        let y = world.observe(&state, rng);
        node = controller.next_node(node, y, n_obs);
        world.step(&mut state, controller.act[node as usize] as usize, rng);
        if world.done(&state) {
            break;
        }
    }
    world.reward(&state)
}
