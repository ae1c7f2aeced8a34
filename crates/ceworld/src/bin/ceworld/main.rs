//! `ceworld`: optimise, evaluate and inspect HHMM policies from the command line
//! ([`ceworld::cli`], which Python's `cehmm` console script runs too).

fn main() -> std::process::ExitCode {
    std::process::ExitCode::from(ceworld::cli::main("ceworld", std::env::args_os().collect()))
}
