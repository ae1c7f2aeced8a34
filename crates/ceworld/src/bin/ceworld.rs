//! `ceworld`: optimise, evaluate and inspect HHMM policies from the command line.

use std::io::Write;
use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

use clap::{Parser, Subcommand};
use serde_json::Value;

use ceworld::optimize::thread_pool;
use ceworld::{
    CeConfig, Error, Flow, PolicyFile, Result, TargetTracking, TrackingParams, evaluate, optimize, random_policy,
    uniform_policy,
};

/// Cross-entropic learning of hierarchical-HMM policies (Dambreville's method) for the
/// target-tracking world of SPEC §4.
#[derive(Parser)]
#[command(name = "ceworld", version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Optimise a policy by the cross-entropy method and save it as JSON (SPEC §6).
    ///
    /// Prints a live progress line; Ctrl-C stops between iterations and still saves the best
    /// policy so far (marked "interrupted" in its provenance).
    Optimize(OptimizeArgs),
    /// Evaluate a saved policy on fresh episodes of the world stored in its file.
    Evaluate {
        /// The policy file (JSON, SPEC §6).
        file: PathBuf,
        /// Number of fresh episodes.
        #[arg(long, default_value_t = 100_000)]
        episodes: usize,
        /// Seed of the evaluation episodes.
        #[arg(long, default_value_t = 0)]
        seed: u64,
        /// Worker threads (default: one per core).
        #[arg(long)]
        threads: Option<usize>,
    },
    /// Print the exact optimum of a world (known for case 1, fixed target).
    Optimum {
        /// World case (only 1 has a known optimum).
        #[arg(long, default_value_t = 1)]
        case: u8,
        /// A world parameter KEY=VALUE (repeatable), e.g. --param target_cell=[5,5].
        #[arg(long = "param", value_name = "KEY=VALUE")]
        params: Vec<String>,
    },
}

#[derive(clap::Args)]
struct OptimizeArgs {
    /// World case: 1 fixed target, 2 moving target unobserved, 3 moving target observed.
    #[arg(long, default_value_t = 3)]
    case: u8,
    /// A world parameter KEY=VALUE (repeatable): width, height, horizon, start_b, start_c,
    /// start_heading, reward_radius, observe_radius, target_cell, target_rows; lists as [a,b].
    #[arg(long = "param", value_name = "KEY=VALUE")]
    params: Vec<String>,
    /// Memory sizes per level, bottom first: 16 is a memoryless policy, 16,16 an IO-HMM.
    #[arg(long, default_value = "16,16", value_delimiter = ',')]
    levels: Vec<usize>,
    /// Episodes per iteration (N).
    #[arg(long, default_value_t = 1000)]
    samples: usize,
    /// Selective rate: the best ceil(rho*N) episodes refit the tables; 0 < rho < 1.
    #[arg(long, default_value_t = 0.5)]
    rho: f64,
    /// Smoothing alpha in (0, 1]: h := alpha*new + (1-alpha)*h (1 = the paper's basic CE).
    #[arg(long, default_value_t = 1.0)]
    smoothing: f64,
    /// Stop after this many unsuccessful iterations in a row (the paper's weak criterion is
    /// 100, its strong criterion 500).
    #[arg(long, default_value_t = 100)]
    patience: usize,
    /// Stop after this many iterations.
    #[arg(long)]
    max_iterations: Option<usize>,
    /// Stop after this many seconds (checked between iterations).
    #[arg(long)]
    time_limit: Option<f64>,
    /// Stop once an iteration's mean reward reaches this value.
    #[arg(long)]
    target: Option<f64>,
    /// Seed: the same seed and settings give the same policy, whatever the thread count.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Worker threads (default: one per core).
    #[arg(long)]
    threads: Option<usize>,
    /// Fresh episodes used to evaluate the result.
    #[arg(long, default_value_t = 10_000)]
    eval_episodes: usize,
    /// Start from random tables (drawn from the seed) instead of uniform ones.
    #[arg(long)]
    random_init: bool,
    /// Start from a saved policy instead.
    #[arg(long, value_name = "FILE.json", conflicts_with = "random_init")]
    init: Option<PathBuf>,
    /// Where to save the best policy.
    #[arg(long, default_value = "policy.json", value_name = "FILE.json")]
    out: PathBuf,
    /// No progress line.
    #[arg(long, short)]
    quiet: bool,
}

fn world_from(case: u8, params: &[String]) -> Result<TargetTracking> {
    let mut value = serde_json::to_value(TrackingParams { case, ..TrackingParams::default() }).expect("serialisable");
    for p in params {
        let (key, raw) = p
            .split_once('=')
            .ok_or_else(|| Error::invalid("--param", format!("{p:?} (expected KEY=VALUE, e.g. horizon=50)")))?;
        let map = value.as_object_mut().expect("an object");
        if !map.contains_key(key) {
            let known: Vec<&String> = map.keys().collect();
            return Err(Error::invalid("--param", format!("unknown key {key:?} (expected one of {known:?})")));
        }
        let v: Value = serde_json::from_str(raw)
            .map_err(|e| Error::invalid("--param", format!("{key}={raw}: not a JSON value ({e})")))?;
        map.insert(key.to_string(), v);
    }
    let params: TrackingParams = serde_json::from_value(value).map_err(|e| Error::invalid("--param", e.to_string()))?;
    TargetTracking::with_params(params)
}

fn run_optimize(args: OptimizeArgs) -> Result<()> {
    let world = world_from(args.case, &args.params)?;
    let config = CeConfig {
        samples: args.samples,
        rho: args.rho,
        smoothing: args.smoothing,
        patience: args.patience,
        max_iterations: args.max_iterations,
        time_limit: args.time_limit,
        target: args.target,
        seed: args.seed,
        threads: args.threads,
        eval_episodes: args.eval_episodes,
    };
    config.validate()?;
    let initial = match &args.init {
        Some(path) => PolicyFile::load(path)?.policy,
        None if args.random_init => random_policy(&world, &args.levels, args.seed)?,
        None => uniform_policy(&world, &args.levels)?,
    };
    let stop = Arc::new(AtomicBool::new(false));
    {
        let stop = stop.clone();
        // A second Ctrl-C while the first is being honoured kills the process as usual.
        let _ = ctrlc::set_handler(move || {
            if stop.swap(true, Ordering::SeqCst) {
                std::process::exit(130);
            }
        });
    }
    if !args.quiet {
        eprintln!(
            "ceworld: case {} levels {:?} ({} parameters), N = {}, rho = {}, alpha = {}, patience {}, seed {}",
            args.case,
            initial.levels(),
            initial.layout().parameter_count(),
            config.samples,
            config.rho,
            config.smoothing,
            config.patience,
            config.seed
        );
    }
    let mut best_mean = f64::NEG_INFINITY;
    let mut best_iteration = 0;
    let mut since = 0;
    let mut last_print = Instant::now();
    let result = optimize(&world, initial, &config, |r| {
        if r.successful {
            best_mean = r.mean;
            best_iteration = r.iteration;
            since = 0;
        } else {
            since += 1;
        }
        if !args.quiet && (last_print.elapsed().as_millis() >= 100 || r.iteration == 0) {
            last_print = Instant::now();
            eprint!(
                "\r\x1b[Kiter {:>5}  mean {:>7.2}  elite>= {:>6.1}  best mean {:>7.2} (iter {})  no gain {:>3}/{}  {:>6.1}s",
                r.iteration, r.mean, r.elite_threshold, best_mean, best_iteration, since, config.patience, r.seconds
            );
            let _ = std::io::stderr().flush();
        }
        if stop.load(Ordering::SeqCst) { Flow::Stop } else { Flow::Continue }
    })?;
    let file = PolicyFile::from_result(&world, &result, &config);
    file.save(&args.out)?;
    let e = &result.evaluation;
    if !args.quiet {
        eprintln!();
    }
    println!(
        "{}: {} iterations in {:.1}s, best iteration {} (mean {:.2}); evaluation on {} fresh episodes: {:.2} ± {:.2} (min {}, max {}); saved {}",
        result.stop.as_str(),
        result.history.len(),
        result.seconds,
        result.best_iteration,
        result.history[result.best_iteration].mean,
        e.episodes,
        e.mean,
        e.std_error,
        e.min,
        e.max,
        args.out.display()
    );
    Ok(())
}

fn run() -> Result<()> {
    match Cli::parse().command {
        Command::Optimize(args) => run_optimize(args),
        Command::Evaluate { file, episodes, seed, threads } => {
            let f = PolicyFile::load(&file)?;
            let world = TargetTracking::from_json(&f.world)?;
            let pool = thread_pool(threads)?;
            let started = Instant::now();
            let e = pool.install(|| evaluate(&world, &f.policy, episodes, seed))?;
            let q: Vec<String> = e.quantiles.iter().map(|(q, v)| format!("q{:.0}={v}", q * 100.0)).collect();
            println!(
                "{}: {} episodes: mean {:.3} ± {:.3} (std {:.2}), min {}, max {}, {} ({:.2}s)",
                file.display(),
                e.episodes,
                e.mean,
                e.std_error,
                e.std,
                e.min,
                e.max,
                q.join(" "),
                started.elapsed().as_secs_f64()
            );
            Ok(())
        }
        Command::Optimum { case, params } => {
            let world = world_from(case, &params)?;
            println!("{}", world.case1_optimum()?);
            Ok(())
        }
    }
}

fn main() -> ExitCode {
    match run() {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("ceworld: error: {e}");
            ExitCode::from(2)
        }
    }
}
