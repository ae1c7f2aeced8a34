//! What the command line says about itself: its one list of commands (the Python package's
//! among them when it runs as `cehmm`), and the errors clap would word for another case.

use clap::CommandFactory;
use clap::error::{ContextKind, ContextValue, ErrorKind};

use crate::Error;

/// The commands the Python package's `cehmm` runs itself (python/cehmm/cli.py, which reads them
/// from here as `cehmm._core.PACKAGE_COMMANDS`), listed with the engine's in `cehmm --help`.
pub const PACKAGE_COMMANDS: [(&str, &str); 3] = [
    ("plot", "Draw history files as learning curves, or a policy file as its graph, decision law or memory use"),
    ("reproduce", "Reproduce the paper's results table (model §5) and write the report"),
    ("benchmarks", "Learn controllers for every .pomdp file of data/pomdp and write docs/benchmarks.md"),
];

/// The command line of `program` (`ceworld`, or `cehmm` with the package's commands too).
pub(crate) fn command(program: &'static str) -> clap::Command {
    let mut command = super::Cli::command()
        .name(program)
        .bin_name(program)
        .arg_required_else_help(true)
        .after_help(format!("'{program} COMMAND --help' shows a command's options."));
    if program == "cehmm" {
        for (name, about) in PACKAGE_COMMANDS {
            // Listed only: the package runs them before the engine sees its arguments.
            command = command.subcommand(clap::Command::new(name).about(about).disable_help_flag(true));
        }
    }
    command
}

/// Memory sizes given apart (`--levels 16 16`), which clap calls an unexpected argument: the
/// error says they are comma-separated.
pub(crate) fn spaced_levels(error: &clap::Error, args: &[String]) -> Option<Error> {
    if error.kind() != ErrorKind::UnknownArgument {
        return None;
    }
    let Some(ContextValue::String(unexpected)) = error.get(ContextKind::InvalidArg) else {
        return None;
    };
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    let is_sizes = |a: &str| !a.is_empty() && a.split(',').all(|n| n.trim().parse::<usize>().is_ok());
    for (k, arg) in args.iter().enumerate() {
        // The sizes clap took (`--levels 16` or `--levels=16`), then those it did not.
        let (first, rest) = match arg.strip_prefix("--levels") {
            Some("") => (args.get(k + 1).copied().unwrap_or(""), k + 2),
            Some(value) if value.starts_with('=') => (&value[1..], k + 1),
            _ => continue,
        };
        let more: Vec<&str> = args[rest.min(args.len())..].iter().copied().take_while(|a| is_sizes(a)).collect();
        if is_sizes(first) && more.first() == Some(&unexpected.as_str()) {
            let given: Vec<&str> = std::iter::once(first).chain(more).collect();
            return Some(Error::invalid(
                "--levels",
                format!(
                    "{} (expected sizes separated by commas, not spaces: --levels {})",
                    given.join(" "),
                    given.join(",")
                ),
            ));
        }
    }
    None
}
