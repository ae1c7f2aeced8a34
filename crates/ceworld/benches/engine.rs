//! Hot paths of the engine: one episode and one CE iteration, for several model sizes.
//! Throughput is in episode-steps per second (`cargo bench -p ceworld`).

use std::hint::black_box;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};

use ceworld::ce::counting::count_episode;
use ceworld::episodes::run::run_recorded;
use ceworld::rng::{Purpose, stream};
use ceworld::{CeConfig, Flow, PomdpWorld, TargetTracking, World, optimize, random_policy};

const MODELS: [&[usize]; 3] = [&[16], &[16, 16], &[256, 256]];

fn episode(c: &mut Criterion) {
    let world = TargetTracking::new(3).unwrap();
    let mut group = c.benchmark_group("episode");
    group.throughput(Throughput::Elements(world.horizon() as u64));
    for levels in MODELS {
        let policy = random_policy(&world, levels, 1).unwrap();
        let mut record = vec![0u16; world.horizon() * policy.layout().record_width()];
        let mut k = 0u64;
        group.bench_function(format!("{levels:?}"), |b| {
            b.iter(|| {
                k += 1;
                let mut rng = stream(0, Purpose::Optimise, 0, k);
                black_box(run_recorded(&world, &policy, &mut rng, &mut record))
            });
        });
        let mut counts = vec![0u32; policy.layout().len];
        group.bench_function(format!("count {levels:?}"), |b| {
            b.iter(|| count_episode(policy.layout(), black_box(&record), &mut counts));
        });
    }
    group.finish();
}

/// One world step and one policy step alone, over a batch of 1000 to amortise the loop.
fn steps(c: &mut Criterion) {
    let world = TargetTracking::new(3).unwrap();
    let mut group = c.benchmark_group("step_x1000");
    group.throughput(Throughput::Elements(1000));
    let mut rng = stream(0, Purpose::Optimise, 0, 0);
    let mut state = world.reset(&mut rng);
    group.bench_function("world (observe + step)", |b| {
        b.iter(|| {
            let mut acc = 0;
            for k in 0..1000 {
                acc += world.observe(&state, &mut rng);
                world.step(&mut state, k & 15, &mut rng);
            }
            black_box(acc)
        });
    });
    for levels in MODELS {
        let policy = random_policy(&world, levels, 1).unwrap();
        let mut memory = vec![0u16; levels.len()];
        group.bench_function(format!("policy {levels:?}"), |b| {
            b.iter(|| {
                let mut acc = 0;
                for k in 0..1000 {
                    acc += policy.step(k & 15, &mut memory, false, &mut rng);
                }
                black_box(acc)
            });
        });
    }
    group.finish();
}

fn ce_iteration(c: &mut Criterion) {
    let world = TargetTracking::new(3).unwrap();
    let mut group = c.benchmark_group("ce_iteration_N1000");
    group.sample_size(10);
    group.throughput(Throughput::Elements(1000 * world.horizon() as u64));
    for levels in MODELS {
        let policy = random_policy(&world, levels, 1).unwrap();
        let config = CeConfig { max_iterations: Some(1), eval_episodes: 1, ..CeConfig::default() };
        group.bench_function(format!("{levels:?}"), |b| {
            b.iter(|| optimize(&world, policy.clone(), &config, |_| Flow::Continue).unwrap());
        });
    }
    group.finish();
}

/// A world step (observe + step) of tabular worlds beside target tracking's, over 1000 steps,
/// with sampled and belief rewards: the cost per step of the `.pomdp` world (model §7).
fn tabular_steps(c: &mut Criterion) {
    let mut group = c.benchmark_group("world_step_x1000");
    group.throughput(Throughput::Elements(1000));
    let tracking = TargetTracking::new(3).unwrap();
    bench_world(&mut group, "target-tracking case 3", &tracking);
    for (file, reward) in [
        ("tiger.95.POMDP", "sampled"),
        ("hallway.POMDP", "sampled"),
        ("tag.pomdp", "sampled"),
        ("hallway.POMDP", "belief"),
        ("tag.pomdp", "belief"),
    ] {
        let path = format!("{}/../../data/pomdp/{file}", env!("CARGO_MANIFEST_DIR"));
        let params = ceworld::PomdpParams {
            file: path,
            reward: serde_json::from_value(reward.into()).unwrap(),
            ..ceworld::PomdpParams::default()
        };
        let world = PomdpWorld::with_params(params).unwrap();
        bench_world(&mut group, &format!("{file} {reward}"), &world);
    }
    group.finish();
}

fn bench_world<W: World>(
    group: &mut criterion::BenchmarkGroup<'_, criterion::measurement::WallTime>,
    name: &str,
    world: &W,
) {
    let mut rng = stream(0, Purpose::Optimise, 0, 0);
    let d = world.n_decisions();
    group.bench_function(name, |b| {
        b.iter(|| {
            let mut state = world.reset(&mut rng);
            let mut acc = 0;
            for k in 0..1000 {
                acc += world.observe(&state, &mut rng);
                world.step(&mut state, k % d, &mut rng);
            }
            black_box((acc, world.reward(&state)))
        });
    });
}

/// The exact value of one controller (model §8) of hallway at 8, 32 and 64 nodes (seeded random
/// controllers, which reach most (state, node) pairs), beside the exact evaluation of the same
/// controller as an HHMM (`exact::infinite_horizon`, the general recursion) as the in-run
/// reference: `cargo bench -p ceworld -- exact_controller_value`.
fn exact_controller_value(c: &mut Criterion) {
    use ceworld::ce::controller::{Controller, ControllerValue, Scratch};
    use rand::RngExt;
    let path = format!("{}/../../data/pomdp/hallway.POMDP", env!("CARGO_MANIFEST_DIR"));
    let world = PomdpWorld::from_file(path, 100, None).unwrap();
    let t = world.tables();
    let (y1, n_a) = (t.n_observations() + 1, t.n_actions());
    let mut group = c.benchmark_group("exact_controller_value");
    group.sample_size(10);
    for n in [8usize, 32, 64] {
        let mut rng = stream(7, Purpose::Evaluate, 0, n as u64);
        let controller = Controller::moore(
            (0..n).map(|_| rng.random_range(0..n_a as u32)).collect(),
            (0..n * y1).map(|_| rng.random_range(0..n as u32)).collect(),
        );
        let values = ControllerValue::new(&world, 1e-6);
        let mut scratch = Scratch::default();
        group.bench_function(format!("hallway {n} nodes"), |b| {
            b.iter(|| black_box(values.value(&controller, &mut scratch)));
        });
        if n == 8 {
            let policy = controller.to_hhmm(y1, n_a).unwrap();
            group.bench_function(format!("hallway {n} nodes as an HHMM (reference)"), |b| {
                b.iter(|| black_box(ceworld::exact::infinite_horizon(&world, &policy, 1e-6).unwrap().value));
            });
        }
    }
    group.finish();
}

criterion_group!(benches, steps, episode, ce_iteration, tabular_steps, exact_controller_value);
criterion_main!(benches);
