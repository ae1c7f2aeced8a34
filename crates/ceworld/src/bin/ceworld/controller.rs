//! `ceworld controller`: the cross-entropy method over deterministic controllers of any world,
//! on exact values (a tabular world) or sampled ones (model §8).

use std::path::PathBuf;

use ceworld::ce::controller::{ControllerConfig, Template, ValueKind, Valued, optimize_controller_with};
use ceworld::progress::LiveLine;
use ceworld::{Flow, Result};

use crate::{CheckpointArgs, WorldArgs, stop, world_from};

#[derive(clap::Args)]
pub(crate) struct ControllerArgs {
    #[command(flatten)]
    world: WorldArgs,
    /// Nodes of the controller.
    #[arg(long, default_value_t = ControllerConfig::default().nodes)]
    nodes: usize,
    /// Controllers drawn per iteration (N).
    /// [default: 2000 on exact values, 1000 on sampled ones]
    #[arg(long)]
    samples: Option<usize>,
    /// Selective rate: the best ceil(rho*N) controllers refit the laws; 0 < rho < 1 [default:
    /// 0.02 on exact values, 0.05 on sampled ones].
    #[arg(long)]
    rho: Option<f64>,
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
    /// Stop once the best value so far reaches this.
    #[arg(long)]
    target: Option<f64>,
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
    /// How each controller is valued: "exact" (a tabular world, the default there) or "sampled"
    /// (episodes on common random numbers: the default on every other world).
    #[arg(long, value_parser = parse_value_kind, value_name = "exact|sampled")]
    value: Option<ValueKind>,
    /// Sampled values: episodes per controller and iteration (K), shared by every controller of
    /// an iteration.
    #[arg(long, default_value_t = ControllerConfig::default().episodes)]
    episodes: usize,
    /// Sampled values: the iteration's best controllers scored again on the selection episodes;
    /// the best so far is the best there.
    #[arg(long, default_value_t = ControllerConfig::default().candidates)]
    candidates: usize,
    /// Sampled values: the selection episodes (the same for every iteration and run).
    #[arg(long, default_value_t = ControllerConfig::default().select_episodes)]
    select_episodes: usize,
    /// Sampled values: fresh episodes that value the controller returned.
    #[arg(long, default_value_t = ControllerConfig::default().eval_episodes)]
    eval_episodes: usize,
    /// When patience runs out, mix this weight of the uniform law into every law and go on
    /// (an escape from a converged run; see --injections).
    #[arg(long, default_value_t = ControllerConfig::default().injection)]
    injection: f64,
    /// The most escapes of one run (0: a run stops when patience runs out).
    #[arg(long, default_value_t = ControllerConfig::default().injections)]
    injections: usize,
    /// The memory the laws start from: uniform, hold (a latch: nodes stay), clock (node q moves
    /// to q+1), mixed (both) or window (the last observations: q moves to (q*Y + y) mod n).
    /// [default: uniform on exact values, mixed on sampled ones]
    #[arg(long, value_parser = parse_template)]
    template: Option<Template>,
    /// The weight of the template in the first successor laws, in [0, 1).
    #[arg(long, default_value_t = ControllerConfig::default().template_weight)]
    template_weight: f64,
    /// Where to save the best controller (a policy file, model §6).
    #[arg(long, default_value = "policy.json", value_name = "FILE.json")]
    out: PathBuf,
    #[command(flatten)]
    checkpoint: CheckpointArgs,
    /// No progress line.
    #[arg(long, short)]
    quiet: bool,
}

pub(crate) fn run_controller(args: &ControllerArgs) -> Result<()> {
    let world = world_from(&args.world)?;
    let valued = Valued::of(&world, args.value)?;
    let d = ControllerConfig::defaults_for(valued.kind());
    let config = ControllerConfig {
        nodes: args.nodes,
        samples: args.samples.unwrap_or(d.samples),
        rho: args.rho.unwrap_or(d.rho),
        smoothing: args.smoothing,
        patience: args.patience,
        max_iterations: args.max_iterations,
        target: args.target,
        time_limit: args.time_limit,
        tolerance: args.tolerance,
        seed: args.seed,
        threads: args.threads,
        restarts: args.restarts,
        episodes: args.episodes,
        candidates: args.candidates,
        select_episodes: args.select_episodes,
        eval_episodes: args.eval_episodes,
        injection: args.injection,
        injections: args.injections,
        template: args.template.unwrap_or(d.template),
        template_weight: args.template_weight,
    };
    config.validate()?;
    let checkpointing = args.checkpoint.checkpointing(args.quiet)?;
    stop::install();
    let mut line = (!args.quiet).then(LiveLine::stderr);
    let outcome = optimize_controller_with(valued, &config, checkpointing.as_ref(), |r| {
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
    outcome.to_file(valued.episodes(), &config).save(&args.out)?;
    let what = match (&outcome.evaluation, &world) {
        (Some(e), _) => format!("{:.4} ± {:.4} on {} fresh episodes", e.mean, e.std_error, e.episodes),
        (None, ceworld::AnyWorld::Pomdp(w)) if w.tables().gamma < 1.0 => {
            format!("exact infinite-horizon value {:.6}", outcome.value)
        }
        (None, _) => format!("exact value at the horizon {:.6}", outcome.value),
    };
    if config.restarts > 1 {
        let values: Vec<String> = outcome.run_values.iter().map(|v| format!("{v:.6}")).collect();
        let on = if outcome.evaluation.is_some() { "on the selection episodes" } else { "exact" };
        println!(
            "best of {} runs: run {} (values {on}: {})",
            outcome.run_values.len(),
            outcome.restart,
            values.join(", ")
        );
    }
    println!(
        "{}: {} iterations in {:.1}s, best controller from iteration {}: {what}; saved {}",
        outcome.stop.as_str(),
        outcome.history.len(),
        outcome.seconds,
        outcome.best_iteration,
        args.out.display()
    );
    Ok(())
}

fn parse_value_kind(text: &str) -> std::result::Result<ValueKind, String> {
    ValueKind::parse(text).map_err(|e| e.to_string())
}

fn parse_template(text: &str) -> std::result::Result<Template, String> {
    Template::parse(text).map_err(|e| e.to_string())
}
