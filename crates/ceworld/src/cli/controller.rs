//! `ceworld controller`: the cross-entropy method over deterministic controllers of any world
//! (a .pomdp file, target tracking), on exact values (a .pomdp file's) or sampled ones (model §8).

use crate::Result;
use crate::ce::controller::{ControllerConfig, Decisions, Memory, Template, ValueKind};
use crate::episodes::Episodes;
use crate::run;

use crate::cli::{OutputArgs, WorldArgs, stop, world_from};

#[derive(clap::Args)]
pub(crate) struct ControllerArgs {
    #[command(flatten)]
    world: WorldArgs,
    #[command(flatten)]
    config: ControllerConfig,
    /// Controllers drawn per iteration (N).
    /// [default: 2000 on exact values, 200 on sampled ones]
    #[arg(long)]
    samples: Option<usize>,
    /// Selective rate: the best ceil(rho*N) controllers refit the laws; 0 < rho < 1 [default:
    /// 0.02 on exact values, 0.05 on sampled ones].
    #[arg(long)]
    rho: Option<f64>,
    /// Smoothing alpha in (0, 1]: p := alpha*(refit law) + (1 - alpha)*p [default: 0.1 on
    /// exact values, 0.25 on sampled ones].
    #[arg(long)]
    smoothing: Option<f64>,
    /// How each controller is valued: "exact" (a .pomdp file's world, the default there) or
    /// "sampled" (episodes on common random numbers: any world, the default on every other).
    #[arg(long, value_parser = parse_value_kind, value_name = "exact|sampled")]
    value: Option<ValueKind>,
    /// The memory the laws start from: uniform, hold (a latch: nodes stay), clock (node q moves
    /// to q+1), mixed (both) or window (the last observations: q moves to (q*Y + y) mod n).
    /// [default: uniform on exact values, mixed on sampled ones]
    #[arg(long, value_parser = parse_template)]
    template: Option<Template>,
    /// What a decision reads: moore (the node) or mealy (the node and the observation: one
    /// node is a memoryless policy). [default: moore on exact values, mealy on sampled ones]
    #[arg(long, value_parser = parse_decisions, value_name = "moore|mealy")]
    decisions: Option<Decisions>,
    /// Mealy decisions without a model start: the laws start with one node (a memoryless
    /// policy) and widen to --nodes around the best after this many iterations without a
    /// better controller (three times as many in all at most); 0: no memoryless stage.
    /// [default: 0 on exact values, 10 on sampled ones]
    #[arg(long)]
    memoryless_patience: Option<usize>,
    /// The memory's layout: nodes (--nodes flat nodes), registers (--registers registers of
    /// --register-size values, each moving on the observation and the register before it; Mealy
    /// decisions), clock (64 nodes, node t for step t, with Moore decisions: a time-indexed
    /// policy) or alternate (runs take turns: flat nodes from --template, registers as a shift
    /// register of the last observations, then the clock). [default: nodes on exact values,
    /// alternate on sampled ones]
    #[arg(long, value_parser = parse_memory, value_name = "nodes|registers|clock|alternate")]
    memory: Option<Memory>,
    #[command(flatten)]
    output: OutputArgs,
}

pub(crate) fn run_controller(args: &ControllerArgs) -> Result<()> {
    let world = world_from(&args.world)?;
    crate::with_world!(&world, w => search_in(w, args))
}

/// `controller` in one world of the registry.
fn search_in(world: &dyn Episodes, args: &ControllerArgs) -> Result<()> {
    let (valued, config) = run::controller_setup(world, args.value, |config| {
        *config = ControllerConfig {
            samples: args.samples.unwrap_or(config.samples),
            rho: args.rho.unwrap_or(config.rho),
            smoothing: args.smoothing.unwrap_or(config.smoothing),
            template: args.template.unwrap_or(config.template),
            decisions: args.decisions.unwrap_or(config.decisions),
            memoryless_patience: args.memoryless_patience.unwrap_or(config.memoryless_patience),
            memory: args.memory.unwrap_or(config.memory),
            ..args.config.clone()
        };
        Ok(())
    })?;
    // The result is not lost to an unwritable --out found after the run.
    args.output.check::<crate::ce::controller::checkpoint::ControllerSearch>(&args.world.files())?;
    let checkpointing = args.output.checkpointing()?;
    stop::install();
    let options = args.output.run_options(checkpointing.as_ref());
    let outcome = run::controller(valued, &config, &options)?;
    let file = outcome.to_file(valued.episodes(), &config);
    args.output.save(&file, &outcome.history, outcome.checkpoint_error.as_deref())?;
    let what = match (&outcome.evaluation, world.tabular()) {
        (Some(e), _) => {
            let d = crate::progress::decimals(e.std_error);
            let (mean, se) = (crate::progress::fixed(e.mean, d), crate::progress::fixed(e.std_error, d));
            format!("{mean} ± {se} on {} fresh episodes", e.episodes)
        }
        (None, Some(w)) if w.tables().gamma < 1.0 => {
            format!("exact infinite-horizon value {:.6}", outcome.value)
        }
        (None, _) => format!("exact value at the horizon {:.6}", outcome.value),
    };
    if let Some(s) = &outcome.start {
        let fate = if s.kept { "kept: the runs start around it" } else { "not kept: it does not beat that" };
        println!(
            "model start: {} nodes, exact value {:.6} ({:.6} before its nodes were improved; the best blind policy {:.6}); {fate}",
            s.nodes, s.value, s.built, s.blind
        );
    }
    if outcome.run_values.len() > 1 {
        // The first runs' values (all of them are in the policy file's provenance).
        const SHOWN: usize = 10;
        let mut values: Vec<String> = outcome.run_values.iter().take(SHOWN).map(|v| format!("{v:.6}")).collect();
        if outcome.run_values.len() > SHOWN {
            values.push("...".into());
        }
        let on = if outcome.evaluation.is_some() { "on the selection episodes" } else { "exact" };
        println!(
            "best of {} runs: run {} (values {on}: {})",
            outcome.run_values.len(),
            outcome.restart,
            values.join(", ")
        );
    }
    println!(
        "{}: {} iterations ({} steps of the world) in {:.1}s, best controller from iteration {}: {what}; saved {}",
        outcome.stop.as_str(),
        outcome.history.len(),
        outcome.env_steps,
        outcome.seconds,
        outcome.best_iteration,
        args.output.out.display()
    );
    Ok(())
}

fn parse_value_kind(text: &str) -> std::result::Result<ValueKind, String> {
    ValueKind::parse(text).map_err(|e| e.to_string())
}

fn parse_template(text: &str) -> std::result::Result<Template, String> {
    Template::parse(text).map_err(|e| e.to_string())
}

fn parse_decisions(text: &str) -> std::result::Result<Decisions, String> {
    Decisions::parse(text).map_err(|e| e.to_string())
}

fn parse_memory(text: &str) -> std::result::Result<Memory, String> {
    Memory::parse(text).map_err(|e| e.to_string())
}
