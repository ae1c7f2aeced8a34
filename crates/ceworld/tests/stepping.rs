//! A policy and a world stepped from outside (`policy::agent`, `world::session`): the episode's
//! rewards add up to the world's reward, bad decisions and observations are refused, and the
//! same seeds give the same episodes.

use ceworld::policy::agent::Agent;
use ceworld::world::session::Session;
use ceworld::{AnyWorld, Error, TargetTracking, TrackingParams, random_policy};

fn world() -> AnyWorld {
    AnyWorld::TargetTracking(TargetTracking::with_params(TrackingParams { horizon: 30, ..Default::default() }).unwrap())
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
    let AnyWorld::TargetTracking(w) = world() else { unreachable!() };
    let policy = random_policy(&w, &[4, 3], 2).unwrap();
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
    let AnyWorld::TargetTracking(w) = world() else { unreachable!() };
    let mut agent = Agent::new(random_policy(&w, &[2], 0).unwrap(), 0);
    assert!(matches!(agent.act(16), Err(Error::InvalidArgument { name, .. }) if name == "observation"));
    assert_eq!(agent.memory().len(), 1);
}
