//! Episodes that end before the horizon (`World::done`), and worlds that run outside the engine
//! in lockstep batches (`episodes::outside`): one deterministic world written both ways gives the
//! same episodes, the same evaluation and the same optimisation, bit for bit, whatever the batch
//! size and the thread count; counting stops where an episode stopped; bad values from an
//! outside world are named by episode and step.

use ceworld::episodes::Shape;
use ceworld::episodes::outside::{BatchWorld, Lockstep, Recorded, StepOut, rollout};
use ceworld::episodes::run::{run_recorded, run_with};
use ceworld::evaluate::{rewards, rewards_of};
use ceworld::rng::{EngineRng, Purpose, stream};
use ceworld::{CeConfig, Checkpointing, Error, Flow, Interrupt, World, optimize, optimize_with, random_policy};
use serde_json::{Value, json};

#[path = "common/temp.rs"]
mod temp;

const HORIZON: usize = 10;

/// Three cells in a ring; decision `d` moves `d + 1` cells; a step is rewarded when `d` is the
/// cell's parity; the episode ends once 4 rewards are won (or at the horizon). Deterministic.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Ring {
    cell: usize,
    won: usize,
    t: usize,
}

fn ring_step(state: &mut Ring, d: usize) -> f64 {
    let reward = if d == state.cell % 2 { 1.0 } else { 0.0 };
    state.won += reward as usize;
    state.cell = (state.cell + d + 1) % 3;
    state.t += 1;
    reward
}

/// The ring world; with `stop`, every episode also ends after that many steps.
struct RingOf {
    horizon: usize,
    stop: Option<usize>,
}

const RING: RingOf = RingOf { horizon: HORIZON, stop: None };

impl World for RingOf {
    type State = Ring;
    fn n_observations(&self) -> usize {
        3
    }
    fn n_decisions(&self) -> usize {
        2
    }
    fn horizon(&self) -> usize {
        self.horizon
    }
    fn reset(&self, _: &mut EngineRng) -> Ring {
        Ring { cell: 0, won: 0, t: 0 }
    }
    fn observe(&self, state: &Ring, _: &mut EngineRng) -> usize {
        state.cell
    }
    fn step(&self, state: &mut Ring, d: usize, _: &mut EngineRng) {
        ring_step(state, d);
    }
    fn reward(&self, state: &Ring) -> f64 {
        state.won as f64
    }
    fn done(&self, state: &Ring) -> bool {
        state.won >= 4 || self.stop.is_some_and(|s| state.t >= s)
    }
    fn to_json(&self) -> Value {
        json!({"name": "ring"})
    }
}

/// The same world stepped in batches of at most `batch`, as Python code would.
struct RingBatch {
    batch: usize,
    states: Vec<Ring>,
    /// What to corrupt: (call number, episode in the batch, what).
    fault: Option<(usize, usize, Fault)>,
    calls: usize,
    /// A stop asked at these step calls (as Ctrl-C would, from another thread).
    requests: Vec<usize>,
    interrupt: Interrupt,
    /// A folder removed at this step call (the disk of a checkpoint gone).
    remove: Option<(usize, std::path::PathBuf)>,
}

#[derive(Clone, Copy)]
enum Fault {
    Observation,
    Reward,
}

impl RingBatch {
    fn new(batch: usize) -> RingBatch {
        RingBatch {
            batch,
            states: Vec::new(),
            fault: None,
            calls: 0,
            requests: Vec::new(),
            interrupt: Interrupt::default(),
            remove: None,
        }
    }
}

impl BatchWorld for RingBatch {
    fn shape(&self) -> Shape {
        Shape { observations: 3, decisions: 2, horizon: HORIZON }
    }
    fn description(&self) -> Value {
        json!({"name": "outside", "class": "tests.RingBatch"})
    }
    fn max_batch(&self) -> usize {
        self.batch
    }
    fn reset(&mut self, _seed: u64, observations: &mut [i64]) -> ceworld::Result<()> {
        self.states = vec![Ring { cell: 0, won: 0, t: 0 }; observations.len()];
        observations.fill(0);
        Ok(())
    }
    fn step(&mut self, decisions: &[i64], out: StepOut<'_>) -> ceworld::Result<()> {
        self.calls += 1;
        if self.requests.contains(&self.calls) {
            self.interrupt.request();
        }
        if let Some((_, dir)) = self.remove.as_ref().filter(|(call, _)| *call == self.calls) {
            std::fs::remove_dir_all(dir).unwrap();
        }
        for (i, state) in self.states.iter_mut().enumerate() {
            out.rewards[i] = ring_step(state, decisions[i] as usize);
            out.observations[i] = state.cell as i64;
            out.done[i] = state.won >= 4;
            match self.fault {
                Some((call, episode, Fault::Observation)) if call == self.calls && episode == i => {
                    out.observations[i] = 3;
                }
                Some((call, episode, Fault::Reward)) if call == self.calls && episode == i => out.rewards[i] = f64::NAN,
                _ => {}
            }
        }
        Ok(())
    }
}

fn config(threads: usize) -> CeConfig {
    CeConfig {
        samples: 200,
        rho: 0.1,
        smoothing: 0.5,
        max_iterations: Some(6),
        threads: Some(threads),
        eval_episodes: 500,
        ..CeConfig::default()
    }
}

#[test]
fn an_episode_stops_where_the_world_ends_it() {
    let policy = random_policy(&RING, &[3, 2], 1).unwrap();
    let width = policy.layout().record_width();
    let mut lengths = Vec::new();
    for k in 0..200 {
        let mut record = vec![u16::MAX; HORIZON * width];
        let (value, steps) = run_recorded(&RING, &policy, &mut stream(0, Purpose::Optimise, 0, k), &mut record);
        let mut visited = 0;
        let v = run_with(&RING, &policy, &mut stream(0, Purpose::Optimise, 0, k), |_, _, _, _, _| visited += 1);
        assert_eq!((v, visited), (value, steps));
        // Ended by the world (4 rewards, on the last step) or by the horizon; nothing written after.
        assert!(value == 4.0 && steps <= HORIZON || value < 4.0 && steps == HORIZON, "{value} in {steps} steps");
        assert!(record[steps * width..].iter().all(|&x| x == u16::MAX));
        lengths.push(steps);
    }
    assert!(lengths.iter().any(|&s| s < HORIZON) && lengths.contains(&HORIZON), "{lengths:?}");
}

#[test]
fn counting_stops_where_the_episode_stopped() {
    // Episodes that the world ends after 4 steps of 10 are counted as episodes of 4 steps: the
    // optimisation is that of the same world with a horizon of 4, bit for bit. Counting the
    // rows after the end (left from earlier episodes) would change the tables.
    let short = RingOf { horizon: 4, stop: None };
    let stopped = RingOf { horizon: HORIZON, stop: Some(4) };
    let initial = random_policy(&short, &[3, 2], 8).unwrap();
    let a = optimize(&short, initial.clone(), &config(2), |_| Flow::Continue).unwrap();
    let b = optimize(&stopped, initial.clone(), &config(2), |_| Flow::Continue).unwrap();
    assert_eq!((&a.policy, &a.last_policy, &a.evaluation), (&b.policy, &b.last_policy, &b.evaluation));
    let full = optimize(&RING, initial, &config(2), |_| Flow::Continue).unwrap();
    assert_ne!(full.last_policy, b.last_policy);
}

#[test]
fn a_batched_world_gives_the_engines_episodes_bit_for_bit() {
    let policy = random_policy(&RING, &[3, 2], 4).unwrap();
    let engine = rewards(&RING, &policy, 100, 9).unwrap();
    for batch in [1, 7, 64, 1000] {
        let outside = Lockstep::new(RingBatch::new(batch)).unwrap();
        assert_eq!(rewards(&outside, &policy, 100, 9).unwrap(), engine, "batch {batch}");
        // A slice that starts on a multiple of the batch size gives the same episodes.
        let start = if batch < 100 { batch } else { 0 };
        assert_eq!(rewards_of(&outside, &policy, start..100, 9).unwrap(), engine[start..], "batch {batch}");
        for k in [0u64, 5, 63] {
            let alone = rollout(&outside, &policy, 9, k).unwrap();
            let reference = ceworld::evaluate::rollout(&RING, &policy, 9, k).unwrap();
            assert_eq!(
                (&alone.y, &alone.d, &alone.memory, alone.reward),
                (&reference.y, &reference.d, &reference.memory, reference.reward)
            );
        }
    }
}

#[test]
fn a_batched_world_is_optimised_as_the_engine_would_whatever_the_threads() {
    let initial = random_policy(&RING, &[3, 2], 4).unwrap();
    let engine = optimize(&RING, initial.clone(), &config(2), |_| Flow::Continue).unwrap();
    for (batch, threads) in [(1, 1), (16, 2), (200, 1), (200, 2)] {
        let outside = Lockstep::new(RingBatch::new(batch)).unwrap();
        let result = optimize(&outside, initial.clone(), &config(threads), |_| Flow::Continue).unwrap();
        let means = |r: &ceworld::CeResult| -> Vec<_> {
            r.history.iter().map(|i| (i.mean, i.best, i.elite_threshold, i.elite_mean, i.successful)).collect()
        };
        assert_eq!(means(&result), means(&engine), "batch {batch}, threads {threads}");
        assert_eq!(result.policy, engine.policy, "batch {batch}, threads {threads}");
        assert_eq!(result.evaluation, engine.evaluation);
    }
}

#[test]
fn bad_values_from_an_outside_world_are_named_by_episode_and_step() {
    let policy = random_policy(&RING, &[2], 1).unwrap();
    for (fault, expected) in [(Fault::Observation, "observation 3 (expected 0..3)"), (Fault::Reward, "reward NaN")] {
        let mut world = RingBatch::new(8);
        // The third call of `step` returned the bad value: named "step 3" either way.
        world.fault = Some((3, 5, fault));
        let e = rewards(&Lockstep::new(world).unwrap(), &policy, 20, 0).unwrap_err();
        let step = 3;
        let message = e.to_string();
        assert!(matches!(e, Error::World(_)), "{message}");
        assert!(
            message.contains(&format!("world tests.RingBatch, episode 5 (evaluate), step {step}: {expected}")),
            "{message}"
        );
    }
}

struct Scored(RingBatch);

impl BatchWorld for Scored {
    fn shape(&self) -> Shape {
        self.0.shape()
    }
    fn description(&self) -> Value {
        self.0.description()
    }
    fn max_batch(&self) -> usize {
        self.0.max_batch()
    }
    fn reset(&mut self, seed: u64, observations: &mut [i64]) -> ceworld::Result<()> {
        self.0.reset(seed, observations)
    }
    fn step(&mut self, decisions: &[i64], out: StepOut<'_>) -> ceworld::Result<()> {
        self.0.step(decisions, out)
    }
    /// Not additive: the number of steps with decision 1, minus the episode's length.
    fn score(&mut self, episode: &Recorded<'_>) -> ceworld::Result<f64> {
        let ones = episode.decisions().filter(|&d| d == 1).count();
        assert_eq!(episode.observations().count(), episode.rewards.len());
        Ok(ones as f64 - episode.rewards.len() as f64)
    }
}

#[test]
fn a_score_sees_the_whole_recorded_episode() {
    let policy = random_policy(&RING, &[2], 3).unwrap();
    let values = rewards(&Lockstep::new(Scored(RingBatch::new(16))).unwrap(), &policy, 50, 2).unwrap();
    for (k, value) in values.iter().enumerate() {
        let r = ceworld::evaluate::rollout(&RING, &policy, 2, k as u64).unwrap();
        let ones = r.d.iter().filter(|&&d| d == 1).count();
        assert_eq!(*value, ones as f64 - r.len() as f64, "episode {k}");
    }
}

#[test]
fn outside_worlds_of_impossible_shapes_are_refused() {
    struct Empty(usize, usize);
    impl BatchWorld for Empty {
        fn shape(&self) -> Shape {
            Shape { observations: self.0, decisions: 2, horizon: self.1 }
        }
        fn description(&self) -> Value {
            json!({"class": "Empty"})
        }
        fn max_batch(&self) -> usize {
            1
        }
        fn reset(&mut self, _: u64, _: &mut [i64]) -> ceworld::Result<()> {
            Ok(())
        }
        fn step(&mut self, _: &[i64], _: StepOut<'_>) -> ceworld::Result<()> {
            Ok(())
        }
    }
    for (observations, horizon, expected) in
        [(0, 5, "invalid world Empty observations: 0"), (70_000, 5, "70000"), (3, 0, "invalid world Empty horizon: 0")]
    {
        let e = Lockstep::new(Empty(observations, horizon)).err().expect("refused").to_string();
        assert!(e.contains(expected), "{e}");
    }
}

#[test]
fn horizons_and_batches_beyond_the_memory_are_refused_before_allocating() {
    struct Long(usize, usize);
    impl BatchWorld for Long {
        fn shape(&self) -> Shape {
            Shape { observations: 2, decisions: 2, horizon: self.0 }
        }
        fn description(&self) -> Value {
            json!({"class": "Long"})
        }
        fn max_batch(&self) -> usize {
            self.1
        }
        fn reset(&mut self, _: u64, _: &mut [i64]) -> ceworld::Result<()> {
            Ok(())
        }
        fn step(&mut self, _: &[i64], _: StepOut<'_>) -> ceworld::Result<()> {
            Ok(())
        }
    }
    let e = Lockstep::new(Long(1 << 62, 1)).err().expect("refused").to_string();
    assert!(e.contains("invalid world Long horizon: 4611686018427387904 (expected 1..=1000000 steps)"), "{e}");
    // 10^6 steps for a batch of 10^6 episodes: 8 TB of step rewards, refused by the memory check.
    let world = Lockstep::new(Long(1_000_000, 1_000_000_000)).unwrap();
    let policy = random_policy(&world, &[2], 0).unwrap();
    let e = rewards(&world, &policy, 1_000_000, 0).unwrap_err();
    assert!(matches!(e, Error::Memory { .. }), "{e}");
}

/// A small sampled controller search's settings; the decisions refitted from the elite, as on
/// the engine's ring, whose steps have no rewards of their own (tests/credit.rs has the credit).
fn search(threads: usize) -> ceworld::ControllerConfig {
    ceworld::ControllerConfig {
        credit: ceworld::ce::controller::Credit::Elite,
        nodes: 3,
        samples: 60,
        rho: 0.1,
        max_iterations: Some(5),
        episodes: 7,
        candidates: 2,
        select_episodes: 20,
        eval_episodes: 50,
        threads: Some(threads),
        ..ceworld::ControllerConfig::default()
    }
}

#[test]
fn controllers_are_valued_and_searched_as_the_engine_would_whatever_the_batch_and_threads() {
    use ceworld::ce::controller::{Controller, Valued, optimize_controller};
    use ceworld::episodes::{Episodes, Streams};
    let controllers: Vec<Controller> = (0..5u32)
        .map(|k| Controller::moore(vec![k % 2, (k / 2) % 2, 1], (0..9).map(|i| (i * 7 + k) % 3).collect()))
        .collect();
    let streams = Streams { seed: 4, purpose: Purpose::Controllers, iteration: 2 };
    let mut engine = vec![0.0; 5 * 6];
    RING.run_controllers(&controllers, streams, 6, &mut engine).unwrap();
    // Each value is the controller's HHMM played in the ring (a deterministic world).
    for (c, values) in controllers.iter().zip(engine.chunks(6)) {
        let policy = c.to_hhmm(3, 2).unwrap();
        let v = run_with(&RING, &policy, &mut stream(0, Purpose::Evaluate, 0, 0), |_, _, _, _, _| {});
        assert!(values.iter().all(|&x| x == v), "{values:?} vs {v}");
    }
    // 400 controllers: valued in groups of about 1024 episodes, whole batches each.
    let search = |threads| ceworld::ControllerConfig { samples: 400, ..search(threads) };
    let reference = optimize_controller(Valued::Sampled(&RING), &search(2), |_| Flow::Continue).unwrap();
    for (batch, threads) in [(1, 1), (4, 2), (6, 1), (7, 2), (1000, 2)] {
        let outside = Lockstep::new(RingBatch::new(batch)).unwrap();
        let mut values = vec![0.0; 5 * 6];
        outside.run_controllers(&controllers, streams, 6, &mut values).unwrap();
        assert_eq!(values, engine, "batch {batch}");
        let found = optimize_controller(Valued::Sampled(&outside), &search(threads), |_| Flow::Continue).unwrap();
        assert_eq!(
            (&found.policy, found.value, &found.history.iter().map(|r| r.best_so_far).collect::<Vec<_>>()),
            (&reference.policy, reference.value, &reference.history.iter().map(|r| r.best_so_far).collect::<Vec<_>>()),
            "batch {batch}, threads {threads}"
        );
    }
}

/// Records the seed of every reset, one entry per episode.
struct Seeds {
    batch: usize,
    seeds: Vec<u64>,
}

impl BatchWorld for Seeds {
    fn shape(&self) -> Shape {
        Shape { observations: 1, decisions: 1, horizon: 2 }
    }
    fn description(&self) -> Value {
        json!({"name": "outside", "class": "tests.Seeds"})
    }
    fn max_batch(&self) -> usize {
        self.batch
    }
    fn reset(&mut self, seed: u64, observations: &mut [i64]) -> ceworld::Result<()> {
        self.seeds.extend(std::iter::repeat_n(seed, observations.len()));
        observations.fill(0);
        Ok(())
    }
    fn step(&mut self, _: &[i64], out: StepOut<'_>) -> ceworld::Result<()> {
        out.observations.fill(0);
        out.rewards.fill(0.0);
        Ok(())
    }
}

#[test]
fn every_controller_is_valued_on_the_same_world_seeds() {
    use ceworld::ce::controller::Controller;
    use ceworld::episodes::{Episodes, Streams};
    let controllers = vec![Controller::moore(vec![0], vec![0]); 3];
    let streams = Streams { seed: 1, purpose: Purpose::Controllers, iteration: 0 };
    for (batch, episodes) in [(1, 4), (2, 3), (3, 3), (8, 3), (5, 2)] {
        let world = Lockstep::new(Seeds { batch, seeds: Vec::new() }).unwrap();
        world.run_controllers(&controllers, streams, episodes, &mut vec![0.0; 3 * episodes]).unwrap();
        let seeds = world.into_inner().seeds;
        assert_eq!(seeds.len(), 3 * episodes);
        // Episode k of every controller was reset with the same seed.
        for k in 0..episodes {
            let first = seeds[k];
            assert!((0..3).all(|c| seeds[c * episodes + k] == first), "batch {batch}: {seeds:?}");
        }
        // With one episode a batch, the episodes of one controller have seeds of their own.
        if batch == 1 {
            let mut own = seeds[..episodes].to_vec();
            own.dedup();
            assert_eq!(own.len(), episodes, "{seeds:?}");
        }
    }
}

/// The ring in batches of `batch`, a stop asked at the step calls `requests`.
fn interrupted_ring(batch: usize, requests: &[usize]) -> Lockstep<RingBatch> {
    let interrupt = Interrupt::default();
    let world = RingBatch { requests: requests.to_vec(), interrupt: interrupt.clone(), ..RingBatch::new(batch) };
    Lockstep::new(world).unwrap().interruptible(interrupt)
}

#[test]
fn a_stop_cuts_the_iteration_between_two_steps_and_a_resumed_run_draws_it_again() {
    // Batches of 50 episodes of 10 steps: 40 step calls an iteration (fewer where every
    // episode of a batch ends early). A stop asked at call 100 cuts the third iteration.
    let initial = random_policy(&RING, &[3, 2], 4).unwrap();
    let reference = optimize(&RING, initial.clone(), &config(2), |_| Flow::Continue).unwrap();
    let path = temp::TempPath::new("ceworld-interrupt", "run.ckpt");
    let checkpointing = Checkpointing { path: path.to_path_buf(), every: 1e9, resume: true, outputs: Vec::new() };
    let world = interrupted_ring(50, &[100]);
    let cut = optimize_with(&world, initial.clone(), &config(2), Some(&checkpointing), |_| Flow::Continue).unwrap();
    assert!(cut.interrupted() && (1..6).contains(&cut.history.len()), "{} iterations", cut.history.len());
    let means = |r: &ceworld::CeResult| r.history.iter().map(|i| (i.mean, i.elite_threshold)).collect::<Vec<_>>();
    assert_eq!(means(&cut)[..], means(&reference)[..cut.history.len()]);
    // The best policy is still evaluated, for at most the grace (the ring is fast: in full).
    assert_eq!(cut.evaluation.episodes, 500);
    let resumed = optimize_with(&interrupted_ring(50, &[]), initial.clone(), &config(2), Some(&checkpointing), |_| {
        Flow::Continue
    })
    .unwrap();
    assert!(!resumed.interrupted());
    assert_eq!((&resumed.policy, &resumed.last_policy), (&reference.policy, &reference.last_policy));
    assert_eq!(resumed.evaluation, reference.evaluation);
    // A stop in the first iteration leaves nothing to return; a second one aborts at once.
    let early = optimize(&interrupted_ring(50, &[3]), initial.clone(), &config(2), |_| Flow::Continue);
    assert!(matches!(early, Err(Error::Interrupted)), "{early:?}");
    let interrupt = Interrupt::default();
    interrupt.request();
    interrupt.request();
    let outside = Lockstep::new(RingBatch::new(50)).unwrap().interruptible(interrupt);
    assert!(matches!(rewards(&outside, &initial, 100, 0), Err(Error::Interrupted)));
}

#[test]
fn a_stop_cuts_a_controller_search_and_keeps_its_best_so_far() {
    use ceworld::ce::controller::{Valued, optimize_controller};
    let reference = optimize_controller(Valued::Sampled(&RING), &search(2), |_| Flow::Continue).unwrap();
    // 60 controllers × 7 episodes in batches of 7: 600 step calls an iteration at most.
    let world = interrupted_ring(7, &[1500]);
    let cut = optimize_controller(Valued::Sampled(&world), &search(2), |_| Flow::Continue).unwrap();
    assert_eq!(cut.stop, ceworld::StopReason::Interrupted);
    assert!((1..5).contains(&cut.history.len()), "{} iterations", cut.history.len());
    let best_so_far = |o: &ceworld::ControllerOutcome| o.history.iter().map(|r| r.best_so_far).collect::<Vec<_>>();
    assert_eq!(best_so_far(&cut)[..], best_so_far(&reference)[..cut.history.len()]);
    let early = optimize_controller(Valued::Sampled(&interrupted_ring(7, &[3])), &search(2), |_| Flow::Continue);
    assert!(matches!(early, Err(Error::Interrupted)));
}

#[test]
fn a_checkpoint_that_cannot_be_written_does_not_cost_the_result() {
    // The checkpoint's folder disappears in the third iteration (as a full or lost disk): the
    // run goes on, returns the uninterrupted result, and says why the checkpoint failed.
    let initial = random_policy(&RING, &[3, 2], 4).unwrap();
    let reference = optimize(&RING, initial.clone(), &config(2), |_| Flow::Continue).unwrap();
    assert_eq!(reference.checkpoint_error, None);
    let dir = temp::TempPath::new("ceworld-lost-disk", "sub");
    std::fs::create_dir(&*dir).unwrap();
    let path = dir.join("run.ckpt");
    for every in [1e9, 0.0001] {
        std::fs::create_dir_all(&*dir).unwrap();
        let checkpointing = Checkpointing { path: path.clone(), every, resume: false, outputs: Vec::new() };
        let world = Lockstep::new(RingBatch { remove: Some((100, dir.to_path_buf())), ..RingBatch::new(50) }).unwrap();
        let result =
            optimize_with(&world, initial.clone(), &config(2), Some(&checkpointing), |_| Flow::Continue).unwrap();
        assert_eq!((&result.policy, &result.evaluation), (&reference.policy, &reference.evaluation));
        let error = result.checkpoint_error.expect("the failure is told");
        assert!(error.contains("run.ckpt") && !error.contains(".tmp"), "{error}");
        assert!(!path.exists());
    }
}
