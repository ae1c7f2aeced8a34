//! The command line: optimise, evaluate and inspect HHMM policies. One implementation, reached
//! from the `ceworld` binary and from the Python package's `cehmm` console script alike
//! ([`main`]).

mod controller;
mod help;
pub use help::PACKAGE_COMMANDS;
mod output;
mod qlearn;
mod run;
mod stop;

use std::ffi::OsString;
use std::path::PathBuf;
use std::time::Instant;

use crate::progress::{decimals, fixed};
use clap::{FromArgMatches, Parser, Subcommand};
use output::OutputArgs;
use qlearn::{QlearnArgs, QlearnEvalArgs, run_qlearn, run_qlearn_eval};
use serde_json::Value;

use crate::thread_pool;
use crate::{AnyWorld, CeConfig, Error, Init, PolicyFile, Result, World, evaluate};

/// Cross-entropic learning of hierarchical-HMM policies (Dambreville's method) for the
/// target-tracking world of model §4.
#[derive(Parser)]
#[command(name = "ceworld", version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Optimise a policy by the cross-entropy method and save it as JSON (model §6).
    ///
    /// Prints a live progress line; Ctrl-C or SIGTERM stops between iterations and still saves
    /// the best policy so far (marked "interrupted" in its provenance) and, with --checkpoint,
    /// the run's state, from which --resume continues.
    Optimize(OptimizeArgs),
    /// Search a deterministic finite-state controller of any world by the cross-entropy method
    /// (model §8).
    ///
    /// The method draws whole controllers, on any world the engine has: a Cassandra .pomdp file
    /// (--pomdp FILE) or target tracking (--case, --param). Each is valued exactly on a .pomdp
    /// file's tabular world (--value exact, the default there) or on any world by the mean of
    /// episodes on common random numbers (--value sampled, the default on every other world).
    /// The model search of every step taken (model §10), Python's `optimize_controller` default
    /// on sampled values of a world that gives its steps' rewards, is `run model-search`.
    ///
    /// Prints a live progress line; Ctrl-C stops between iterations and still saves the best
    /// controller so far as a policy file (two levels [n, n], one-hot tables).
    Controller(controller::ControllerArgs),
    /// Evaluate a saved policy on fresh episodes of the world stored in its file, or exactly.
    Evaluate {
        /// The policy file (JSON, model §6).
        file: PathBuf,
        /// Number of fresh episodes [default: 100000] (not with --exact).
        #[arg(long)]
        episodes: Option<usize>,
        /// Seed of the evaluation episodes [default: 0] (not with --exact).
        #[arg(long)]
        seed: Option<u64>,
        /// Worker threads (default: one per core).
        #[arg(long)]
        threads: Option<usize>,
        /// Instead, compute the expected reward exactly (tabular worlds, model §7): at the
        /// world's horizon, and for a discount below 1 also the infinite-horizon value.
        #[arg(long)]
        exact: bool,
        /// Tolerance of the exact infinite-horizon value.
        #[arg(long, default_value_t = crate::exact::DEFAULT_TOLERANCE, requires = "exact")]
        tolerance: f64,
    },
    /// Show a policy of a tabular world as a finite-state controller (a policy graph).
    ///
    /// The graph is printed in the .pomdp file's names, and optionally saved as JSON, as
    /// Graphviz DOT or as a pomdp-solve policy graph.
    Show {
        /// The policy file (JSON, model §6).
        file: PathBuf,
        /// Also write the graph as JSON (the file's names) to this file.
        #[arg(long, value_name = "FILE.json")]
        json: Option<PathBuf>,
        /// Also write it as a pomdp-solve policy graph (`N A Z1 Z2 ...`, node 0 initial). A
        /// stochastic policy writes its most likely controller (each law at its likeliest
        /// outcome), and both exact values are printed.
        #[arg(long, value_name = "FILE.pg")]
        pg: Option<PathBuf>,
        /// Also write it in Graphviz's DOT language (the file's names; `dot -Tpng FILE.dot`),
        /// pruned as the graph shown.
        #[arg(long, value_name = "FILE.dot")]
        dot: Option<PathBuf>,
        /// Leave out of the graph shown the laws of this probability or less (and the memories
        /// only they reach).
        #[arg(long, default_value_t = crate::policy::graph::PRUNE)]
        prune: f64,
        /// Replace --json, --pg and --dot when they exist.
        #[arg(long)]
        force: bool,
    },
    /// Print the exact optimum of a world (known for case 1, fixed target).
    Optimum {
        #[command(flatten)]
        world: WorldArgs,
    },
    /// Learn a Q table by Q-learning, the paper's baseline (model §5).
    ///
    /// The state is the last observation and both mobiles' cells and headings, the task
    /// continuing (never reset).
    ///
    /// The table (f32; 2.6 GB for the 20×20 grid) is refused when it would not fit in memory.
    /// The run is checkpointed (table, update count, random stream, world state) every
    /// --checkpoint-every seconds, on Ctrl-C and at the end; --resume continues it exactly as
    /// if it had never stopped. Then the greedy policy is evaluated on 100-step windows.
    #[command(after_long_help = QLEARN_EXAMPLE)]
    Qlearn(QlearnArgs),
    /// Evaluate a Q table's greedy policy and/or HHMM policies on 100-step windows.
    ///
    /// As the paper compares them: (a) windows from the initial state, (b) consecutive windows of long continuing runs after
    /// a burn-in; worst, mean, best, also as % of 69.
    QlearnEval(QlearnEvalArgs),
    /// Run an optimiser by its name (random-search), its settings as --set KEY=VALUE.
    ///
    /// Any optimiser given by its iteration step (random-search: random deterministic
    /// controllers, the best kept); progress, checkpoints, --out and --history as for every
    /// optimiser.
    Run(run::RunArgs),
}

/// The example at the end of `ceworld qlearn --help` (a test runs it as written).
const QLEARN_EXAMPLE: &str = "Example (a small table, a few seconds): ceworld qlearn --param width=5 \
    --param height=5 --param start_b=[0,4] --param start_c=[4,4] --param target_cell=[2,2] \
    --param target_rows=[0,2] --iterations 1e5 --window 20 --episodes 100 --chains 2 --burn-in 100 \
    --windows-per-chain 50 --out qtable.bin";

/// Which world: a name of the registry and its parameters.
#[derive(clap::Args)]
pub(crate) struct WorldArgs {
    /// The world, by its name in the registry: `target-tracking` (the default: the paper's; its
    /// parameters are --case and --param) or `pomdp` (a Cassandra .pomdp file: see --pomdp).
    #[arg(long)]
    world: Option<String>,
    /// Target tracking's case: 1 fixed target, 2 moving target unobserved, 3 moving target
    /// observed (default: the world's, 3; the exact optimum is known for case 1).
    #[arg(long)]
    case: Option<u8>,
    /// A tabular POMDP read from this file, Cassandra's .pomdp or APPL's .pomdpx (the world
    /// `pomdp`, model §7); its policy files record the file's SHA-256.
    #[arg(long, value_name = "FILE.pomdp", conflicts_with_all = ["world", "case"])]
    pomdp: Option<PathBuf>,
    /// Steps per episode (the parameter `horizon`).
    #[arg(long)]
    horizon: Option<usize>,
    /// The discount of a .pomdp world, instead of the file's (the parameter `discount`).
    #[arg(long, requires = "pomdp")]
    discount: Option<f64>,
    /// A world parameter KEY=VALUE (repeatable; VALUE is JSON, or else a string): for target
    /// tracking width, height, horizon, `start_b`, `start_c`, `start_heading`, `reward_radius`,
    /// `observe_radius`, `target_cell`, `target_rows` (lists as [a,b]); for pomdp file,
    /// horizon, discount.
    #[arg(long = "param", value_name = "KEY=VALUE")]
    params: Vec<String>,
}

#[derive(clap::Args)]
struct OptimizeArgs {
    #[command(flatten)]
    world: WorldArgs,
    /// Memory sizes per level, bottom first: 16 is a memoryless policy, 16,16 an IO-HMM (give
    /// it once; a policy given by --init brings its own).
    #[arg(long, default_value_t = Levels(crate::DEFAULT_LEVELS.to_vec()))]
    levels: Levels,
    #[command(flatten)]
    config: CeConfig,
    /// Start from a clock: the memory counts the steps and h0 becomes a time-indexed plan
    /// (needs two equal levels, e.g. --levels 100,100).
    #[arg(long, conflicts_with_all = ["random_init", "init"])]
    clock_init: bool,
    /// Start from random tables (drawn from the seed) instead of uniform ones.
    #[arg(long)]
    random_init: bool,
    /// Start from a saved policy instead.
    #[arg(long, value_name = "FILE.json", conflicts_with_all = ["random_init", "levels"])]
    init: Option<PathBuf>,
    #[command(flatten)]
    output: OutputArgs,
}

/// Checkpoints of a long optimisation (every optimiser's).
#[derive(clap::Args)]
pub(crate) struct CheckpointArgs {
    /// Save the whole state of the run to this file every --checkpoint-every seconds and
    /// whenever it stops (the end, Ctrl-C, SIGTERM); see --resume.
    #[arg(long, value_name = "FILE")]
    checkpoint: Option<PathBuf>,
    /// Seconds between two checkpoints.
    #[arg(long, default_value_t = crate::ce::resume::DEFAULT_EVERY, requires = "checkpoint")]
    checkpoint_every: f64,
    /// Continue from --checkpoint when that file exists (else start afresh), with the same
    /// world and settings: the final policy is the one an uninterrupted run gives, bit for bit.
    #[arg(long, requires = "checkpoint")]
    resume: bool,
}

impl CheckpointArgs {
    /// Whether the run continues one saved in --checkpoint.
    pub(crate) fn resuming(&self) -> bool {
        self.resume && self.checkpoint.as_ref().is_some_and(|p| p.exists())
    }

    /// The checkpoints asked for, checked, recording the run's `outputs`; says when a run
    /// resumes (unless `quiet`).
    fn checkpointing(&self, quiet: bool, outputs: Vec<PathBuf>) -> Result<Option<crate::Checkpointing>> {
        let checkpointing = self.checkpoint.as_ref().map(|path| crate::Checkpointing {
            path: path.clone(),
            every: self.checkpoint_every,
            resume: self.resume,
            outputs,
        });
        if let Some(c) = &checkpointing {
            c.validate()?;
            if !quiet && c.resume && c.path.exists() {
                eprintln!("{}: resuming from {}", program(), c.path.display());
            }
        }
        Ok(checkpointing)
    }
}

impl WorldArgs {
    /// The files the world is read from (a .pomdp file), by the option that names them.
    pub(crate) fn files(&self) -> Vec<(&'static str, &std::path::Path)> {
        let mut files: Vec<(&str, &std::path::Path)> = self.pomdp.iter().map(|p| ("--pomdp", p.as_path())).collect();
        files.extend(
            self.params
                .iter()
                .filter_map(|p| p.strip_prefix("file="))
                .map(|f| ("--param file", std::path::Path::new(f))),
        );
        files
    }
}

/// The world `name` of the registry with `--case` (target tracking's case) and every
/// `--param KEY=VALUE` over its defaults; giving the case twice is refused.
pub(crate) fn world_from(args: &WorldArgs) -> Result<AnyWorld> {
    let name = match (&args.pomdp, &args.world) {
        (Some(_), _) => crate::PomdpWorld::NAME,
        (None, Some(name)) => name.as_str(),
        (None, None) => crate::world::registry::DEFAULT_WORLD,
    };
    let mut map = serde_json::Map::new();
    for p in &args.params {
        let (key, raw) = p
            .split_once('=')
            .ok_or_else(|| Error::invalid("--param", format!("{p:?} (expected KEY=VALUE, e.g. horizon=50)")))?;
        // JSON, or else the text itself (a file name).
        let v: Value = serde_json::from_str(raw).unwrap_or_else(|_| Value::String(raw.to_string()));
        if map.insert(key.to_string(), v).is_some() {
            return Err(Error::invalid("--param", format!("{key} given twice")));
        }
    }
    // A world's parameters are JSON text: a path that is not UTF-8 cannot be one (it would
    // become another name, and "no such file").
    if let Some(p) = &args.pomdp
        && p.to_str().is_none()
    {
        return Err(Error::invalid("--pomdp", crate::files::not_utf8(&p.display().to_string())));
    }
    // JSON has no NaN or infinity: such a value would become null, and silently no discount.
    if let Some(d) = args.discount
        && !d.is_finite()
    {
        return Err(Error::invalid("--discount", format!("{d} (expected 0 <= discount <= 1)")));
    }
    let options: [(&str, &str, Option<Value>); 4] = [
        ("--case", "case", args.case.map(Value::from)),
        ("--pomdp", "file", args.pomdp.as_ref().map(|p| Value::from(p.display().to_string()))),
        ("--horizon", "horizon", args.horizon.map(Value::from)),
        ("--discount", "discount", args.discount.map(Value::from)),
    ];
    for (option, key, value) in options {
        if let Some(value) = value
            && map.insert(key.into(), value).is_some()
        {
            return Err(Error::invalid(
                option,
                format!("given both as {option} and as --param {key}=... (give it once)"),
            ));
        }
    }
    AnyWorld::with_params(name, &map)
}

fn run_optimize(args: &OptimizeArgs) -> Result<()> {
    let world = world_from(&args.world)?;
    crate::with_world!(&world, w => optimize_in(w, args))
}

/// `optimize` in one world of the registry.
fn optimize_in<W: World>(world: &W, args: &OptimizeArgs) -> Result<()> {
    let config = args.config.clone();
    config.validate()?;
    // The result is not lost to an unwritable --out found after the run.
    let mut inputs = args.world.files();
    inputs.extend(args.init.as_deref().map(|p| ("--init", p)));
    args.output.check::<crate::ce::checkpoint::CeRun>(&inputs)?;
    let initial = if let Some(path) = &args.init {
        PolicyFile::load(path)?.policy
    } else {
        let init = match (args.random_init, args.clock_init) {
            (true, _) => Init::Random,
            (_, true) => Init::Clock,
            _ => Init::Uniform,
        };
        init.policy(world, &args.levels.0, config.seed)?
    };
    stop::install();
    if !args.output.quiet {
        eprintln!(
            "{}: world {} levels {:?} ({} parameters), N = {}, rho = {}, alpha = {}, patience {}, seed {}",
            program(),
            world.to_json(),
            initial.levels(),
            initial.layout().parameter_count(),
            config.samples,
            config.rho,
            config.smoothing,
            config.patience,
            config.seed
        );
    }
    let checkpointing = args.output.checkpointing()?;
    let options = args.output.run_options(checkpointing.as_ref());
    let result = crate::run::optimize(world, initial, &config, &options)?;
    args.output.save(&result.to_file(world, &config), &result.history, result.checkpoint_error.as_deref())?;
    let e = &result.evaluation;
    if config.restarts > 1 {
        println!("best of {} restarts: restart {}", config.restarts, result.restart);
    }
    let d = decimals(e.std_error);
    println!(
        "{}: {} iterations ({} steps of the world) in {:.1}s, best iteration {} (mean {}); evaluation on {} fresh episodes: {} ± {} (min {}, max {}); saved {}",
        result.stop.as_str(),
        result.history.len(),
        result.env_steps,
        result.seconds,
        result.best_iteration,
        fixed(result.history[result.best_iteration].mean, d),
        e.episodes,
        fixed(e.mean, d),
        fixed(e.std_error, d),
        fixed(e.min, d),
        fixed(e.max, d),
        args.output.out.display()
    );
    Ok(())
}

/// A policy's exact value on a tabular world: infinite-horizon for a discount below 1, else at
/// the world's horizon (model §7).
fn exact_value(world: &crate::PomdpWorld, policy: &crate::Hhmm) -> Result<f64> {
    if world.tables().gamma < 1.0 {
        Ok(crate::exact::infinite_horizon(world, policy, 1e-6)?.value)
    } else {
        Ok(crate::exact::finite_horizon(world, policy, None)?.value)
    }
}

/// `show`: a tabular world's policy as a policy graph, printed and written where asked.
fn run_show(
    file: &std::path::Path,
    json: Option<&std::path::Path>,
    pg: Option<&std::path::Path>,
    dot: Option<&std::path::Path>,
    prune: f64,
    force: bool,
) -> Result<()> {
    crate::policy::graph::check_prune("--prune", prune)?;
    let f = PolicyFile::load(file)?;
    let world = AnyWorld::from_json(&f.world)?;
    let world = world
        .tabular()
        .ok_or_else(|| Error::invalid("show", "the policy's world is not tabular (expected a pomdp world)"))?;
    let model_file = PathBuf::from(&world.params().file);
    let outputs: Vec<(&str, &std::path::Path)> =
        [("--json", json), ("--pg", pg), ("--dot", dot)].into_iter().filter_map(|(o, p)| Some((o, p?))).collect();
    check_outputs(&[("FILE", file), ("the policy's model file", &model_file)], &outputs, force)?;
    let graph = world.graph(&f.policy, prune)?;
    let model = &world.tables().pomdp;
    print!("{}", graph.describe(&model.actions, &model.observations));
    let write = |path: &std::path::Path, text: String| {
        crate::files::write_atomic(path, |out| std::io::Write::write_all(out, text.as_bytes()))
    };
    if let Some(path) = pg {
        if world.graph(&f.policy, 0.0)?.is_deterministic() {
            write(path, world.graph(&f.policy, 0.0)?.to_pg()?)?;
        } else {
            let likely = f.policy.most_likely();
            let controller = world.graph(&likely, 0.0)?;
            write(path, controller.to_pg()?)?;
            println!(
                "stochastic policy: {} holds its most likely controller ({} nodes, each law at its likeliest outcome): exact value {:.4} (the stochastic policy's: {:.4})",
                path.display(),
                controller.nodes.len(),
                exact_value(world, &likely)?,
                exact_value(world, &f.policy)?
            );
        }
    }
    if let Some(path) = json {
        let doc = graph.to_json(&model.actions, &model.observations);
        write(path, serde_json::to_string_pretty(&doc).expect("a graph serialises"))?;
    }
    if let Some(path) = dot {
        write(path, graph.to_dot(&model.actions, &model.observations))?;
    }
    Ok(())
}

fn run(command: Command) -> Result<()> {
    match command {
        Command::Optimize(args) => run_optimize(&args),
        Command::Controller(args) => controller::run_controller(&args),
        Command::Evaluate { file, exact: true, tolerance, episodes, seed, .. } => {
            // Sampling options do not apply: refused rather than silently ignored.
            let sampling = [("--episodes", episodes.map(|e| e.to_string())), ("--seed", seed.map(|s| s.to_string()))];
            if let Some((option, value)) = sampling.into_iter().find_map(|(o, v)| Some((o, v?))) {
                return Err(Error::invalid(
                    option,
                    format!("{value} (expected no {option} with --exact: the exact value samples no episodes)"),
                ));
            }
            let f = PolicyFile::load(&file)?;
            let world = AnyWorld::from_json(&f.world)?;
            let world = world.tabular().ok_or_else(|| {
                Error::invalid("--exact", "the policy's world is not tabular (expected a pomdp world)")
            })?;
            let h = crate::exact::finite_horizon(world, &f.policy, None)?;
            println!("{}: exact expected reward at horizon {}: {:.6}", file.display(), h.steps, h.value);
            if world.tables().gamma < 1.0 {
                let v = crate::exact::infinite_horizon(world, &f.policy, tolerance)?;
                println!(
                    "{}: exact infinite-horizon value (discount {}): {:.6} (± {:.1e}, {} steps)",
                    file.display(),
                    world.tables().gamma,
                    v.value,
                    v.tail_bound,
                    v.steps
                );
            }
            Ok(())
        }
        Command::Evaluate { file, episodes, seed, threads, .. } => {
            let f = PolicyFile::load(&file)?;
            let world = AnyWorld::from_json(&f.world)?;
            let pool = thread_pool(threads)?;
            let (episodes, seed) = (episodes.unwrap_or(100_000), seed.unwrap_or(0));
            let started = Instant::now();
            let e = crate::with_world!(&world, w => pool.install(|| evaluate(w, &f.policy, episodes, seed)))?;
            let d = decimals(e.std_error);
            let q: Vec<String> =
                e.quantiles.iter().map(|(q, v)| format!("q{:.0}={}", q * 100.0, fixed(*v, d))).collect();
            println!(
                "{}: {} episodes: mean {} ± {} (std {}), min {}, max {}, {} ({:.2}s)",
                file.display(),
                e.episodes,
                fixed(e.mean, d),
                fixed(e.std_error, d),
                fixed(e.std, d),
                fixed(e.min, d),
                fixed(e.max, d),
                q.join(" "),
                started.elapsed().as_secs_f64()
            );
            Ok(())
        }
        Command::Show { file, json, pg, dot, prune, force } => {
            run_show(&file, json.as_deref(), pg.as_deref(), dot.as_deref(), prune, force)
        }
        Command::Optimum { world } => {
            let world = world_from(&world)?;
            println!("{}", crate::with_world!(&world, w => w.exact_optimum())?);
            Ok(())
        }
        Command::Qlearn(args) => run_qlearn(&args),
        Command::QlearnEval(args) => run_qlearn_eval(&args),
        Command::Run(args) => run::run_named(&args),
    }
}

/// Refuses, before any work, `outputs` (option, path) that are the same file as an input or as
/// each other, that exist (unless `force`), or that cannot be written.
pub(crate) fn check_outputs(
    inputs: &[(&str, &std::path::Path)],
    outputs: &[(&str, &std::path::Path)],
    force: bool,
) -> Result<()> {
    crate::files::check_distinct(inputs, outputs)?;
    for (option, path) in outputs {
        if !force {
            crate::files::check_new(option, path, "give --force")?;
        }
        crate::files::check_writable(option, path)?;
    }
    Ok(())
}

/// Memory sizes per level as the command line writes them and shows its default: `16,16`.
#[derive(Clone, Debug)]
struct Levels(Vec<usize>);

impl std::fmt::Display for Levels {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let sizes: Vec<String> = self.0.iter().map(ToString::to_string).collect();
        write!(f, "{}", sizes.join(","))
    }
}

impl std::str::FromStr for Levels {
    type Err = String;

    fn from_str(text: &str) -> std::result::Result<Self, String> {
        let sizes = text.split(',').map(|n| n.trim().parse::<usize>()).collect::<std::result::Result<Vec<_>, _>>();
        sizes.map(Levels).map_err(|_| format!("{text:?} (expected sizes separated by commas, e.g. --levels 16,16)"))
    }
}

/// The name the command line goes by in its messages.
static PROGRAM: std::sync::Mutex<&str> = std::sync::Mutex::new("ceworld");

fn set_program(name: &'static str) {
    *PROGRAM.lock().unwrap_or_else(std::sync::PoisonError::into_inner) = name;
}

/// The command line's name (`ceworld`, or `cehmm` from Python), for its messages.
pub(crate) fn program() -> &'static str {
    *PROGRAM.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
}

/// Runs the command line `args` (the program's name first, as `std::env::args_os` gives them)
/// as the program `program` (`"ceworld"`, `"cehmm"`); returns the exit status: 0, 2 for an
/// error (one line naming it), 70 for a bug, 128 + the signal's number after a stop signal.
pub fn main(program: &'static str, args: Vec<OsString>) -> u8 {
    // As text, for an error clap words for another case.
    let given: Vec<String> = args.iter().map(|a| a.to_string_lossy().into_owned()).collect();
    let parsed = help::command(program).try_get_matches_from(args).and_then(|m| Cli::from_arg_matches(&m));
    let cli = match parsed {
        Ok(cli) => cli,
        Err(e) => {
            if let Some(e) = help::spaced_levels(&e, &given) {
                eprintln!("{program}: error: {e}");
                return 2;
            }
            // --help and --version are printed on stdout and are a success.
            let _ = e.print();
            return u8::try_from(e.exit_code()).unwrap_or(2);
        }
    };
    set_program(program);
    let outcome = crate::catch_panics(|| run(cli.command));
    let status = stop::exit_code();
    stop::restore();
    match outcome {
        Err(e @ Error::Internal(_)) => {
            eprintln!("{program}: {e}");
            70
        }
        // A run stopped by a signal saved what it had: exit with 128 + the signal.
        Ok(()) => status.unwrap_or(0),
        Err(e) => {
            eprintln!("{program}: error: {e}");
            2
        }
    }
}
