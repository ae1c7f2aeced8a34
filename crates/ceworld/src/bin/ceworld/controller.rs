//! `ceworld controller`: the cross-entropy method over deterministic controllers of a tabular
//! world (model §8).

use std::path::PathBuf;

use ceworld::ce::controller::{ControllerConfig, optimize_controller};
use ceworld::progress::LiveLine;
use ceworld::{AnyWorld, Error, Flow, PolicyFile, Result};

use crate::{WorldArgs, stop, world_from};

#[derive(clap::Args)]
pub(crate) struct ControllerArgs {
    #[command(flatten)]
    world: WorldArgs,
    /// Nodes of the controller.
    #[arg(long, default_value_t = ControllerConfig::default().nodes)]
    nodes: usize,
    /// Controllers drawn per iteration (N).
    #[arg(long, default_value_t = ControllerConfig::default().samples)]
    samples: usize,
    /// Selective rate: the best ceil(rho*N) controllers refit the laws; 0 < rho < 1.
    #[arg(long, default_value_t = ControllerConfig::default().rho)]
    rho: f64,
    /// Smoothing alpha in (0, 1]: p := alpha*frequency + (1-alpha)*p.
    #[arg(long, default_value_t = ControllerConfig::default().smoothing)]
    smoothing: f64,
    /// Stop after this many iterations in a row without progress (neither a better controller
    /// nor a higher elite threshold).
    #[arg(long, default_value_t = ControllerConfig::default().patience)]
    patience: usize,
    /// Stop after this many iterations.
    #[arg(long)]
    max_iterations: Option<usize>,
    /// Stop after this many seconds (checked before each controller's evaluation; an iteration
    /// it cuts does not refit the laws).
    #[arg(long)]
    time_limit: Option<f64>,
    /// Absolute tolerance of each controller's infinite-horizon value.
    #[arg(long, default_value_t = ControllerConfig::default().tolerance)]
    tolerance: f64,
    /// Seed: the same seed and settings give the same controller, whatever the thread count.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Worker threads (default: one per core).
    #[arg(long)]
    threads: Option<usize>,
    /// Independent runs; the best controller of all is kept (the first run uses --seed, the
    /// others seeds derived from it; the values are exact, so choosing has no bias).
    #[arg(long, default_value_t = ControllerConfig::default().restarts)]
    restarts: usize,
    /// Where to save the best controller (a policy file, model §6).
    #[arg(long, default_value = "policy.json", value_name = "FILE.json")]
    out: PathBuf,
    /// No progress line.
    #[arg(long, short)]
    quiet: bool,
}

pub(crate) fn run_controller(args: &ControllerArgs) -> Result<()> {
    let AnyWorld::Pomdp(world) = world_from(&args.world)? else {
        return Err(Error::invalid(
            "--pomdp",
            "missing (a controller search needs a tabular world: give --pomdp FILE)",
        ));
    };
    let config = ControllerConfig {
        nodes: args.nodes,
        samples: args.samples,
        rho: args.rho,
        smoothing: args.smoothing,
        patience: args.patience,
        max_iterations: args.max_iterations,
        time_limit: args.time_limit,
        tolerance: args.tolerance,
        seed: args.seed,
        threads: args.threads,
        restarts: args.restarts,
    };
    config.validate()?;
    stop::install();
    let mut line = (!args.quiet).then(LiveLine::stderr);
    let outcome = optimize_controller(&world, &config, |r| {
        if let Some(line) = &mut line {
            if r.iteration == 0 && r.restart > 0 {
                line.note(&format!("restart {} of {}", r.restart + 1, config.restarts));
            }
            line.update(format!(
                "iter {:>5}  mean {:>10.4}  elite>= {:>10.4}  best {:>10.4}  concentration {:.3}  {:>6.1}s",
                r.iteration, r.mean, r.elite_min, r.best, r.concentration, r.seconds
            ));
        }
        if stop::requested() { Flow::Stop } else { Flow::Continue }
    })?;
    if let Some(line) = line {
        line.finish();
    }
    PolicyFile::from_controller(&world, &outcome, &config).save(&args.out)?;
    let horizon = if world.tables().gamma < 1.0 { "infinite-horizon" } else { "at the horizon" };
    if config.restarts > 1 {
        let values: Vec<String> = outcome.run_values.iter().map(|v| format!("{v:.6}")).collect();
        println!("best of {} runs: run {} (values {})", outcome.run_values.len(), outcome.restart, values.join(", "));
    }
    println!(
        "{}: {} iterations in {:.1}s, best controller from iteration {}: exact {horizon} value {:.6}; saved {}",
        outcome.stop.as_str(),
        outcome.history.len(),
        outcome.seconds,
        outcome.best_iteration,
        outcome.value,
        args.out.display()
    );
    Ok(())
}
