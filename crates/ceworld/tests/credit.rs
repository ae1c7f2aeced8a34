//! Credit within episodes (model §8, `credit = "steps"`): on a world whose value sums its steps'
//! rewards, the decision laws move onto each row's best decision by the credit of the steps
//! taken there, from every controller's episodes; a world whose value is not a sum, and
//! `credit = "elite"`, refit from the elite alone.

use ceworld::ce::controller::{ControllerOutcome, Credit, Decisions, Memory, Valued, optimize_controller};
use ceworld::episodes::Shape;
use ceworld::episodes::outside::{BatchWorld, Lockstep, Recorded, StepOut};
use ceworld::{ControllerConfig, Flow};
use serde_json::{Value, json};

#[path = "common/sessions.rs"]
mod sessions;

/// Cards of `CARDS` kinds dealt at random (from the reset's seed, the episode's place in its
/// batch and the step); a step pays 1 when its decision is the card's colour (`card mod 2`).
/// The best policy is memoryless and pays `HORIZON`; every row (card) matters.
struct Colours {
    cards: Vec<u64>,
    t: usize,
    /// Not additive: the value is the decisions equal to 1 (a `score` of its own).
    scored: bool,
}

const CARDS: usize = 8;
const HORIZON: usize = 10;

fn card(seed: u64, episode: usize, t: usize) -> u64 {
    let mut x =
        seed ^ (episode as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ (t as u64).wrapping_mul(0xD1B5_4A32_D192_ED03);
    x ^= x >> 31;
    x = x.wrapping_mul(0xBF58_476D_1CE4_E5B9);
    x ^= x >> 29;
    x % CARDS as u64
}

impl BatchWorld for Colours {
    fn shape(&self) -> Shape {
        Shape { observations: CARDS, decisions: 2, horizon: HORIZON }
    }
    fn description(&self) -> Value {
        json!({"name": "outside", "class": "tests.Colours"})
    }
    fn max_batch(&self) -> usize {
        64
    }
    fn reset(&mut self, seed: u64, observations: &mut [i64]) -> ceworld::Result<()> {
        self.t = 0;
        self.cards = (0..observations.len()).map(|i| seed.wrapping_add(i as u64)).collect();
        for (i, y) in observations.iter_mut().enumerate() {
            *y = card(self.cards[i], i, 0) as i64;
        }
        Ok(())
    }
    fn step(&mut self, decisions: &[i64], out: StepOut<'_>) -> ceworld::Result<()> {
        for (i, &d) in decisions.iter().enumerate() {
            out.rewards[i] = f64::from(u8::from(d as u64 == card(self.cards[i], i, self.t) % 2));
            out.observations[i] = card(self.cards[i], i, self.t + 1) as i64;
        }
        self.t += 1;
        Ok(())
    }
    fn additive(&self) -> bool {
        !self.scored
    }
    fn score(&mut self, episode: &Recorded<'_>) -> ceworld::Result<f64> {
        if self.scored {
            Ok(episode.decisions().filter(|&d| d == 1).count() as f64)
        } else {
            Ok(episode.rewards.iter().sum())
        }
    }
}

fn world(scored: bool) -> Lockstep<Colours> {
    Lockstep::new(Colours { cards: Vec::new(), t: 0, scored }).unwrap()
}

/// Memoryless policies (one Mealy node), the laws refitted wholly each iteration (`α = 1`).
fn settings(credit: Credit, threads: usize) -> ControllerConfig {
    ControllerConfig {
        nodes: 1,
        samples: 20,
        rho: 0.1,
        smoothing: 1.0,
        episodes: 5,
        max_iterations: Some(2),
        candidates: 2,
        select_episodes: 20,
        eval_episodes: 100,
        decisions: Decisions::Mealy,
        memory: Memory::Nodes,
        model_nodes: 0,
        threads: Some(threads),
        credit,
        ..ControllerConfig::default()
    }
}

fn search(world: &Lockstep<Colours>, credit: Credit, threads: usize) -> ControllerOutcome {
    optimize_controller(Valued::Sampled(world), &settings(credit, threads), |_| Flow::Continue).unwrap()
}

/// What a search found: its policy file's policy and each iteration's mean and best so far.
fn found(outcome: &ControllerOutcome) -> (ceworld::Hhmm, Vec<(f64, f64)>) {
    let means = outcome.history.iter().map(|r| (r.record.mean, r.best_so_far)).collect();
    (outcome.policy.clone(), means)
}

#[test]
fn credit_within_episodes_finds_every_row_s_best_decision_in_one_iteration() {
    let steps = search(&world(false), Credit::Steps, 1);
    // 20 random memoryless policies of 2^8, 1000 steps: each card's best colour by its steps'
    // credit, so that every controller of the second iteration is the best policy.
    let second = &steps.history[1].record;
    assert_eq!((second.mean, second.best), (HORIZON as f64, HORIZON as f64));
    // From the elite (its best 2 controllers), the second iteration is not there yet.
    let elite = search(&world(false), Credit::Elite, 1);
    assert!(elite.history[1].record.mean < HORIZON as f64 - 1.0, "{:?}", elite.history[1].record);
    // The same search whatever the thread count.
    let again = search(&world(false), Credit::Steps, 2);
    assert_eq!(found(&again), found(&steps));
}

#[test]
fn a_world_whose_value_is_not_a_sum_of_rewards_refits_from_the_elite() {
    let (steps, elite) = (search(&world(true), Credit::Steps, 1), search(&world(true), Credit::Elite, 1));
    assert_eq!(found(&steps), found(&elite));
}

#[test]
fn a_credited_search_resumes_from_its_checkpoint_bit_for_bit() {
    use ceworld::Checkpointing;
    let dir = std::env::temp_dir().join(format!("ceworld-credit-resume-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let world = world(false);
    let config = ControllerConfig {
        nodes: 2,
        smoothing: 0.25,
        max_iterations: Some(9),
        restarts: 2,
        ..settings(Credit::Steps, 1)
    };
    let whole = optimize_controller(Valued::Sampled(&world), &config, |_| Flow::Continue).unwrap();
    let checkpointing = Checkpointing { path: dir.join("credit.ckpt"), every: 1e9, resume: true, outputs: Vec::new() };
    // Stopped at every third iteration (a Ctrl-C), then resumed, until it ends.
    let (resumed, sessions) = sessions::in_sessions(Valued::Sampled(&world), &config, &checkpointing);
    assert!(sessions > 2, "{sessions} sessions");
    assert_eq!(found(&resumed), found(&whole));
    assert_eq!(resumed.run_values, whole.run_values);
    // The same episodes too: the checkpoints keep the selection scores.
    let episodes =
        |o: &ceworld::ce::controller::ControllerOutcome| o.history.iter().map(|r| r.episodes).collect::<Vec<_>>();
    assert_eq!(episodes(&resumed), episodes(&whole));
    std::fs::remove_dir_all(&dir).unwrap();
}
