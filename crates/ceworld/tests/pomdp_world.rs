//! The tabular POMDP world (model §7) on real files: its conventions, sampling against exact
//! evaluation, exact values computed by hand, and the registry's identity of a model file.

#[path = "common/tiger.rs"]
mod tiger;

use ceworld::exact::{finite_horizon, infinite_horizon};
use ceworld::{AnyWorld, Error, PomdpWorld, World, evaluate, random_policy};
use tiger::reactive;

fn data(name: &str) -> String {
    format!("{}/../../data/pomdp/{name}", env!("CARGO_MANIFEST_DIR"))
}

fn tiger(horizon: usize) -> PomdpWorld {
    PomdpWorld::from_file(data("tiger.95.POMDP"), horizon, None).unwrap()
}

const LISTEN: usize = 0;
const OPEN_LEFT: usize = 1;
const OPEN_RIGHT: usize = 2;

#[test]
fn tiger_sizes_and_the_start_symbol() {
    let world = tiger(10);
    assert_eq!((world.n_observations(), world.n_decisions(), world.horizon()), (3, 3, 10));
    let t = world.tables();
    assert_eq!((t.n_states(), t.n_actions(), t.n_observations(), t.gamma), (2, 3, 2, 0.95));
    let mut rng = ceworld::rng::stream(0, ceworld::rng::Purpose::Evaluate, 0, 0);
    let state = world.reset(&mut rng);
    assert_eq!(world.observe(&state, &mut rng), 2, "no observation precedes the first action");
    assert_eq!(t.expected_reward(0, LISTEN), -1.0);
    assert_eq!(t.expected_reward(0, OPEN_LEFT), -100.0);
    assert_eq!(t.expected_reward(1, OPEN_LEFT), 10.0);
}

#[test]
fn exact_values_by_hand_on_tiger() {
    let world = tiger(10);
    let close = |a: f64, b: f64| assert!((a - b).abs() < 1e-9, "{a} != {b}");
    // Always listen: -1 a step.
    let listen = reactive([0, 0, 0], &[LISTEN]);
    close(finite_horizon(&world, &listen, None).unwrap().value, -(1.0 - 0.95f64.powi(10)) / 0.05);
    close(infinite_horizon(&world, &listen, 1e-9).unwrap().value, -20.0);
    // Always open the left door: the tiger is behind it half the time, -45 a step.
    let open = reactive([0, 0, 0], &[OPEN_LEFT]);
    close(infinite_horizon(&world, &open, 1e-9).unwrap().value, -900.0);
    // Listen first, then open the door opposite to the last observation: right after listening
    // the observation is right with probability 0.85 (0.85·10 − 0.15·100 = −6.5); after that the
    // observations of an opened door are noise, and each step is worth −45.
    let react = reactive([2, 1, 0], &[LISTEN, OPEN_LEFT, OPEN_RIGHT]);
    let expected = -1.0 + 0.95 * -6.5 - 45.0 * 0.95f64.powi(2) / 0.05;
    close(infinite_horizon(&world, &react, 1e-9).unwrap().value, expected);
    close(finite_horizon(&world, &react, Some(2)).unwrap().value, -1.0 + 0.95 * -6.5);
    let e = infinite_horizon(&world, &react, 1e-6).unwrap();
    assert!(e.tail_bound < 1e-6 && e.steps > 100, "{e:?}");
}

#[test]
fn sampling_agrees_with_the_exact_value() {
    for (file, levels) in
        [("tiger.95.POMDP", vec![2, 2]), ("4x3.95.POMDP", vec![3]), ("shuttle.95.POMDP", vec![2, 2, 2])]
    {
        let world = PomdpWorld::from_file(data(file), 15, None).unwrap();
        let policy = random_policy(&world, &levels, 3).unwrap();
        let exact = finite_horizon(&world, &policy, None).unwrap().value;
        let mc = evaluate(&world, &policy, 200_000, 1).unwrap();
        let z = (mc.mean - exact) / mc.std_error;
        assert!(z.abs() < 4.5, "{file} {levels:?}: exact {exact}, sampled {} ± {} (z = {z:.2})", mc.mean, mc.std_error);
    }
}

#[test]
fn costs_are_negated_and_a_file_without_discount_counts_every_step() {
    // ejs3: costs 4 and -4 for action 0 in states 0 and 1; discount 1.0.
    let world = PomdpWorld::from_file(data("ejs3.POMDP"), 5, None).unwrap();
    assert_eq!(world.tables().gamma, 1.0);
    let r = (world.tables().expected_reward(0, 0), world.tables().expected_reward(1, 0));
    assert!((r.0 + 4.0).abs() < 1e-12 && (r.1 - 4.0).abs() < 1e-12, "{r:?}");
    let policy = random_policy(&world, &[1], 0).unwrap();
    // ejs4 has no discount line: every step counts fully.
    assert_eq!(PomdpWorld::from_file(data("ejs4.POMDP"), 5, None).unwrap().tables().gamma, 1.0);
    assert!(infinite_horizon(&world, &policy, 1e-6).is_err(), "no infinite-horizon value without a discount");
    let overridden = PomdpWorld::from_file(data("ejs3.POMDP"), 5, Some(0.5)).unwrap();
    assert_eq!(overridden.tables().gamma, 0.5);
}

#[test]
fn an_exact_value_of_no_steps_or_an_infinite_tolerance_is_refused() {
    let world = tiger(10);
    let policy = random_policy(&world, &[2], 0).unwrap();
    for tolerance in [f64::INFINITY, f64::NAN, 0.0, -1.0] {
        match infinite_horizon(&world, &policy, tolerance) {
            Err(Error::InvalidArgument { name, .. }) => assert_eq!(name, "tolerance"),
            other => panic!("{tolerance}: {other:?}"),
        }
    }
    match finite_horizon(&world, &policy, Some(0)) {
        Err(Error::InvalidArgument { name, .. }) => assert_eq!(name, "horizon"),
        other => panic!("{other:?}"),
    }
    assert!(finite_horizon(&world, &policy, Some(1)).is_ok());
}

#[test]
fn rewards_whose_episode_sum_overflows_are_refused_by_name() {
    let path = std::env::temp_dir().join(format!("ceworld-huge-reward-{}.pomdp", std::process::id()));
    let model = "discount: 0.95\nvalues: reward\nstates: 1\nactions: 1\nobservations: 1\nT: * identity\nO: * uniform\nR: * : * : * : * 1e308\n";
    std::fs::write(&path, model).unwrap();
    let file = path.to_str().unwrap();
    // One step of 1e308 is a number; twenty (about 1 / (1 - 0.95)) are not.
    assert!(PomdpWorld::from_file(file, 1, None).is_ok());
    match PomdpWorld::from_file(file, 100, None) {
        Err(Error::InvalidArgument { name, message }) => {
            assert_eq!(name, "pomdp.file");
            assert!(message.contains("1e308") && message.contains("100 steps"), "{message}");
        }
        other => panic!("{other:?}"),
    }
    std::fs::remove_file(&path).unwrap();
}

#[test]
fn the_registry_names_the_file_and_its_hash() {
    let world = tiger(7);
    let json = world.to_json();
    assert_eq!(json["name"], "pomdp");
    assert_eq!(json["horizon"], 7);
    assert_eq!(json["sha256"].as_str().unwrap().len(), 64);
    assert_eq!(AnyWorld::from_json(&json).unwrap(), AnyWorld::Pomdp(world));
    let mut other = json.clone();
    other["sha256"] = "0".repeat(64).into();
    assert!(matches!(AnyWorld::from_json(&other), Err(Error::Mismatch(_))));
    let mut bad = json;
    bad["file"] = data("ejs7.POMDP").into();
    bad["sha256"] = serde_json::Value::Null;
    let e = AnyWorld::from_json(&bad).unwrap_err();
    assert!(matches!(e, Error::ModelFormat(_)) && e.to_string().contains("ejs7.POMDP:22:1"), "{e}");
}

#[test]
fn a_file_s_world_gives_its_steps_rewards_to_a_learner_that_keeps_them() {
    use ceworld::episodes::credit::StepCredit;
    use ceworld::episodes::{Episodes, Streams};
    use ceworld::policy::controller::Controller;
    use ceworld::rng::Purpose;

    let world = tiger(6);
    // Listen twice, then open the left door; and listen always (three nodes, Moore).
    let controllers = [
        Controller::moore(vec![LISTEN as u32, LISTEN as u32, 1], vec![1, 1, 1, 2, 2, 2, 0, 0, 0]),
        Controller::moore(vec![LISTEN as u32], vec![0; 3]),
    ];
    let streams = Streams { seed: 7, purpose: Purpose::Controllers, iteration: 0 };
    let (mut plain, mut kept) = (vec![0.0; 2 * 50], vec![0.0; 2 * 50]);
    let steps = world.run_controllers(&controllers, streams, 50, &mut plain).unwrap();
    let mut credit = StepCredit::traced(2, StepCredit::rows_of(&controllers[0]));
    let (traced, credited) = world.run_controllers_credited(&controllers, streams, 50, &mut kept, &mut credit).unwrap();
    // The same episodes, and their steps kept: each episode's rewards, discounted, are its value.
    assert_eq!((kept.clone(), traced, credited), (plain, steps, true));
    let traces = credit.traces.unwrap();
    assert_eq!((traces.steps(), traces.gamma), (steps as usize, 0.95));
    for (episode, value) in traces.episodes().zip(&kept) {
        let sum: f64 = episode.clone().rev().fold(0.0, |later, t| traces.rew[t] + 0.95 * later);
        assert!((sum - value).abs() < 1e-9, "{sum} vs {value}");
        // Listening costs 1 a step.
        assert!(
            episode.clone().filter(|&t| traces.dec[t] == LISTEN as u32).all(|t| (traces.rew[t] + 1.0).abs() < 1e-9)
        );
    }
    // Credit without its steps kept is left as it was (the search of §8 sees no change).
    let mut plain_credit = StepCredit::new(2, StepCredit::rows_of(&controllers[0]));
    let (_, credited) =
        world.run_controllers_credited(&controllers, streams, 50, &mut kept, &mut plain_credit).unwrap();
    assert!(!credited);
}
