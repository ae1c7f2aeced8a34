//! The cross-entropy search over deterministic controllers (model §8): the value of a controller
//! against a hand computation and against the exact evaluation of its HHMM, the search against
//! brute force on a tiny problem, determinism, restarts, interruption and bad settings.

use ceworld::ce::budget::Budget;
use ceworld::ce::controller::{
    Controller, ControllerConfig, ControllerValue, Scratch, Valued, improve, optimize_controller,
};
use ceworld::exact::{finite_horizon, infinite_horizon};
use ceworld::rng::{Purpose, stream};
use ceworld::{Error, Flow, PomdpWorld, StopReason};
use rand::RngExt;

#[path = "common/sessions.rs"]
mod sessions;

fn data(name: &str) -> String {
    format!("{}/../../data/pomdp/{name}", env!("CARGO_MANIFEST_DIR"))
}

fn world(name: &str, horizon: usize, discount: Option<f64>) -> PomdpWorld {
    PomdpWorld::from_file(data(name), horizon, discount).unwrap()
}

fn value(world: &PomdpWorld, c: &Controller, tolerance: f64) -> f64 {
    ControllerValue::new(world, tolerance).value(c, &mut Scratch::default())
}

/// A random deterministic controller of `n` nodes.
fn random_controller(world: &PomdpWorld, n: usize, k: u64) -> Controller {
    let t = world.tables();
    let y1 = t.n_observations() + 1;
    let mut rng = stream(7, Purpose::Evaluate, 0, k);
    Controller::moore(
        (0..n).map(|_| rng.random_range(0..t.n_actions() as u32)).collect(),
        (0..n * y1).map(|_| rng.random_range(0..n as u32)).collect(),
    )
}

/// A random Mealy machine of `n` nodes.
fn random_mealy(world: &PomdpWorld, n: usize, k: u64) -> Controller {
    let t = world.tables();
    let y1 = t.n_observations() + 1;
    let mut rng = stream(8, Purpose::Evaluate, 0, k);
    Controller::mealy(
        (0..n * y1).map(|_| rng.random_range(0..t.n_actions() as u32)).collect(),
        (0..n * y1).map(|_| rng.random_range(0..n as u32)).collect(),
        y1,
    )
}

const LISTEN: u32 = 0;
const OPEN_LEFT: u32 = 1;
const OPEN_RIGHT: u32 = 2;

#[test]
fn values_by_hand_on_tiger() {
    let tiger = world("tiger.95.POMDP", 10, None);
    // One node that always listens: −1 a step, −1/(1 − 0.95) = −20.
    let listen = Controller::moore(vec![LISTEN], vec![0, 0, 0]);
    assert!((value(&tiger, &listen, 1e-10) - -20.0).abs() < 1e-9);
    // Listen, then open the door opposite to what was heard, then start again: from either
    // state, v = −1 + 0.95·(0.85·10 + 0.15·(−100)) + 0.95²·v, so v = −7.175 / (1 − 0.9025).
    let once = Controller::moore(vec![LISTEN, OPEN_RIGHT, OPEN_LEFT], vec![1, 2, 0, 0, 0, 0, 0, 0, 0]);
    let expected = (-1.0 + 0.95 * (0.85 * 10.0 + 0.15 * -100.0)) / (1.0 - 0.95 * 0.95);
    assert!((value(&tiger, &once, 1e-10) - expected).abs() < 1e-8, "{}", value(&tiger, &once, 1e-10));
    // At a horizon with γ = 1: two steps of "listen, open" give −1 − 6.5.
    let tiger2 = world("tiger.95.POMDP", 2, Some(1.0));
    assert!((value(&tiger2, &once, 1e-10) - (-1.0 - 6.5)).abs() < 1e-12);
}

#[test]
fn the_value_is_the_exact_value_of_the_controllers_hhmm() {
    for (name, n) in [("tiger.95.POMDP", 3), ("4x3.95.POMDP", 4), ("cheese.95.POMDP", 5), ("shuttle.95.POMDP", 3)] {
        let w = world(name, 7, None);
        let t = w.tables();
        for k in 0..5 {
            let c = random_controller(&w, n, k);
            let policy = c.to_hhmm(t.n_observations() + 1, t.n_actions()).unwrap();
            let exact = infinite_horizon(&w, &policy, 1e-9).unwrap().value;
            let v = value(&w, &c, 1e-9);
            assert!((v - exact).abs() < 1e-7, "{name} controller {k}: {v} vs {exact}");
        }
        // With γ = 1, the value at the world's horizon.
        let undiscounted = world(name, 7, Some(1.0));
        let c = random_controller(&undiscounted, n, 9);
        let policy = c.to_hhmm(t.n_observations() + 1, t.n_actions()).unwrap();
        let exact = finite_horizon(&undiscounted, &policy, None).unwrap().value;
        assert!((value(&undiscounted, &c, 1e-9) - exact).abs() < 1e-9, "{name}");
    }
}

#[test]
fn controllers_alike_on_what_they_reach_get_the_same_value_bit_for_bit() {
    let tiger = world("tiger.95.POMDP", 10, None);
    // "Listen, then open the door opposite to what was heard", its nodes numbered otherwise,
    // with a node it never reaches, and with different successors on the start symbol where
    // it cannot be met again.
    let once = Controller::moore(vec![LISTEN, OPEN_RIGHT, OPEN_LEFT], vec![1, 2, 0, 0, 0, 0, 0, 0, 0]);
    let renumbered =
        Controller::moore(vec![OPEN_LEFT, LISTEN, OPEN_RIGHT, OPEN_LEFT], vec![1, 1, 1, 2, 0, 2, 1, 1, 0, 2, 2, 1]);
    let a = value(&tiger, &once, 1e-6);
    let b = ControllerValue::new(&tiger, 1e-6).value(&renumbered, &mut Scratch::default());
    assert_eq!(a.to_bits(), b.to_bits(), "{a} vs {b}");
    // Rewards the same in every pair reached: one sweep gives the exact value, whatever the
    // controller (a plateau of controllers that listen forever is a plateau of equal values).
    let listen_1 = Controller::moore(vec![LISTEN], vec![0, 0, 0]);
    let listen_3 = Controller::moore(vec![LISTEN, LISTEN, OPEN_LEFT], vec![1, 1, 1, 0, 1, 2, 1, 1, 1]);
    let (one, three) = (value(&tiger, &listen_1, 1e-6), value(&tiger, &listen_3, 1e-6));
    assert_eq!(one.to_bits(), three.to_bits());
    assert!((one - -20.0).abs() < 1e-12, "{one}");
}

#[test]
fn the_value_is_within_the_tolerance() {
    let hallway = world("hallway.POMDP", 10, None);
    for k in 0..3 {
        let c = random_controller(&hallway, 16, k);
        let tight = value(&hallway, &c, 1e-12);
        for tolerance in [1e-3, 1e-6] {
            let v = value(&hallway, &c, tolerance);
            assert!((v - tight).abs() <= tolerance, "controller {k} at {tolerance}: {v} vs {tight}");
        }
    }
}

/// Every deterministic controller of `n` nodes, by counting in mixed radix.
fn all_controllers(n_actions: usize, y1: usize, n: usize) -> impl Iterator<Item = Controller> {
    let digits = n + n * y1;
    let radix = move |i: usize| if i < n { n_actions } else { n };
    let total: usize = (0..digits).map(radix).product();
    (0..total).map(move |mut code| {
        let mut d = Vec::with_capacity(digits);
        for i in 0..digits {
            d.push((code % radix(i)) as u32);
            code /= radix(i);
        }
        Controller::moore(d[..n].to_vec(), d[n..].to_vec())
    })
}

#[test]
fn the_search_finds_the_brute_force_optimum_of_a_tiny_problem() {
    // Tiger over 4 undiscounted steps, 2-node controllers: 3² · 2⁶ = 576 of them.
    let w = world("tiger.95.POMDP", 4, Some(1.0));
    let mut scratch = Scratch::default();
    let values = ControllerValue::new(&w, 1e-9);
    let optimum = all_controllers(3, 3, 2).map(|c| values.value(&c, &mut scratch)).fold(f64::MIN, f64::max);
    let config = ControllerConfig { nodes: 2, samples: 200, patience: 10, threads: Some(2), ..Default::default() };
    let found = optimize_controller(Valued::Exact(&w), &config, |_| Flow::Continue).unwrap();
    assert!((found.value - optimum).abs() < 1e-9, "found {} optimum {optimum}", found.value);
    // The returned policy is the controller of that value.
    assert!((finite_horizon(&w, &found.policy, None).unwrap().value - optimum).abs() < 1e-9);
    assert_eq!(found.stop, StopReason::Patience);
}

#[test]
fn results_do_not_depend_on_the_thread_count() {
    let w = world("cheese.95.POMDP", 10, None);
    let run = |threads| {
        let config = ControllerConfig {
            nodes: 3,
            samples: 300,
            max_iterations: Some(6),
            threads: Some(threads),
            ..Default::default()
        };
        optimize_controller(Valued::Exact(&w), &config, |_| Flow::Continue).unwrap()
    };
    let (one, two) = (run(1), run(2));
    assert_eq!(one.policy, two.policy);
    assert_eq!(one.value.to_bits(), two.value.to_bits());
    let strip = |o: &ceworld::ControllerOutcome| {
        o.history.iter().map(|r| (r.record.mean.to_bits(), r.best_so_far.to_bits())).collect::<Vec<_>>()
    };
    assert_eq!(strip(&one), strip(&two));
}

#[test]
fn restarts_keep_the_best_run_and_interruption_keeps_the_best_so_far() {
    let w = world("cheese.95.POMDP", 10, None);
    let config =
        ControllerConfig { nodes: 2, samples: 100, max_iterations: Some(3), restarts: 3, ..Default::default() };
    let out = optimize_controller(Valued::Exact(&w), &config, |_| Flow::Continue).unwrap();
    assert_eq!(out.run_values.len(), 3);
    assert_eq!(out.history.len(), 9);
    let best = out.run_values.iter().copied().fold(f64::MIN, f64::max);
    assert_eq!(out.value, best);
    assert_eq!(out.run_values[out.restart], best);
    // The first run is the single run with the same seed.
    let single =
        optimize_controller(Valued::Exact(&w), &ControllerConfig { restarts: 1, ..config.clone() }, |_| Flow::Continue)
            .unwrap();
    assert_eq!(single.value, out.run_values[0]);
    // Restarts 0: runs follow one another until the time limit (one without a time limit).
    let until = ControllerConfig { restarts: 0, max_iterations: None, patience: 2, ..config.clone() };
    let once = optimize_controller(Valued::Exact(&w), &until, |_| Flow::Continue).unwrap();
    assert_eq!((once.run_values.len(), once.stop), (1, StopReason::Patience));
    let timed = ControllerConfig { budget: Budget::seconds(0.5), ..until };
    let many = optimize_controller(Valued::Exact(&w), &timed, |_| Flow::Continue).unwrap();
    assert!(many.run_values.len() > 2 && many.stop == StopReason::TimeLimit, "{:?}", many.run_values);
    assert_eq!(many.run_values[0], once.run_values[0]);
    // Alternating memories: a first run that would go on takes half the time limit, and the
    // registers the rest; alone, it takes the whole limit.
    let alternate = ControllerConfig {
        patience: 1_000_000,
        budget: Budget::seconds(1.0),
        max_iterations: None,
        restarts: 0,
        memory: ceworld::ce::controller::Memory::Alternate,
        registers: 2,
        register_size: 2,
        ..ControllerConfig::defaults_for(ceworld::ce::controller::ValueKind::Sampled)
    };
    let turns = optimize_controller(Valued::Sampled(&w), &alternate, |_| Flow::Continue).unwrap();
    let first = turns.history.iter().rfind(|r| r.restart == 0).unwrap();
    assert!(first.record.seconds < 0.9 && turns.history.iter().any(|r| r.restart == 1), "{}", first.record.seconds);
    let alone = ControllerConfig { restarts: 1, ..alternate };
    let one = optimize_controller(Valued::Sampled(&w), &alone, |_| Flow::Continue).unwrap();
    assert!(one.history.last().unwrap().record.seconds >= 0.9 && one.run_values.len() == 1);

    let mut seen = 0;
    let stopped = optimize_controller(Valued::Exact(&w), &config, |_| {
        seen += 1;
        if seen == 2 { Flow::Stop } else { Flow::Continue }
    })
    .unwrap();
    assert_eq!(stopped.stop, StopReason::Interrupted);
    assert_eq!(stopped.history.len(), 2);
    assert_eq!(stopped.value, stopped.history[1].best_so_far);
}

#[test]
fn bad_settings_are_named() {
    let w = world("tiger.95.POMDP", 10, None);
    let mealy = ceworld::ce::controller::Decisions::Mealy;
    let registers = ceworld::ce::controller::Memory::Registers;
    let cases: [(&str, ControllerConfig); 11] = [
        ("nodes", ControllerConfig { nodes: 0, ..Default::default() }),
        ("samples", ControllerConfig { samples: 0, ..Default::default() }),
        ("rho", ControllerConfig { rho: 1.0, ..Default::default() }),
        ("smoothing", ControllerConfig { smoothing: 0.0, ..Default::default() }),
        ("tolerance", ControllerConfig { tolerance: f64::NAN, ..Default::default() }),
        ("restarts", ControllerConfig { restarts: ceworld::ce::controller::MAX_RESTARTS + 1, ..Default::default() }),
        ("time_limit", ControllerConfig { budget: Budget::seconds(-1.0), ..Default::default() }),
        // A memoryless stage of Moore machines would be a blind policy's.
        ("memoryless_patience", ControllerConfig { memoryless_patience: 3, ..Default::default() }),
        // Registers hold Mealy decisions; one register is flat nodes; 4^9 nodes are too many.
        ("memory", ControllerConfig { memory: registers, ..Default::default() }),
        ("registers", ControllerConfig { memory: registers, decisions: mealy, registers: 1, ..Default::default() }),
        ("registers", ControllerConfig { memory: registers, decisions: mealy, registers: 9, ..Default::default() }),
    ];
    for (name, config) in cases {
        match optimize_controller(Valued::Exact(&w), &config, |_| Flow::Continue) {
            Err(Error::InvalidArgument { name: n, .. }) => assert_eq!(n, name),
            other => panic!("{name}: {other:?}"),
        }
    }
}

#[test]
fn the_time_limit_cuts_an_iteration_without_refitting_on_it() {
    // Hallway: 2000 eight-node controllers take far longer than 10 ms to evaluate.
    let w = world("hallway.POMDP", 10, None);
    let config = ControllerConfig { budget: Budget::seconds(0.01), threads: Some(2), ..Default::default() };
    let out = optimize_controller(Valued::Exact(&w), &config, |_| Flow::Continue).unwrap();
    assert_eq!(out.stop, StopReason::TimeLimit);
    assert_eq!(out.history.len(), 1);
    let first = &out.history[0];
    assert!(first.evaluated >= 1 && first.evaluated < 2000, "{}", first.evaluated);
    assert!(out.value.is_finite() && out.value == first.best_so_far);
    assert_eq!(first.episodes, 0, "exact values run no episode");
    // Sampled values: cut between groups of controllers, each group's values those of a whole
    // iteration.
    let w = world("hallway.POMDP", 60, None);
    let config = ControllerConfig { samples: 3000, episodes: 50, budget: Budget::seconds(0.01), ..config };
    let out = optimize_controller(Valued::Sampled(&w), &config, |_| Flow::Continue).unwrap();
    assert_eq!(out.stop, StopReason::TimeLimit);
    let first = &out.history[0];
    assert!(first.evaluated >= 1 && first.evaluated < 3000, "{}", first.evaluated);
    let whole =
        ControllerConfig { samples: first.evaluated, budget: Budget::default(), max_iterations: Some(1), ..config };
    let all = optimize_controller(Valued::Sampled(&w), &whole, |_| Flow::Continue).unwrap();
    assert_eq!(all.history[0].record.mean.to_bits(), first.record.mean.to_bits());
    // The episodes run: K for each controller valued, the selection episodes for each of the
    // (at most 4, distinct) candidates.
    let (selection, m) = (first.episodes - first.evaluated as u64 * 50, config.select_episodes as u64);
    assert!(selection % m == 0 && (1..=4).contains(&(selection / m)), "{}", first.episodes);
    assert_eq!(all.history[0].episodes, first.episodes);
}

#[test]
fn sampled_values_agree_with_exact_values() {
    for (name, n) in [("tiger.95.POMDP", 3), ("4x3.95.POMDP", 4), ("cheese.95.POMDP", 5), ("shuttle.95.POMDP", 3)] {
        // γ^400 leaves less than 1e-6 of the infinite-horizon value out.
        let w = world(name, 400, None);
        let controllers: Vec<Controller> = (0..4).map(|k| random_controller(&w, n, k)).collect();
        episode_means_agree_with_exact_values(&w, &controllers, 3, name);
    }
}

/// The mean of 20 000 episodes of each of `controllers` (streams of `seed`) is its exact value,
/// within four standard errors (and the 1e-3 of a finite horizon).
fn episode_means_agree_with_exact_values(w: &PomdpWorld, controllers: &[Controller], seed: u64, name: &str) {
    use ceworld::Episodes;
    use ceworld::episodes::Streams;
    let k = 20_000;
    let mut values = vec![0.0; controllers.len() * k];
    let streams = Streams { seed, purpose: Purpose::Controllers, iteration: 0 };
    w.run_controllers(controllers, streams, k, &mut values).unwrap();
    for (c, v) in controllers.iter().zip(values.chunks(k)) {
        let mean = v.iter().sum::<f64>() / k as f64;
        let sd = (v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (k - 1) as f64).sqrt();
        let exact = value(w, c, 1e-9);
        assert!(
            (mean - exact).abs() < 4.0 * sd / (k as f64).sqrt() + 1e-3,
            "{name}: {mean} ± {} vs {exact}",
            sd / (k as f64).sqrt()
        );
    }
}

#[test]
fn a_search_resumes_from_its_checkpoint_bit_for_bit() {
    use ceworld::Checkpointing;
    use ceworld::ce::controller::optimize_controller_with;
    let dir = std::env::temp_dir().join(format!("ceworld-controller-resume-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let tiger = world("tiger.95.POMDP", 30, None);
    let config = ControllerConfig {
        nodes: 3,
        samples: 80,
        rho: 0.1,
        patience: 2,
        max_iterations: Some(10),
        restarts: 2,
        episodes: 5,
        select_episodes: 30,
        eval_episodes: 40,
        injections: 1,
        growths: 1,
        ..ControllerConfig::default()
    };
    // Mealy machines after a memoryless stage, runs alternating between flat nodes and
    // registers: the sampled defaults.
    let staged = ControllerConfig {
        decisions: ceworld::ce::controller::Decisions::Mealy,
        memoryless_patience: 2,
        memory: ceworld::ce::controller::Memory::Alternate,
        registers: 2,
        register_size: 2,
        max_iterations: Some(24),
        ..config.clone()
    };
    // A budget in steps instead of a count of iterations: the steps are resumed too.
    let budgeted = ControllerConfig { max_iterations: None, budget: Budget::steps(250_000), ..config.clone() };
    let cases = [
        ("exact", Valued::Exact(&tiger), &config),
        ("sampled", Valued::Sampled(&tiger), &config),
        ("staged", Valued::Sampled(&tiger), &staged),
        ("budgeted", Valued::Sampled(&tiger), &budgeted),
    ];
    for (name, valued, config) in cases {
        let whole = optimize_controller(valued, config, |_| Flow::Continue).unwrap();
        // Both escapes are taken, so that the state they change is resumed too.
        let (injected, grown) = (whole.history.iter().any(|r| r.injected), whole.history.iter().any(|r| r.grown));
        assert!(injected && grown, "{name}: injected {injected}, grown {grown}");
        assert_eq!(whole.history.iter().any(|r| r.widened), name == "staged", "{name}");
        let path = dir.join(format!("{name}.ckpt"));
        let checkpointing = Checkpointing { path: path.clone(), every: 1e9, resume: true, outputs: Vec::new() };
        // Stopped at every third iteration (a Ctrl-C), then resumed, until it ends.
        let (resumed, sessions) = sessions::in_sessions(valued, config, &checkpointing);
        assert!(sessions > 2, "{name}: {sessions} sessions");
        let strip = |h: &[ceworld::ce::controller::ControllerIteration]| {
            h.iter()
                .map(|r| {
                    let mut r = r.clone();
                    r.record.seconds = 0.0;
                    r
                })
                .collect::<Vec<_>>()
        };
        assert_eq!(strip(&resumed.history), strip(&whole.history), "{name}");
        assert_eq!(
            (&resumed.policy, resumed.value, &resumed.run_values, resumed.env_steps, resumed.stop),
            (&whole.policy, whole.value, &whole.run_values, whole.env_steps, whole.stop)
        );
        assert_eq!(whole.stop == StopReason::MaxEnvSteps, name == "budgeted", "{name}: {:?}", whole.stop);
        // Another search's settings are refused, naming what differs.
        let other = ControllerConfig { rho: 0.2, ..config.clone() };
        let e = optimize_controller_with(valued, &other, Some(&checkpointing), |_| Flow::Continue).unwrap_err();
        assert!(e.to_string().contains("rho 0.1, not 0.2"), "{e}");
    }
    // An exact search's checkpoint is not a sampled one's.
    let path = dir.join("exact.ckpt");
    let checkpointing = Checkpointing { path, every: 1e9, resume: true, outputs: Vec::new() };
    let e = optimize_controller_with(Valued::Sampled(&tiger), &config, Some(&checkpointing), |_| Flow::Continue)
        .unwrap_err();
    assert!(e.to_string().contains("value exact, not sampled"), "{e}");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn the_model_start_is_never_lost_and_sets_the_nodes() {
    use ceworld::pointbased::PointBased;
    let w = world("4x3.95.POMDP", 10, None);
    let config = ControllerConfig { nodes: 3, samples: 50, max_iterations: Some(1), ..Default::default() };
    let built = PointBased::solve(&w, ceworld::pointbased::Budget::within(config.budget.time_limit), config.seed)
        .controller(&w, 64, config.seed);
    let start = value(&w, &built, 1e-6);
    let found = optimize_controller(Valued::Exact(&w), &config, |_| Flow::Continue).unwrap();
    // One iteration: the controller built from the model, improved node by node, is among its
    // draws; the result says what it was.
    let facts = found.start.expect("a model start");
    assert_eq!(facts.built.to_bits(), start.to_bits());
    assert!(facts.kept && facts.value >= facts.built && facts.blind < facts.value);
    assert!(found.value >= facts.value, "{} < {}", found.value, facts.value);
    assert_eq!(found.policy.levels(), [built.nodes(), built.nodes()]);
    assert_eq!(facts.nodes, built.nodes());
    assert!(start > 1.8, "{start} (SARSOP's lower bound: 1.8899)");
    // Without it, the nodes asked and uniform laws.
    let without = ControllerConfig { model_nodes: 0, ..config };
    let found = optimize_controller(Valued::Exact(&w), &without, |_| Flow::Continue).unwrap();
    assert_eq!(found.policy.levels(), [3, 3]);
    assert_eq!(found.start, None);
    assert!(found.value < start);
}

#[test]
fn a_mealy_machine_decides_values_and_exports_as_a_policy_of_its_pairs() {
    for (name, n) in [("tiger.95.POMDP", 3), ("4x3.95.POMDP", 4), ("cheese.95.POMDP", 2)] {
        let w = world(name, 400, None);
        let t = w.tables();
        let y1 = t.n_observations() + 1;
        let controllers: Vec<Controller> = (0..3).map(|k| random_mealy(&w, n, k)).collect();
        for (k, c) in controllers.iter().enumerate() {
            c.check(y1, t.n_actions()).unwrap();
            // Its Moore machine takes the same decisions on any observations.
            let moore = c.to_moore(y1);
            assert!(!moore.is_mealy() && moore.nodes() <= 1 + n * y1);
            let mut rng = stream(4, Purpose::Evaluate, 1, k as u64);
            let (mut q, mut p) = (0, 0);
            for step in 0..50 {
                let y = if step == 0 { y1 - 1 } else { rng.random_range(0..y1 - 1) };
                assert_eq!(c.step(&mut q, y, y1), moore.step(&mut p, y, y1), "{name} {k} step {step}");
            }
            // Its value is its HHMM's exact value; the HHMM's memories are the nodes and the
            // (decision, next node) pairs, not nodes × observations.
            let policy = c.to_hhmm(y1, t.n_actions()).unwrap();
            let levels = policy.levels();
            assert!(levels[1] <= n && levels[0] <= n * t.n_actions().min(y1), "{name} {k}: {levels:?}");
            let exact = infinite_horizon(&w, &policy, 1e-9).unwrap().value;
            assert!((value(&w, c, 1e-9) - exact).abs() < 1e-7, "{name} {k}");
        }
        // And the mean of its episodes.
        episode_means_agree_with_exact_values(&w, &controllers, 5, name);
    }
    // A Mealy machine with too few decisions is refused, naming it.
    let bad = Controller { on: vec![0; 2], ..Controller::moore(vec![0], vec![0, 0, 0]) };
    assert!(matches!(bad.check(3, 3), Err(Error::InvalidArgument { name, .. }) if name == "controller"));
}

#[test]
fn the_memoryless_stage_keeps_the_best_memoryless_policy_and_memory_adds_to_it() {
    use ceworld::ce::controller::Decisions;
    let tiger = world("tiger.95.POMDP", 10, None);
    let y1 = tiger.tables().n_observations() + 1;
    // Every memoryless policy: a one-node Mealy machine, 3³ of them.
    let memoryless = (0..27u32)
        .map(|code| {
            let on = vec![code % 3, code / 3 % 3, code / 9];
            value(&tiger, &Controller::mealy(on, vec![0; y1], y1), 1e-9)
        })
        .fold(f64::MIN, f64::max);
    let config = ControllerConfig {
        nodes: 4,
        samples: 300,
        patience: 10,
        decisions: Decisions::Mealy,
        memoryless_patience: 3,
        model_nodes: 0,
        threads: Some(2),
        ..Default::default()
    };
    let found = optimize_controller(Valued::Exact(&tiger), &config, |_| Flow::Continue).unwrap();
    let widened = found.history.iter().position(|r| r.widened).expect("the stage ends");
    // The stage ends with the best memoryless policy (27 of them: every one is drawn), after
    // `memoryless_patience` iterations without a better one, and memory adds to it.
    let stage = &found.history[widened];
    assert!((stage.best_so_far - memoryless).abs() < 1e-6, "{} vs {memoryless}", stage.best_so_far);
    let found_at = found.history.iter().position(|r| r.best_so_far == stage.best_so_far).unwrap();
    assert_eq!(widened - found_at, config.memoryless_patience);
    assert!(found.history.iter().filter(|r| r.widened).count() == 1);
    assert!(found.value > memoryless + 1.0, "{} vs memoryless {memoryless}", found.value);
    assert!(found.policy.levels()[1] <= config.nodes, "{:?}", found.policy.levels());
    // One node asked: the stage is the whole search.
    let one = ControllerConfig { nodes: 1, ..config };
    let found = optimize_controller(Valued::Exact(&tiger), &one, |_| Flow::Continue).unwrap();
    assert!(found.history.iter().all(|r| !r.widened));
    assert!((found.value - memoryless).abs() < 1e-6);
}

#[test]
fn the_time_limit_holds_the_final_evaluation_of_sampled_values_too() {
    let w = world("cheese.95.POMDP", 100, None);
    let config = ControllerConfig {
        nodes: 2,
        samples: 50,
        budget: Budget::seconds(1.0),
        patience: 1_000_000,
        eval_episodes: 10_000_000,
        ..ControllerConfig::defaults_for(ceworld::ce::controller::ValueKind::Sampled)
    };
    let clock = std::time::Instant::now();
    let out = optimize_controller(Valued::Sampled(&w), &config, |_| Flow::Continue).unwrap();
    let wall = clock.elapsed().as_secs_f64();
    let evaluation = out.evaluation.expect("sampled values are evaluated");
    assert_eq!(out.stop, StopReason::TimeLimit);
    assert!(evaluation.episodes > 0 && evaluation.episodes < 10_000_000, "{evaluation:?}");
    assert!(wall < 1.5 && out.seconds < 1.5, "{wall} s, {} s", out.seconds);
}

#[test]
fn an_improved_controller_is_valued_exactly_and_never_lower() {
    for (name, n) in [("tiger.95.POMDP", 3), ("4x3.95.POMDP", 6), ("cheese.95.POMDP", 4), ("network.POMDP", 4)] {
        let w = world(name, 100, None);
        for k in 0..3 {
            let c = random_controller(&w, n, k);
            let (better, found) = improve(&w, &c, 1e-6, 1e9);
            better.check(w.tables().n_observations() + 1, w.tables().n_actions()).unwrap();
            assert_eq!(better.nodes(), n, "{name} {k}");
            assert_eq!(found.to_bits(), value(&w, &better, 1e-6).to_bits(), "{name} {k}");
            assert!(found >= value(&w, &c, 1e-6), "{name} {k}: {found} < {}", value(&w, &c, 1e-6));
            // Deterministic: the same controller again.
            assert_eq!(improve(&w, &c, 1e-6, 1e9).0, better, "{name} {k}");
        }
    }
}

#[test]
fn the_point_based_controller_of_tiger_grid_is_improved_and_the_work_stops_it() {
    use ceworld::pointbased::{Budget as Work, PointBased};
    let w = world("tiger-grid.POMDP", 100, None);
    let built = PointBased::solve(&w, Work { work: 1e9, ..Work::default() }, 0).controller(&w, 32, 0);
    let before = value(&w, &built, 1e-6);
    let (_, after) = improve(&w, &built, 1e-6, 1e10);
    // SARSOP's lower bound: 2.2708 (data/pomdp/SOURCES.md).
    assert!(after > before + 0.05, "{before} -> {after}");
    // No work allowed: the controller as it was.
    let (same, found) = improve(&w, &built, 1e-6, 0.0);
    assert_eq!((same, found.to_bits()), (built, before.to_bits()));
}
