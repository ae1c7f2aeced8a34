//! Thread scaling of one CE iteration: `cargo run --release -p ceworld --example scaling --
//! [SAMPLES] [LEVELS] [ITERATIONS] [THREADS...]`, e.g. `10000 16,16 5 1 2 4 8 16`.
//!
//! Prints, per thread count, the median seconds per iteration (evaluation excluded), the
//! episode-steps per second, the speed-up over 1 thread and the parallel efficiency
//! (speed-up / threads). Every run checks that the policy is bit-identical to the 1-thread one.

use ceworld::{CeConfig, Flow, TargetTracking, World, optimize, uniform_policy};

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let samples: usize = args.first().map_or(10_000, |s| s.parse().expect("SAMPLES is a number"));
    let levels: Vec<usize> =
        args.get(1).map_or("16,16", String::as_str).split(',').map(|s| s.parse().expect("LEVELS like 16,16")).collect();
    let iterations: usize = args.get(2).map_or(5, |s| s.parse().expect("ITERATIONS is a number"));
    let threads: Vec<usize> = if args.len() > 3 {
        args[3..].iter().map(|s| s.parse().expect("THREADS are numbers")).collect()
    } else {
        vec![1, 2, 4, 8, 16]
    };
    let world = TargetTracking::new(3).unwrap();
    let cores = std::thread::available_parallelism().map_or(1, std::num::NonZero::get);
    println!(
        "# CE iteration scaling: case 3, levels {levels:?}, N = {samples}, {iterations} iterations, {cores} cores"
    );
    println!("| threads | s / iteration (median) | episode-steps/s | speed-up | efficiency |");
    println!("|---:|---:|---:|---:|---:|");
    let mut base: Option<(f64, ceworld::Hhmm)> = None;
    for &t in &threads {
        let config = CeConfig {
            samples,
            max_iterations: Some(iterations),
            eval_episodes: 1,
            threads: Some(t),
            ..CeConfig::default()
        };
        let r = optimize(&world, uniform_policy(&world, &levels).unwrap(), &config, |_| Flow::Continue).unwrap();
        let mut per_iteration: Vec<f64> = r.history.iter().map(|h| h.seconds).collect();
        for k in (1..per_iteration.len()).rev() {
            per_iteration[k] -= per_iteration[k - 1];
        }
        per_iteration.sort_by(f64::total_cmp);
        let median = per_iteration[per_iteration.len() / 2];
        let rate = (samples * world.horizon()) as f64 / median;
        let (t1, reference) = base.get_or_insert((median, r.last_policy.clone()));
        assert!(*reference == r.last_policy, "{t} threads gave another policy than 1 thread");
        let speedup = *t1 / median;
        println!("| {t} | {median:.4} | {:.1} M | {speedup:.2} | {:.0} % |", rate / 1e6, 100.0 * speedup / t as f64);
    }
}
