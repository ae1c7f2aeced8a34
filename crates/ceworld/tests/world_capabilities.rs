//! What a world can do is read from the registry (`world::registry::Capabilities`): Q-learning
//! and window evaluation reach the worlds with a known state, and refuse the others by name,
//! without any code outside the registry naming a world.

use ceworld::qlearn::{AnyLearner, evaluate_policy_windows};
use ceworld::{AnyWorld, Error, QConfig, WindowConfig, random_policy, with_world};
use serde_json::json;

fn small_tracking() -> AnyWorld {
    AnyWorld::from_json(&json!({
        "name": "target-tracking", "width": 5, "height": 5, "start_b": [0, 4], "start_c": [4, 4],
        "target_rows": [0, 2], "target_cell": [2, 2], "horizon": 20
    }))
    .unwrap()
}

fn tiger() -> AnyWorld {
    let file = format!("{}/../../data/pomdp/tiger.95.POMDP", env!("CARGO_MANIFEST_DIR"));
    AnyWorld::from_json(&json!({"name": "pomdp", "file": file, "horizon": 10})).unwrap()
}

fn windows() -> WindowConfig {
    WindowConfig { window: 5, episodes: 3, chains: 2, burn_in: 1, windows_per_chain: 2 }
}

#[test]
fn capabilities_are_the_registry_rows() {
    let (tracking, pomdp) = (small_tracking(), tiger());
    assert!(tracking.capabilities().q_learning && !tracking.capabilities().tabular);
    assert!(pomdp.capabilities().tabular && !pomdp.capabilities().q_learning);
    assert_eq!(pomdp.entry().name, "pomdp");
    assert!(tracking.tabular().is_none() && pomdp.tabular().is_some());
}

#[test]
fn q_learning_runs_where_the_state_is_known_and_refuses_other_worlds_by_name() {
    let learner = AnyLearner::new(small_tracking(), QConfig::default()).unwrap();
    assert_eq!(learner.world(), small_tracking());
    learner.evaluate_windows(&small_tracking(), None, &windows(), 1).unwrap();

    let e = AnyLearner::new(tiger(), QConfig::default()).err().expect("refused").to_string();
    assert!(e.contains("Q-learning needs a world whose state it can index; pomdp has none"), "{e}");
    let e = learner.evaluate_windows(&tiger(), None, &windows(), 1).unwrap_err();
    assert!(matches!(&e, Error::Mismatch(m) if m.contains("learnt in a target-tracking world, not pomdp")), "{e}");
}

#[test]
fn window_evaluation_runs_on_continuing_worlds_only() {
    let tracking = small_tracking();
    let policy = with_world!(&tracking, w => random_policy(w, &[2], 0)).unwrap();
    let report = evaluate_policy_windows(&tracking, &policy, &windows(), 3).unwrap();
    assert_eq!(report, evaluate_policy_windows(&tracking, &policy, &windows(), 3).unwrap());

    let pomdp = tiger();
    let policy = with_world!(&pomdp, w => random_policy(w, &[2], 0)).unwrap();
    let e = evaluate_policy_windows(&pomdp, &policy, &windows(), 3).unwrap_err().to_string();
    assert!(e.contains("the pomdp world cannot run as a continuing task"), "{e}");
}
