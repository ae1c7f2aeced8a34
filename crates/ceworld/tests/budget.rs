//! The budget in the world's steps (issue 46): every optimiser that samples a world counts its
//! steps, stops once learning has taken `max_env_steps` (the iteration that reaches it cut after
//! a batch), counts the final evaluation's apart, gives the same count and result for any
//! thread count, resumes bit for bit, and refuses the budget on exact values.

#[path = "common/temp.rs"]
mod temp;

use ceworld::ce::budget::Budget;
use ceworld::ce::controller::{ValueKind, Valued, optimize_controller};
use ceworld::ce::random_search::{RandomSearch, RandomSearchConfig};
use ceworld::ce::stepped::{Rules, run_stepped};
use ceworld::rng::EngineRng;
use ceworld::{
    CeConfig, CeResult, Checkpointing, ControllerConfig, Flow, PomdpWorld, StopReason, TargetTracking, TrackingParams,
    World, optimize, optimize_with, random_policy,
};

/// `HORIZON` steps, never ended early: an episode is exactly `HORIZON` steps of the world.
struct Flat;

const HORIZON: usize = 10;

impl World for Flat {
    type State = f64;
    fn n_observations(&self) -> usize {
        2
    }
    fn n_decisions(&self) -> usize {
        2
    }
    fn horizon(&self) -> usize {
        HORIZON
    }
    fn reset(&self, _: &mut EngineRng) -> f64 {
        0.0
    }
    fn observe(&self, s: &f64, _: &mut EngineRng) -> usize {
        (*s as usize) % 2
    }
    fn step(&self, s: &mut f64, d: usize, _: &mut EngineRng) {
        *s += d as f64;
    }
    fn reward(&self, s: &f64) -> f64 {
        *s
    }
    fn to_json(&self) -> serde_json::Value {
        serde_json::json!({"name": "flat"})
    }
}

fn ce(samples: usize, steps: u64, threads: usize) -> CeConfig {
    CeConfig {
        samples,
        rho: 0.1,
        smoothing: 0.5,
        eval_episodes: 300,
        budget: Budget::steps(steps),
        threads: Some(threads),
        ..CeConfig::default()
    }
}

/// A history without its seconds.
fn shown(history: &[ceworld::IterationRecord]) -> Vec<(usize, f64, f64, u64)> {
    history.iter().map(|r| (r.iteration, r.mean, r.elite_mean, r.env_steps)).collect()
}

fn run_ce(config: &CeConfig) -> CeResult {
    optimize(&Flat, random_policy(&Flat, &[3], 1).unwrap(), config, |_| Flow::Continue).unwrap()
}

#[test]
fn episode_ce_counts_every_step_and_cuts_the_iteration_that_reaches_the_budget() {
    // Two whole iterations of 1000 episodes, then part of one: the third is cut where it reaches
    // the budget, after a group of 256 episodes and the 44 that the steps left cover.
    let per_iteration = (1000 * HORIZON) as u64;
    let r = run_ce(&ce(1000, 2 * per_iteration + 300 * HORIZON as u64, 1));
    assert_eq!(r.stop, StopReason::MaxEnvSteps);
    let steps: Vec<u64> = r.history.iter().map(|h| h.env_steps).collect();
    assert_eq!(steps, [per_iteration, 2 * per_iteration, 2 * per_iteration + (300 * HORIZON) as u64]);
    assert_eq!(r.env_steps, steps[2]);
    // The final evaluation's steps are counted apart: 300 episodes of HORIZON steps.
    assert_eq!(r.eval_env_steps, (300 * HORIZON) as u64);
    // The same count and the same policy whatever the thread count.
    let two = run_ce(&ce(1000, 2 * per_iteration + 300 * HORIZON as u64, 2));
    assert_eq!((two.policy, two.env_steps, shown(&two.history)), (r.policy.clone(), r.env_steps, shown(&r.history)));
    // A budget met by whole iterations stops after them.
    let whole = run_ce(&ce(1000, 2 * per_iteration, 1));
    assert_eq!((whole.history.len(), whole.env_steps, whole.stop), (2, 2 * per_iteration, StopReason::MaxEnvSteps));
    // Without a budget the steps are counted all the same.
    let free = run_ce(&CeConfig { budget: Budget::default(), max_iterations: Some(2), ..ce(1000, 1, 1) });
    assert_eq!((free.env_steps, free.stop), (2 * per_iteration, StopReason::MaxIterations));
    // Its two whole iterations are those of the run under a budget.
    assert_eq!(free.history[1].mean, r.history[1].mean);
}

#[test]
fn restarts_share_the_budget_in_steps() {
    // The first run converges in 13 iterations of 2000 steps, then its score takes 3000; the
    // second is stopped by the budget (its last iteration whole: 200 episodes are one cut), is
    // scored on the first slice of its selection episodes alone (the budget is spent), and no
    // third run starts.
    let config = CeConfig { restarts: 3, patience: 2, ..ce(200, 40_000, 1) };
    let r = run_ce(&config);
    let slice = (ceworld::evaluate::CLOSING_SLICE * HORIZON) as u64;
    assert!(r.env_steps >= 40_000 && r.env_steps <= 40_000 + 2000 + slice, "{}", r.env_steps);
    assert_eq!((r.stop, r.restart_scores.len()), (StopReason::MaxEnvSteps, 2));
}

fn tracking() -> TargetTracking {
    TargetTracking::with_params(TrackingParams { horizon: 20, ..Default::default() }).unwrap()
}

#[test]
fn a_run_under_a_budget_resumes_bit_for_bit() {
    let path = temp::TempPath::new("ceworld-budget", "ce.json");
    let w = tracking();
    let config = CeConfig { samples: 300, restarts: 2, patience: 3, ..ce(300, 300 * 20 * 9 + 100, 1) };
    let whole = optimize(&w, random_policy(&w, &[4, 3], 1).unwrap(), &config, |_| Flow::Continue).unwrap();
    let checkpointing = Checkpointing { path: path.to_path_buf(), every: 1e9, resume: true, outputs: Vec::new() };
    let (mut seen, mut sessions) = (0, 0);
    let resumed = loop {
        sessions += 1;
        let r = optimize_with(&w, random_policy(&w, &[4, 3], 1).unwrap(), &config, Some(&checkpointing), |_| {
            seen += 1;
            if [2, 5, 7].contains(&seen) { Flow::Stop } else { Flow::Continue }
        })
        .unwrap();
        if !r.interrupted() {
            break r;
        }
    };
    assert!(sessions > 2, "{sessions} sessions");
    assert_eq!(resumed.policy, whole.policy);
    assert_eq!(
        (resumed.env_steps, resumed.stop, shown(&resumed.history)),
        (whole.env_steps, whole.stop, shown(&whole.history))
    );
    assert_eq!(whole.stop, StopReason::MaxEnvSteps);
}

#[test]
fn the_controller_search_counts_its_steps_and_stops_on_its_budget() {
    let w = tracking();
    let config = ControllerConfig {
        nodes: 2,
        samples: 40,
        episodes: 30,
        eval_episodes: 100,
        budget: Budget::steps(5 * 40 * 30 * 20),
        ..ControllerConfig::defaults_for(ValueKind::Sampled)
    };
    let run = |threads| {
        let config = ControllerConfig { threads: Some(threads), ..config.clone() };
        optimize_controller(Valued::Sampled(&w), &config, |_| Flow::Continue).unwrap()
    };
    let one = run(1);
    assert_eq!(one.stop, StopReason::MaxEnvSteps);
    let last = one.history.last().unwrap();
    assert_eq!(last.record.env_steps, one.env_steps);
    // Its last iteration is cut where the steps left would not cover a selection of every
    // candidate (4 · 200 episodes), and passes the budget by one controller's episodes at most.
    let budget = 5 * 40 * 30 * 20;
    assert!(one.env_steps > budget - 4 * 200 * 20 && one.env_steps <= budget + 30 * 20, "{}", one.env_steps);
    // The iteration's episodes and selection's are all there is: a step a step of an episode.
    let episodes: u64 = one.history.iter().map(|h| h.episodes).sum();
    assert_eq!(one.env_steps, episodes * 20);
    assert_eq!(one.eval_env_steps, 100 * 20);
    let two = run(2);
    assert_eq!((two.policy, two.env_steps), (one.policy, one.env_steps));
}

#[test]
fn a_budget_in_steps_is_refused_on_exact_values() {
    let tiger =
        PomdpWorld::from_file(concat!(env!("CARGO_MANIFEST_DIR"), "/../../data/pomdp/tiger.95.POMDP"), 20, None)
            .expect("tiger");
    let config = ControllerConfig { budget: Budget::steps(1000), ..ControllerConfig::default() };
    let e = optimize_controller(Valued::Exact(&tiger), &config, |_| Flow::Continue).unwrap_err().to_string();
    assert!(e.contains("max_env_steps") && e.contains("exact values"), "{e}");
}

#[test]
fn a_stepped_optimiser_stops_on_its_budget_and_cuts_its_iteration() {
    let w = tracking();
    let config = RandomSearchConfig {
        nodes: 2,
        samples: 300,
        episodes: 10,
        rules: Rules { eval_episodes: 50, budget: Budget::steps(300 * 10 * 20 + 1), ..Rules::default() },
    };
    let out = run_stepped::<RandomSearch>(&w, &config, None, |_| Flow::Continue).unwrap();
    assert_eq!(out.stop, StopReason::MaxEnvSteps);
    assert_eq!(out.history.len(), 2);
    // The second iteration is cut after its first group of controllers: one, the least that
    // covers the step left.
    let first = 300 * 10 * 20;
    assert_eq!(out.history[0].env_steps, first);
    assert_eq!(out.env_steps, first + 10 * 20);
    assert_eq!(out.eval_env_steps, 50 * 20);
}

#[test]
fn the_controller_search_cuts_its_first_iteration_within_the_budget() {
    // 200 controllers of 20 episodes (20 steps each): 80,000 steps an iteration, where the
    // budget is 10,000. The first group is foreseen at the horizon, and the steps of the
    // selection (2 candidates · 20 episodes) and of the memoryless stage's bar (16 blind
    // policies · 20 episodes) are kept for them: 7 controllers, then the bar and the selection.
    let w = tracking();
    let config = ControllerConfig {
        nodes: 2,
        memory: ceworld::ce::controller::Memory::Nodes,
        samples: 200,
        episodes: 20,
        candidates: 2,
        select_episodes: 20,
        eval_episodes: 10,
        budget: Budget::steps(10_000),
        threads: Some(1),
        ..ControllerConfig::defaults_for(ValueKind::Sampled)
    };
    let r = optimize_controller(Valued::Sampled(&w), &config, |_| Flow::Continue).unwrap();
    assert_eq!((r.stop, r.history.len(), r.history[0].evaluated), (StopReason::MaxEnvSteps, 1, 7));
    assert_eq!(r.env_steps, 10_000);
    // 3,000 steps cover neither: one controller (400 steps), its selection (400: no best yet),
    // and the bar on the 6 episodes each blind policy the 2,200 steps left cover (1,920).
    let config = ControllerConfig { budget: Budget::steps(3000), ..config };
    let r = optimize_controller(Valued::Sampled(&w), &config, |_| Flow::Continue).unwrap();
    assert_eq!((r.stop, r.history.len(), r.history[0].evaluated), (StopReason::MaxEnvSteps, 1, 1));
    assert_eq!(r.env_steps, 400 + 400 + 16 * 6 * 20);
    // 1,000 steps and selections of 40 episodes: the selection (no best yet) on the 30 episodes
    // the 600 steps left cover, and the bar on one episode each (the least).
    let config = ControllerConfig { budget: Budget::steps(1000), select_episodes: 40, ..config };
    let r = optimize_controller(Valued::Sampled(&w), &config, |_| Flow::Continue).unwrap();
    assert_eq!(r.env_steps, 400 + 30 * 20 + 16 * 20);
}
