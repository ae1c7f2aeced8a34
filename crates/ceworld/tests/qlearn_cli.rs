//! `ceworld qlearn` and `ceworld qlearn-eval` on a 5 × 5 grid (a 10 MB table): runs, files,
//! resume, Ctrl-C, and the refusal of a table that does not fit in memory.

#[path = "common/temp.rs"]
mod temp;

mod common;
#[cfg(unix)]
use common::interrupt_when_ready;
use std::path::Path;
use std::process::{Command, Output};

/// The 5 × 5 world: 16 × 100 × 100 states.
const SMALL: [&str; 10] = [
    "--param",
    "width=5",
    "--param",
    "height=5",
    "--param",
    "start_b=[0,4]",
    "--param",
    "start_c=[4,4]",
    "--param",
    "target_rows=[0,2]",
];

/// Small evaluation settings.
const WINDOWS: [&str; 8] = ["--episodes", "200", "--chains", "2", "--burn-in", "1000", "--windows-per-chain", "50"];

fn ceworld(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_ceworld")).args(args).output().expect("the binary runs")
}

fn temp(name: &str) -> temp::TempPath {
    temp::TempPath::new("ceworld-qlearn-cli", name)
}

fn qlearn(out: &str, iterations: &str, extra: &[&str]) -> Output {
    let mut args = vec!["qlearn", "--param", "target_cell=[2,2]", "--iterations", iterations, "--out", out, "--quiet"];
    args.extend(SMALL);
    args.extend(WINDOWS);
    args.extend(extra);
    ceworld(&args)
}

fn header(path: &Path) -> serde_json::Value {
    ceworld::qlearn::read_header(path).unwrap()
}

#[test]
fn qlearn_saves_a_table_and_prints_the_window_table() {
    let path = temp("q.bin");
    let out = qlearn(path.to_str().unwrap(), "2e4", &[]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(stdout.starts_with("done: 20000 updates"), "{stdout}");
    assert!(stdout.contains("peak RSS"), "{stdout}");
    assert!(
        stdout.contains("| Q-policy (greedy, random ties, 2.0e4 updates), from the initial state | 200 |"),
        "{stdout}"
    );
    assert!(stdout.contains("after many cycles | 100 |"), "{stdout}");
    let h = header(&path);
    assert_eq!(
        (h["updates"].as_u64(), h["n_states"].as_u64(), h["ties"].as_str()),
        (Some(20_000), Some(160_000), Some("random"))
    );
    assert_eq!(std::fs::read(&path).unwrap()[..8], *b"CEQTABLE");

    // The same table evaluated again, with a CE policy of the same world beside it.
    let policy = temp("ce.json");
    let mut args = vec!["optimize", "--case", "3", "--param", "target_cell=[2,2]", "--levels", "16", "--samples", "50"];
    args.extend(SMALL);
    args.extend(["--max-iterations", "2", "--eval-episodes", "10", "--quiet", "--out", policy.to_str().unwrap()]);
    assert!(ceworld(&args).status.success());
    let json = temp("report.json");
    let mut args = vec!["qlearn-eval", path.to_str().unwrap(), "--ce-policy", policy.to_str().unwrap()];
    args.extend(WINDOWS);
    args.extend(["--json", json.to_str().unwrap()]);
    let out = ceworld(&args);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(stdout.contains("Q-policy (greedy, random ties; learnt with random ties"), "{stdout}");
    assert!(stdout.contains("| HHMM [16] ("), "{stdout}");
    // The header, four rows and what the percentages are of.
    assert_eq!(stdout.lines().count(), 2 + 4 + 1, "{stdout}");
    assert!(
        stdout.contains("mean, % of 69") && stdout.contains("(% of 69: of the reward of the paper's best"),
        "{stdout}"
    );
    let doc: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    assert_eq!(doc[0]["report"]["from_start"]["episodes"], 200);
    assert_eq!(doc[1]["report"]["continuing"]["episodes"], 100);
}

#[test]
fn resume_continues_and_an_existing_checkpoint_is_not_overwritten() {
    let path = temp("resume.bin");
    let p = path.to_str().unwrap();
    assert!(qlearn(p, "10000", &["--no-eval"]).status.success());
    let out = qlearn(p, "20000", &["--no-eval"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("exists: pass --resume"));
    let out = qlearn(p, "20000", &["--no-eval", "--resume"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(String::from_utf8_lossy(&out.stdout).starts_with("done: 10000 updates"));
    assert_eq!(header(&path)["updates"], 20_000);
    // Exactly the run of 20000 updates made in one go.
    let straight = temp("straight.bin");
    assert!(qlearn(straight.to_str().unwrap(), "20000", &["--no-eval"]).status.success());
    let (a, b) = (header(&path), header(&straight));
    assert_eq!((&a["rng"], &a["world_state"]), (&b["rng"], &b["world_state"]));
    let load = |p: &std::path::Path| match ceworld::qlearn::AnyLearner::load(p).unwrap() {
        ceworld::qlearn::AnyLearner::TargetTracking(q) => q,
    };
    assert!(load(&path).table() == load(&straight).table());
    let out = qlearn(p, "30000", &["--no-eval", "--resume", "--seed", "1"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("keeps its settings"));
}

#[cfg(unix)]
#[test]
fn ctrl_c_saves_a_checkpoint_to_resume_from() {
    let path = temp("interrupted.bin");
    let mut args = vec!["qlearn", "--param", "target_cell=[2,2]", "--iterations", "1e12"];
    args.extend(SMALL);
    args.extend(["--out", path.to_str().unwrap()]);
    let (status, stdout, stderr) = interrupt_when_ready(&args);
    assert_eq!(status.code(), Some(130), "Ctrl-C exits with 130 after saving: {stderr}");
    assert!(stdout.starts_with("interrupted:") && stdout.contains("--resume"), "{stdout}");
    let updates = header(&path)["updates"].as_u64().unwrap();
    assert!(updates > 0 && updates % ceworld::qlearn::CHUNK == 0, "{updates}");
}

#[test]
fn a_table_too_big_for_memory_is_refused() {
    let out = ceworld(&["qlearn", "--param", "width=1000", "--param", "height=1000", "--out", "/nonexistent/q.bin"]);
    assert_eq!(out.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("needs 16384000000000064 bytes") && stderr.contains("available"), "{stderr}");
    assert!(!stderr.contains("panicked"));
}

#[test]
fn bad_arguments_are_clear_errors() {
    let out = ceworld(&["qlearn", "--iterations", "1.5"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("expected a whole number"));
    let out = ceworld(&["qlearn-eval"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("nothing to evaluate"));
    let missing = temp("missing.bin");
    let out = ceworld(&["qlearn-eval", missing.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(2));
    let out = ceworld(&["qlearn", "--resume", "--checkpoint", missing.to_str().unwrap()]);
    assert!(String::from_utf8_lossy(&out.stderr).contains("does not exist"));
}

#[test]
fn the_example_in_the_help_runs_as_written() {
    let help = ceworld(&["qlearn", "--help"]);
    let text = String::from_utf8_lossy(&help.stdout).replace('\n', " ");
    let example = text.split("Example (a small table, a few seconds): ").nth(1).expect("an example in the help");
    let command: Vec<&str> = example.split_whitespace().take_while(|w| !w.starts_with("Usage")).collect();
    assert_eq!(command[..2], ["ceworld", "qlearn"]);
    let out = temp("help-example.bin");
    let mut args: Vec<&str> =
        command[1..].iter().map(|a| if *a == "qtable.bin" { out.to_str().unwrap() } else { a }).collect();
    args.push("--quiet");
    let run = ceworld(&args);
    assert!(run.status.success(), "{args:?}: {}", String::from_utf8_lossy(&run.stderr));
    assert!(out.exists());
}
