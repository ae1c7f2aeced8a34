//! `ceworld qlearn` and `ceworld qlearn-eval`: the paper's Q-learning baseline and the window
//! comparison of policies.

use std::path::PathBuf;
use std::time::Instant;

use serde_json::Value;

use crate::qlearn::{AnyLearner, KnownState, PAPER_REFERENCE, Ties, evaluate_policy_windows, percent};
use crate::{
    AnyWorld, Error, PolicyFile, QConfig, QLearner, Result, WindowConfig, WindowReport, thread_pool, with_learner,
};

use super::{WorldArgs, world_from};

/// How windows are drawn for the paper's comparison.
#[derive(clap::Args)]
pub(crate) struct WindowArgs {
    #[command(flatten)]
    config: WindowConfig,
    /// Seed of the evaluation runs.
    #[arg(long, default_value_t = 0)]
    eval_seed: u64,
    /// Percentages are of this reward (the paper's best for case 3: 69).
    #[arg(long, default_value_t = PAPER_REFERENCE)]
    reference: f64,
    /// Worker threads for the evaluation (default: one per core; results do not depend on it).
    #[arg(long)]
    threads: Option<usize>,
}

#[derive(clap::Args)]
#[allow(clippy::struct_excessive_bools)] // command-line flags
pub(crate) struct QlearnArgs {
    /// The world (see the example in the command's help).
    #[command(flatten)]
    world: WorldArgs,
    /// Total number of updates (steps) of the run, e.g. 1e9; with --resume the run goes on
    /// until the table has this many.
    #[arg(long, default_value = "1e9", value_parser = parse_count)]
    iterations: u64,
    #[command(flatten)]
    config: QConfig,
    /// Where to save the learnt table (binary: a JSON header, then little-endian f32 values).
    #[arg(long, default_value = "qtable.bin", value_name = "FILE")]
    out: PathBuf,
    /// Checkpoint file (default: --out); written through a temporary file, so never broken.
    #[arg(long, value_name = "FILE")]
    checkpoint: Option<PathBuf>,
    /// Seconds between two checkpoints.
    #[arg(long, default_value_t = crate::qlearn::CHECKPOINT_EVERY, value_name = "SECONDS")]
    checkpoint_every: f64,
    /// Continue the run saved in the checkpoint file.
    #[arg(long, conflicts_with = "overwrite")]
    resume: bool,
    /// Start afresh even if the checkpoint file exists (it is replaced).
    #[arg(long)]
    overwrite: bool,
    /// Do not evaluate the greedy policy at the end.
    #[arg(long)]
    no_eval: bool,
    #[command(flatten)]
    windows: WindowArgs,
    /// No progress line.
    #[arg(long, short)]
    quiet: bool,
}

#[derive(clap::Args)]
pub(crate) struct QlearnEvalArgs {
    /// A Q table saved by `qlearn` (its greedy policy is evaluated).
    table: Option<PathBuf>,
    /// An HHMM policy file (JSON, model §6) to evaluate on the same windows, e.g. a CE policy
    /// with levels [16] from `optimize --case 3 --levels 16`; repeatable.
    #[arg(long = "ce-policy", value_name = "FILE.json")]
    ce_policies: Vec<PathBuf>,
    /// How the greedy policy breaks ties (default: as in learning).
    #[arg(long, value_enum)]
    ties: Option<Ties>,
    #[command(flatten)]
    windows: WindowArgs,
    /// Also write the reports as JSON to this file.
    #[arg(long, value_name = "FILE.json")]
    json: Option<PathBuf>,
    /// Replace --json when it exists.
    #[arg(long)]
    force: bool,
}

/// A count such as 1000000, `1_000_000` or 1e9.
fn parse_count(text: &str) -> std::result::Result<u64, String> {
    let plain = text.replace('_', "");
    if let Ok(n) = plain.parse::<u64>() {
        return Ok(n);
    }
    match plain.parse::<f64>() {
        Ok(x) if x >= 0.0 && x.fract() == 0.0 && x <= 9.2e18 => Ok(x as u64),
        _ => Err(format!("{text:?} (expected a whole number such as 1000000 or 1e9)")),
    }
}

/// The process's peak resident memory (`VmHWM`), in bytes, where the system reports it.
fn peak_rss() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let kib = status.lines().find_map(|l| l.strip_prefix("VmHWM:"))?.trim().strip_suffix("kB")?.trim();
    Some(kib.parse::<u64>().ok()? * 1024)
}

/// The learner `qlearn` runs: the checkpoint's with `--resume` (which must match the world and
/// the settings asked for), else a fresh one (refusing to overwrite a checkpoint unasked).
fn open_learner(
    args: &QlearnArgs,
    world: AnyWorld,
    config: QConfig,
    checkpoint: &std::path::Path,
) -> Result<AnyLearner> {
    Ok(if args.resume {
        if !checkpoint.exists() {
            return Err(Error::invalid(
                "--resume",
                format!("{} does not exist (start without --resume)", checkpoint.display()),
            ));
        }
        AnyLearner::resume(checkpoint, &world, &config)?
    } else {
        if checkpoint.exists() && !args.overwrite {
            return Err(Error::invalid(
                "--checkpoint",
                format!("{} exists: pass --resume to continue it or --overwrite to start afresh", checkpoint.display()),
            ));
        }
        AnyLearner::new(world, config)?
    })
}

pub(crate) fn run_qlearn(args: &QlearnArgs) -> Result<()> {
    args.config.validate()?;
    args.windows.config.validate()?;
    let checkpoint = args.checkpoint.clone().unwrap_or_else(|| args.out.clone());
    // The table is its own checkpoint unless --checkpoint names another file; then --out is a
    // result like any other (replaced by --overwrite, or by --resume of the run that writes it).
    let mut outputs = vec![("--checkpoint", checkpoint.as_path())];
    if args.checkpoint.as_ref().is_some_and(|c| !crate::files::same_file(c, &args.out)) {
        outputs.push(("--out", args.out.as_path()));
    }
    crate::files::check_distinct(&args.world.files(), &outputs)?;
    if outputs.len() > 1 && args.out.exists() && !args.overwrite && !args.resume {
        return Err(Error::invalid(
            "--out",
            format!("{} exists: pass --resume to continue its run or --overwrite to replace it", args.out.display()),
        ));
    }
    let mut learner = open_learner(args, world_from(&args.world)?, args.config.clone(), &checkpoint)?;
    let interrupted = with_learner!(&mut learner, q => train(args, q, &checkpoint))?;
    if interrupted {
        println!("continue with: {} qlearn --resume --checkpoint {} ...", super::program(), checkpoint.display());
    } else if !args.no_eval {
        let pool = thread_pool(args.windows.threads)?;
        let report = pool.install(|| {
            learner.evaluate_windows(&learner.world(), None, &args.windows.config, args.windows.eval_seed)
        })?;
        let (updates, ties) = with_learner!(&learner, q => (q.updates(), q.config().ties));
        let name = format!("Q-policy (greedy, {} ties, {:.1e} updates)", ties.as_str(), updates as f64);
        print_windows(&[(name, report)], args.windows.reference);
    }
    Ok(())
}

/// The learning run of `qlearn` on a learner of any world with a known state; whether Ctrl-C
/// stopped it.
fn train<W: KnownState>(args: &QlearnArgs, learner: &mut QLearner<W>, checkpoint: &std::path::Path) -> Result<bool> {
    super::stop::install();
    if !args.quiet {
        eprintln!(
            "{} qlearn: {}, {} states × {} actions (f32, {:.2} GiB), gamma {}, alpha {}, epsilon = min(1, 1/ln t), {} ties, seed {}; from {} to {} updates; checkpoint {} every {}s",
            super::program(),
            learner.world().to_json(),
            learner.table().n_states(),
            learner.table().n_actions(),
            learner.table().bytes() as f64 / (1u64 << 30) as f64,
            learner.config().gamma,
            learner.config().alpha,
            learner.config().ties.as_str(),
            learner.config().seed,
            learner.updates(),
            args.iterations,
            checkpoint.display(),
            args.checkpoint_every
        );
    }
    let options =
        crate::run::RunOptions { progress: !args.quiet, checkpointing: None, stop: &super::stop::flow, callback: None };
    let outcome =
        crate::run::qlearn(learner, args.iterations, Some(checkpoint), Some(args.checkpoint_every), &options)?;
    if args.out != checkpoint {
        if !outcome.interrupted {
            learner.save(&args.out)?;
        }
        crate::cli::output::warn_checkpoint(outcome.checkpoint_error.as_deref(), &args.out);
    } else if outcome.checkpoint_error.is_some() {
        // The checkpoint is the result: one more try, its error the run's.
        learner.save(&args.out)?;
    }
    let rss = peak_rss().map_or("unknown".into(), |b| format!("{:.2} GiB", b as f64 / (1u64 << 30) as f64));
    println!(
        "{}: {} updates in {:.1}s ({:.2}M updates/s), {} in all; reward per 100 steps of the learning run {:.2}; {} checkpoint(s) to {}; peak RSS {}",
        if outcome.interrupted { "interrupted" } else { "done" },
        outcome.updates,
        outcome.seconds,
        outcome.updates as f64 / outcome.seconds.max(1e-9) / 1e6,
        learner.updates(),
        100.0 * learner.reward_total() / learner.updates().max(1) as f64,
        outcome.checkpoints,
        checkpoint.display(),
        rss
    );
    Ok(outcome.interrupted)
}

/// The paper's comparison table: worst, mean and best window, absolute and in % of `reference`.
fn print_windows(reports: &[(String, WindowReport)], reference: f64) {
    // Percentages of `reference`: the paper's best mean reward of a 100-step window (--reference).
    let of = format!("% of {reference}");
    println!("| policy | windows | worst | mean | best | worst, {of} | mean, {of} | best, {of} |");
    println!("|---|---|---|---|---|---|---|---|");
    for (name, report) in reports {
        for (kind, e) in [("from the initial state", &report.from_start), ("after many cycles", &report.continuing)] {
            println!(
                "| {name}, {kind} | {} | {} | {:.2} | {} | {:.0} | {:.1} | {:.0} |",
                e.episodes,
                e.min,
                e.mean,
                e.max,
                percent(e.min, reference),
                percent(e.mean, reference),
                percent(e.max, reference)
            );
        }
    }
    println!("(% of {reference}: of the reward of the paper's best policy per 100-step window; --reference sets it)");
}

pub(crate) fn run_qlearn_eval(args: &QlearnEvalArgs) -> Result<()> {
    if args.table.is_none() && args.ce_policies.is_empty() {
        return Err(Error::invalid(
            "qlearn-eval",
            "nothing to evaluate (expected a TABLE and/or --ce-policy FILE.json)",
        ));
    }
    let config = &args.windows.config;
    config.validate()?;
    let mut inputs: Vec<(&str, &std::path::Path)> = args.table.iter().map(|t| ("TABLE", t.as_path())).collect();
    inputs.extend(args.ce_policies.iter().map(|p| ("--ce-policy", p.as_path())));
    let outputs: Vec<(&str, &std::path::Path)> = args.json.iter().map(|j| ("--json", j.as_path())).collect();
    super::check_outputs(&inputs, &outputs, args.force)?;
    let pool = thread_pool(args.windows.threads)?;
    let seed = args.windows.eval_seed;
    let mut reports = Vec::new();
    if let Some(path) = &args.table {
        let started = Instant::now();
        let learner = AnyLearner::load(path)?;
        let (updates, learnt_ties) = with_learner!(&learner, q => (q.updates(), q.config().ties));
        eprintln!("{}: {} updates, loaded in {:.1}s", path.display(), updates, started.elapsed().as_secs_f64());
        let ties = args.ties.unwrap_or(learnt_ties);
        let report = pool.install(|| learner.evaluate_windows(&learner.world(), Some(ties), config, seed))?;
        reports.push((
            format!(
                "Q-policy (greedy, {} ties; learnt with {} ties, {:.1e} updates)",
                ties.as_str(),
                learnt_ties.as_str(),
                updates as f64
            ),
            report,
        ));
    }
    for path in &args.ce_policies {
        let file = PolicyFile::load(path)?;
        let world = AnyWorld::from_json(&file.world)?;
        let report = pool.install(|| evaluate_policy_windows(&world, &file.policy, config, seed))?;
        reports.push((format!("HHMM {:?} ({})", file.policy.levels(), path.display()), report));
    }
    print_windows(&reports, args.windows.reference);
    if let Some(out) = &args.json {
        let doc: Vec<Value> = reports
            .iter()
            .map(|(name, r)| serde_json::json!({ "policy": name, "reference": args.windows.reference, "report": r }))
            .collect();
        let text = serde_json::to_string_pretty(&doc).expect("reports serialise");
        crate::files::write_atomic(out, |f| std::io::Write::write_all(f, text.as_bytes()))?;
    }
    Ok(())
}
