//! An optimiser given by its iteration step (`ceworld::ce::stepped`), through the run spine
//! (`ceworld::run`): the random search over controllers reaches the registry by name, keeps its
//! best, stops by its rules, is the same whatever the thread count, and resumes from its
//! checkpoint bit for bit.

#[path = "common/temp.rs"]
mod temp;

use ceworld::ce::budget::Budget;
use ceworld::ce::random_search::{RandomSearch, RandomSearchConfig};
use ceworld::ce::stepped::{Rules, run_stepped};
use ceworld::run::{OPTIMISERS, RunOptions, optimiser};
use ceworld::settings::{Given, Named};
use ceworld::{Checkpointing, Error, Flow, PomdpWorld, StopReason};

fn tiger() -> PomdpWorld {
    let file = format!("{}/../../data/pomdp/tiger.95.POMDP", env!("CARGO_MANIFEST_DIR"));
    PomdpWorld::from_file(file, 20, None).unwrap()
}

fn config(max_iterations: usize) -> RandomSearchConfig {
    RandomSearchConfig {
        nodes: 3,
        samples: 40,
        episodes: 20,
        rules: Rules { max_iterations: Some(max_iterations), eval_episodes: 500, ..Rules::default() },
    }
}

fn set(name: &str, value: Given) -> Named {
    Named { name: name.into(), shown: format!("{value:?}"), value }
}

#[test]
fn the_registry_runs_it_by_name_with_settings_by_name() {
    assert!(OPTIMISERS.iter().any(|o| o.name == "random-search"));
    let defaults = (optimiser("random-search").unwrap().defaults)();
    assert_eq!(defaults["nodes"], 4);
    let e = optimiser("anneal").err().unwrap().to_string();
    assert!(e.contains("\"anneal\"") && e.contains("random-search"), "{e}");
    let world = tiger();
    let run = optimiser("random-search").unwrap().run;
    let settings = [
        set("nodes", Given::Int(3)),
        set("samples", Given::Int(40)),
        set("episodes", Given::Int(20)),
        set("max_iterations", Given::Int(5)),
        set("eval_episodes", Given::Int(500)),
    ];
    let (outcome, file) = run(&world, &settings, &RunOptions::quiet()).unwrap();
    let direct = run_stepped::<RandomSearch>(&world, &config(5), None, |_| Flow::Continue).unwrap();
    assert_eq!(outcome.policy, direct.policy);
    assert_eq!(outcome.stop, StopReason::MaxIterations);
    assert_eq!(file.provenance["method"], "random-search");
    assert_eq!(file.provenance["nodes"], 3);
    let bad = run(&world, &[set("nodes", Given::Int(0))], &RunOptions::quiet()).unwrap_err();
    assert!(matches!(bad, Error::InvalidArgument { .. }) && bad.to_string().contains("nodes"), "{bad}");
    let bad = run(&world, &[set("speed", Given::Int(1))], &RunOptions::quiet()).unwrap_err().to_string();
    assert!(bad.contains("\"speed\"") && bad.contains("nodes"), "{bad}");
}

#[test]
fn the_best_is_kept_and_the_history_says_when_it_improved() {
    let outcome = run_stepped::<RandomSearch>(&tiger(), &config(8), None, |_| Flow::Continue).unwrap();
    let h = &outcome.history;
    assert_eq!(h.len(), 8);
    assert!(h.windows(2).all(|w| w[1].best >= w[0].best), "the best so far never falls");
    for (k, r) in h.iter().enumerate() {
        assert_eq!(r.iteration, k);
        assert_eq!(r.successful, k == 0 || r.best > h[k - 1].best);
        assert!(r.mean <= r.elite_threshold);
    }
    // Patience: a run stops after that many iterations without a better controller.
    let c = RandomSearchConfig { rules: Rules { patience: 2, max_iterations: None, ..config(0).rules }, ..config(0) };
    let outcome = run_stepped::<RandomSearch>(&tiger(), &c, None, |_| Flow::Continue).unwrap();
    assert_eq!(outcome.stop, StopReason::Patience);
    assert!(outcome.history.iter().rev().take(2).all(|r| !r.successful));
    // The caller's stop: the iterations done are kept.
    let mut seen = 0;
    let outcome = run_stepped::<RandomSearch>(&tiger(), &config(8), None, |_| {
        seen += 1;
        if seen == 3 { Flow::Stop } else { Flow::Continue }
    })
    .unwrap();
    assert_eq!((outcome.stop, outcome.history.len()), (StopReason::Interrupted, 3));
}

#[test]
fn the_result_does_not_depend_on_the_threads() {
    let run = |threads| {
        let c = RandomSearchConfig { rules: Rules { threads: Some(threads), ..config(4).rules }, ..config(4) };
        run_stepped::<RandomSearch>(&tiger(), &c, None, |_| Flow::Continue).unwrap()
    };
    let (one, two) = (run(1), run(2));
    assert_eq!(one.policy, two.policy);
    assert_eq!(one.evaluation, two.evaluation);
}

#[test]
fn a_run_resumes_from_its_checkpoint_bit_for_bit() {
    let path = temp::TempPath::new("ceworld-stepped", "search.ckpt");
    let checkpointing = Checkpointing { path: path.to_path_buf(), every: 1e9, resume: true, outputs: Vec::new() };
    let world = tiger();
    let whole = run_stepped::<RandomSearch>(&world, &config(9), None, |_| Flow::Continue).unwrap();
    let first = run_stepped::<RandomSearch>(&world, &config(4), Some(&checkpointing), |_| Flow::Continue).unwrap();
    assert!(path.exists() && first.history.len() == 4);
    // The stop rules may differ between sessions: the rest of the run follows.
    let rest = run_stepped::<RandomSearch>(&world, &config(9), Some(&checkpointing), |_| Flow::Continue).unwrap();
    assert_eq!(rest.policy, whole.policy);
    assert_eq!(rest.evaluation, whole.evaluation);
    let strip = |h: &[ceworld::IterationRecord]| {
        h.iter().map(|r| (r.mean, r.best, r.successful, r.env_steps)).collect::<Vec<_>>()
    };
    assert_eq!(strip(&rest.history), strip(&whole.history));
    assert_eq!(rest.env_steps, whole.env_steps);
    // A budget in steps, given on resume, counts on from the steps already taken.
    let steps = whole.history[6].env_steps;
    let path = temp::TempPath::new("ceworld-stepped", "budget.ckpt");
    let checkpointing = Checkpointing { path: path.to_path_buf(), ..checkpointing };
    run_stepped::<RandomSearch>(&world, &config(4), Some(&checkpointing), |_| Flow::Continue).unwrap();
    let rules = Rules { max_iterations: None, budget: Budget::steps(steps), ..config(9).rules };
    let budget = RandomSearchConfig { rules, ..config(9) };
    let spent = run_stepped::<RandomSearch>(&world, &budget, Some(&checkpointing), |_| Flow::Continue).unwrap();
    assert_eq!((spent.stop, spent.env_steps, spent.history.len()), (StopReason::MaxEnvSteps, steps, 7));
    // Other settings are refused, naming the setting.
    let other = RandomSearchConfig { nodes: 4, ..config(9) };
    let e = run_stepped::<RandomSearch>(&world, &other, Some(&checkpointing), |_| Flow::Continue).unwrap_err();
    assert!(matches!(e, Error::CheckpointMismatch(ref m) if m.contains("nodes 3, not 4")), "{e}");
}

#[test]
fn a_target_stops_the_run_once_the_best_so_far_reaches_it() {
    let whole = run_stepped::<RandomSearch>(&tiger(), &config(8), None, |_| Flow::Continue).unwrap();
    // The third iteration's best so far as the target: the run stops there, the same run.
    let target = whole.history[2].best;
    let at = whole.history.iter().position(|r| r.best >= target).unwrap();
    let c = RandomSearchConfig { rules: Rules { target: Some(target), ..config(8).rules }, ..config(8) };
    let cut = run_stepped::<RandomSearch>(&tiger(), &c, None, |_| Flow::Continue).unwrap();
    assert_eq!((cut.stop, cut.history.len()), (StopReason::Target, at + 1));
    let timeless = |h: &[ceworld::ce::record::IterationRecord]| -> Vec<(f64, f64, u64)> {
        h.iter().map(|r| (r.mean, r.best, r.env_steps)).collect()
    };
    assert_eq!(timeless(&cut.history), timeless(&whole.history[..=at]));
    // By name, and refused where it is not a number.
    let run = optimiser("random-search").unwrap().run;
    let settings = [set("samples", Given::Int(40)), set("target", Given::Real(f64::NEG_INFINITY))];
    let bad = run(&tiger(), &settings, &RunOptions::quiet()).unwrap_err().to_string();
    assert!(bad.contains("target") && bad.contains("-inf") && bad.contains("finite"), "{bad}");
}

#[test]
fn a_controller_search_is_the_model_search_on_sampled_values_unless_told() {
    use ceworld::ce::controller::ValueKind;
    use ceworld::run::{Search, model_search};
    let world = tiger();
    assert_eq!(Search::resolve(&world, None, None).unwrap(), Search::Ce, "a tabular world: exact values, the CE");
    assert_eq!(Search::resolve(&world, Some(ValueKind::Sampled), None).unwrap(), Search::Model);
    assert_eq!(Search::resolve(&world, Some(ValueKind::Sampled), Some(Search::Ce)).unwrap(), Search::Ce);
    let e = Search::resolve(&world, None, Some(Search::Model)).unwrap_err().to_string();
    assert!(e.contains("search") && e.contains("\"model\" on exact values"), "{e}");
    let e = Search::parse("dice").unwrap_err().to_string();
    assert!(e.contains("\"dice\"") && e.contains("\"ce\" or \"model\""), "{e}");
    // Settings of both mean the same; `None` leaves the model search's default; one of the CE
    // alone is refused by its name.
    let small = [
        set("nodes", Given::Int(4)),
        set("samples", Given::Int(2)),
        set("episodes", Given::Int(2)),
        set("max_iterations", Given::Int(2)),
        set("eval_episodes", Given::Int(50)),
        set("patience", Given::Nothing),
    ];
    let (outcome, file) = model_search(&world, &small, &RunOptions::quiet()).unwrap();
    let direct = (optimiser("model-search").unwrap().run)(&world, &small[..5], &RunOptions::quiet()).unwrap().0;
    assert_eq!((outcome.policy, outcome.evaluation), (direct.policy, direct.evaluation));
    assert_eq!(file.provenance["method"], "model-search");
    let with = [&small[..], &[set("injection", Given::Real(0.5))]].concat();
    let e = model_search(&world, &with, &RunOptions::quiet()).unwrap_err().to_string();
    assert!(e.contains("injection") && e.contains("search=\"ce\""), "{e}");
}
