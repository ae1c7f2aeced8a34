//! A policy and a world stepped from outside (`policy::agent`, `world::session`): the episode's
//! rewards add up to the world's reward, bad decisions and observations are refused, and the
//! same seeds give the same episodes, on every registered world.

use ceworld::policy::agent::Agent;
use ceworld::world::session::Session;
use ceworld::{AnyWorld, Error, World, random_policy, with_world};
use serde_json::json;

fn world() -> AnyWorld {
    AnyWorld::from_json(&json!({"name": "target-tracking", "horizon": 30})).unwrap()
}

fn tiger(horizon: usize) -> AnyWorld {
    let file = format!("{}/../../data/pomdp/tiger.95.POMDP", env!("CARGO_MANIFEST_DIR"));
    AnyWorld::from_json(&json!({"name": "pomdp", "file": file, "horizon": horizon})).unwrap()
}

fn episode(seed: u64, agent: &mut Agent) -> (Vec<usize>, f64) {
    let mut session = Session::start(&world(), seed, 0);
    agent.reset();
    let (mut decisions, mut total) = (Vec::new(), 0.0);
    loop {
        let d = agent.act(session.observation()).unwrap();
        decisions.push(d);
        let (_, reward, over) = session.step(d).unwrap();
        total += reward;
        if over {
            assert_eq!(session.t(), 31);
            assert_eq!(total, session.reward());
            return (decisions, total);
        }
    }
}

#[test]
fn episodes_are_reproducible_and_their_rewards_add_up() {
    let policy = with_world!(&world(), w => random_policy(w, &[4, 3], 2)).unwrap();
    let (mut a, mut b) = (Agent::new(policy.clone(), 5), Agent::new(policy, 5));
    let first = episode(1, &mut a);
    assert_eq!(first, episode(1, &mut b));
    assert!((0.0..=30.0).contains(&first.1));
    // The next episodes of an agent use new draws.
    let runs: Vec<_> = (0..5).map(|_| episode(1, &mut a).0).collect();
    assert!(runs.iter().any(|d| *d != first.0));
}

#[test]
fn bad_decisions_and_observations_are_refused() {
    let mut session = Session::start(&world(), 0, 0);
    assert!(matches!(session.step(16), Err(Error::InvalidArgument { name, .. }) if name == "decision"));
    for _ in 0..30 {
        session.step(3).unwrap();
    }
    assert!(matches!(session.step(3), Err(Error::InvalidArgument { name, .. }) if name == "step"));
    let mut agent = Agent::new(with_world!(&world(), w => random_policy(w, &[2], 0)).unwrap(), 0);
    assert!(matches!(agent.act(16), Err(Error::InvalidArgument { name, .. }) if name == "observation"));
    assert_eq!(agent.memory().len(), 1);
}

#[test]
fn a_tabular_world_steps_too_and_a_cloned_session_goes_on_alike() {
    let world = tiger(12);
    let mut session = Session::start(&world, 3, 1);
    let (decisions, observations) = with_world!(&world, w => (w.n_decisions(), w.n_observations()));
    assert_eq!((session.t(), session.reward()), (1, 0.0));
    assert!(session.observation() < observations);
    for d in 0..5 {
        session.step(d % decisions).unwrap();
    }
    let mut copy = session.clone();
    assert!(format!("{copy:?}").contains("Stepper"));
    let (mut total, mut over) = (session.reward(), false);
    while !over {
        let (y, gained, end) = session.step(0).unwrap();
        assert_eq!(copy.step(0).unwrap(), (y, gained, end));
        assert!(y < observations);
        (total, over) = (total + gained, end);
    }
    assert_eq!(session.t(), 13);
    assert!((total - session.reward()).abs() < 1e-9, "{total} != {}", session.reward());
    assert_eq!(session.describe(), copy.describe());
    assert!(matches!(session.step(0), Err(Error::InvalidArgument { name, .. }) if name == "step"));
}
