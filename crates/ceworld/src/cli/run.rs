//! `ceworld run NAME`: any optimiser given by its step ([`crate::run::OPTIMISERS`]), its
//! settings as `--set KEY=VALUE`, with the progress line, checkpoints and outputs of every other
//! optimiser.

use crate::Result;
use crate::cli::{OutputArgs, WorldArgs, stop, world_from};
use crate::error::Error;
use crate::progress::{decimals, fixed};
use crate::run::optimiser;
use crate::settings::{Given, Named};

#[derive(clap::Args)]
pub(crate) struct RunArgs {
    /// The optimiser, by name: random-search.
    name: String,
    #[command(flatten)]
    world: WorldArgs,
    /// A setting KEY=VALUE (repeatable; `ceworld run NAME --list` shows them with their
    /// defaults): an int, a number, true/false, none, or else a string.
    #[arg(long = "set", value_name = "KEY=VALUE")]
    settings: Vec<String>,
    /// List the optimiser's settings with their defaults, and stop.
    #[arg(long)]
    list: bool,
    #[command(flatten)]
    output: OutputArgs,
}

/// `KEY=VALUE` as a setting given by name.
fn named(text: &str) -> Result<Named> {
    let (name, raw) =
        text.split_once('=').ok_or_else(|| Error::invalid("--set", format!("{text:?} (expected KEY=VALUE)")))?;
    let value = match raw {
        "true" => Given::Bool(true),
        "false" => Given::Bool(false),
        "none" | "null" => Given::Nothing,
        _ => raw
            .parse::<i128>()
            .map(Given::Int)
            .or_else(|_| raw.parse::<f64>().map(Given::Real))
            .unwrap_or_else(|_| Given::Text(raw.into())),
    };
    Ok(Named { name: name.into(), value, shown: raw.into() })
}

pub(crate) fn run_named(args: &RunArgs) -> Result<()> {
    let optimiser = optimiser(&args.name)?;
    if args.list {
        for (key, value) in (optimiser.defaults)() {
            println!("{key} = {value}");
        }
        return Ok(());
    }
    let settings = args.settings.iter().map(|s| named(s)).collect::<Result<Vec<_>>>()?;
    let world = world_from(&args.world)?;
    args.output.check_peeked(&args.world.files(), optimiser.peek)?;
    let checkpointing = args.output.checkpointing()?;
    stop::install();
    let options = args.output.run_options(checkpointing.as_ref());
    let (outcome, file) = crate::with_world!(&world, w => (optimiser.run)(w, &settings, &options))?;
    args.output.save(&file, &outcome.history, outcome.checkpoint_error.as_deref())?;
    let e = &outcome.evaluation;
    let d = decimals(e.std_error);
    println!(
        "{}: {} iterations ({} steps of the world) in {:.1}s; evaluation on {} fresh episodes: {} ± {}; saved {}",
        outcome.stop.as_str(),
        outcome.history.len(),
        outcome.env_steps,
        outcome.seconds,
        e.episodes,
        fixed(e.mean, d),
        fixed(e.std_error, d),
        args.output.out.display()
    );
    Ok(())
}
