//! The `ceworld` binary: happy paths, clear errors (exit code 2, never a panic), Ctrl-C.

#[path = "common/temp.rs"]
mod temp;

mod common;
#[cfg(unix)]
use common::interrupt_when_ready;
use std::process::{Command, Output};

fn ceworld(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_ceworld")).args(args).output().expect("the binary runs")
}

fn temp(name: &str) -> temp::TempPath {
    temp::TempPath::new("ceworld-cli", name)
}

fn fails_with(args: &[&str], needles: &[&str]) {
    let out = ceworld(args);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{args:?}: {stderr}");
    assert!(!stderr.contains("panicked"), "{args:?} panicked: {stderr}");
    for needle in needles {
        assert!(stderr.contains(needle), "{args:?}: {needle:?} not in {stderr}");
    }
}

#[test]
fn optimize_then_evaluate() {
    let path = temp("small.json");
    let p = path.to_str().unwrap();
    let out = ceworld(&[
        "optimize",
        "--case",
        "1",
        "--levels",
        "4,2",
        "--samples",
        "100",
        "--max-iterations",
        "3",
        "--eval-episodes",
        "50",
        "--out",
        p,
        "--quiet",
    ]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(stdout.contains("max_iterations: 3 iterations"), "{stdout}");
    let doc: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
    assert_eq!(doc["format"], "cehmm-policy");
    assert_eq!(doc["levels"], serde_json::json!([4, 2]));
    assert_eq!(doc["world"]["case"], 1);
    let out = ceworld(&["evaluate", p, "--episodes", "200"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(String::from_utf8_lossy(&out.stdout).contains("200 episodes: mean"));
}

#[test]
fn a_controller_search_saves_a_policy_whose_value_it_reports() {
    let path = temp("controller.json");
    let p = path.to_str().unwrap();
    let tiger = format!("{}/../../data/pomdp/tiger.95.POMDP", env!("CARGO_MANIFEST_DIR"));
    let args = [
        "controller",
        "--pomdp",
        &tiger,
        "--nodes",
        "3",
        "--model-nodes",
        "0",
        "--samples",
        "200",
        "--max-iterations",
        "4",
    ];
    let out = ceworld(&[&args[..], &["--restarts", "2", "--out", p, "--quiet"]].concat());
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(stdout.contains("best of 2 runs"), "{stdout}");
    let reported: f64 =
        stdout.split("infinite-horizon value ").nth(1).unwrap().split(';').next().unwrap().parse().unwrap();
    let doc: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
    assert_eq!(doc["levels"], serde_json::json!([3, 3]));
    assert_eq!(doc["provenance"]["method"], "controller-ce");
    let out = ceworld(&["evaluate", p, "--exact"]);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{stdout}");
    let exact: f64 = stdout.split("(discount 0.95): ").nth(1).unwrap().split(' ').next().unwrap().parse().unwrap();
    // Both within their tolerance (1e-6) of the true value.
    assert!((exact - reported).abs() < 3e-6, "{reported} / {stdout}");
    // Exact values only on tabular worlds; sampled values on any.
    fails_with(&["controller", "--case", "1", "--value", "exact"], &["value", "exact values need a tabular world"]);
    fails_with(&["controller", "--case", "1", "--value", "near"], &["value", "\"near\"", "sampled"]);
    fails_with(&[&args[..], &["--rho", "2"]].concat(), &["rho", "2"]);
    let sampled = ["controller", "--case", "1", "--nodes", "3", "--samples", "100", "--episodes", "1"];
    let again = ["--max-iterations", "2", "--eval-episodes", "5", "--out", p, "--force", "-q"];
    let out = ceworld(&[&sampled[..], &again[..]].concat());
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success() && stdout.contains("on 5 fresh episodes"), "{stdout}");
    let doc: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
    assert_eq!(
        (&doc["provenance"]["value"], &doc["world"]["name"]),
        (&serde_json::json!("sampled"), &serde_json::json!("target-tracking"))
    );
}

#[test]
fn optimum_of_case_1() {
    let out = ceworld(&["optimum", "--case", "1"]);
    assert_eq!(String::from_utf8_lossy(&out.stdout).trim(), "86");
    fails_with(&["optimum", "--case", "3"], &["case", "case 1 only"]);
}

#[test]
fn bad_arguments_are_named() {
    fails_with(&["optimize", "--rho", "1.5"], &["rho", "1.5", "0 < rho < 1"]);
    fails_with(&["optimize", "--rho", "0"], &["rho"]);
    fails_with(&["optimize", "--samples", "0"], &["samples", "at least 1"]);
    fails_with(&["optimize", "--levels", "16,0"], &["levels", "level 2 has size 0"]);
    fails_with(&["optimize", "--smoothing", "0"], &["smoothing"]);
    fails_with(&["optimize", "--case", "4"], &["case", "expected 1, 2 or 3"]);
    fails_with(&["optimize", "--param", "bogus=1"], &["unknown parameter \"bogus\""]);
    fails_with(&["optimize", "--case", "3", "--param", "case=2"], &["--case", "give it once"]);
    fails_with(&["optimize", "--param", "horizon=5", "--param", "horizon=6"], &["horizon given twice"]);
    fails_with(&["optimize", "--world", "tiger"], &["\"tiger\"", "target-tracking"]);
    fails_with(&["optimum", "--case", "2"], &["case 1 only"]);
    fails_with(&["optimize", "--param", "start_b=[30,0]"], &["start_b", "off the"]);
    fails_with(&["evaluate", "/nonexistent/p.json"], &["/nonexistent/p.json"]);
    // clap's own errors (not a number) also exit with code 2
    fails_with(&["optimize", "--samples", "many"], &["samples"]);
}

#[cfg(unix)]
#[test]
fn devices_and_fifos_are_refused_on_read_at_once() {
    let fifo = temp("fifo");
    let c = std::ffi::CString::new(fifo.to_str().unwrap()).unwrap();
    // SAFETY: a valid C string; mkfifo only creates the node.
    assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o600) }, 0);
    let f = fifo.to_str().unwrap();
    // /dev/zero used to be read to exhaustion, a FIFO to block on its open.
    for path in ["/dev/zero", f] {
        fails_with(&["evaluate", path], &[path, "not a regular file"]);
        fails_with(&["show", path], &[path, "not a regular file"]);
        fails_with(&["optimize", "--pomdp", path], &[path, "not a regular file"]);
        fails_with(&["qlearn-eval", "--ce-policy", path], &[path, "not a regular file"]);
    }
}

#[cfg(target_os = "linux")]
#[test]
fn the_memory_guard_obeys_the_process_limits() {
    // 5,000,000 episodes of 100 steps need about 2.9 GiB: more than `ulimit -v` leaves (this
    // machine has more), so the run is refused at once instead of aborting in an allocation.
    let command = format!(
        "ulimit -v 3000000 && exec timeout 60 {} optimize --case 3 --levels 16 --samples 5000000 --max-iterations 1 -q",
        env!("CARGO_BIN_EXE_ceworld")
    );
    let out = Command::new("sh").args(["-c", &command]).output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("needs") && stderr.contains("ulimit -v"), "{stderr}");
    // A 57-byte model of 2^26 actions (tables within the entries allowed): its tables and their
    // rows' positions (over 3 GiB) are refused before they are made.
    let model = temp("huge.pomdp");
    std::fs::write(&*model, "states: 1\nactions: 67108864\nobservations: 1\nO: * uniform\n").unwrap();
    let command = format!(
        "ulimit -v 3000000 && exec timeout 60 {} optimize --pomdp {} -q",
        env!("CARGO_BIN_EXE_ceworld"),
        model.display()
    );
    let out = Command::new("sh").args(["-c", &command]).output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("the tables T and O") && stderr.contains("needs"), "{stderr}");
}

#[cfg(unix)]
#[test]
fn a_model_path_that_is_not_utf8_is_refused_by_name() {
    use std::os::unix::ffi::OsStrExt;
    let path = std::ffi::OsStr::from_bytes(b"/tmp/ceworld-\xff.pomdp");
    let out = Command::new(env!("CARGO_BIN_EXE_ceworld"))
        .args(["optimize".as_ref(), "--pomdp".as_ref(), path])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("--pomdp") && stderr.contains("not valid UTF-8"), "{stderr}");
}

#[test]
fn a_discount_json_cannot_hold_is_refused_not_ignored() {
    for d in ["nan", "inf", "-inf", "1e309"] {
        let discount = format!("--discount={d}");
        fails_with(&["optimize", "--pomdp", "../../data/pomdp/tiger.95.POMDP", &discount], &["--discount"]);
    }
    // The domain of a file's own `discount:` (0 to 1): 0 is taken as the file would take it.
    fails_with(
        &["optimize", "--pomdp", "../../data/pomdp/tiger.95.POMDP", "--discount", "1.5"],
        &["0 <= discount <= 1"],
    );
    let out = temp("discount0.json");
    let args = ["optimize", "--pomdp", "../../data/pomdp/tiger.95.POMDP", "--discount", "0", "--samples", "20"];
    let run = ceworld(&[&args[..], &["--max-iterations", "1", "--quiet", "--out", out.to_str().unwrap()]].concat());
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
}

#[test]
fn unwritable_outputs_are_refused_before_the_run() {
    let good = temp("p.json");
    let dir = good.parent().unwrap().to_path_buf();
    let missing = dir.join("missing").join("p.json");
    let bad_ckpt = dir.join("missing").join("run.ckpt");
    let (g, m, d, c) =
        (good.to_str().unwrap(), missing.to_str().unwrap(), dir.to_str().unwrap(), bad_ckpt.to_str().unwrap());
    // 10^9 iterations would run for hours: each refusal comes before the first.
    let long = ["--case", "1", "--samples", "100000", "--max-iterations", "1000000000"];
    for command in ["optimize", "controller"] {
        for (out, checkpoint, named) in [(m, None, m), (d, None, d), (g, Some(c), c)] {
            let mut args = vec![command, "--out", out];
            if let Some(c) = checkpoint {
                args.extend(["--checkpoint", c]);
            }
            args.extend(long);
            fails_with(&args, &[named]);
        }
    }
    assert!(!good.exists());
}

#[test]
fn bad_policy_files_are_refused() {
    let path = temp("bad.json");
    let p = path.to_str().unwrap();
    std::fs::write(&path, "{not json").unwrap();
    fails_with(&["evaluate", p], &["invalid policy file", "not JSON"]);
    std::fs::write(&path, r#"{"format": "cehmm-policy", "version": 1, "n_obs": 1, "n_actions": 16, "levels": [1],
        "world": {"name": "target-tracking", "case": 3},
        "policy": {"h0": [[0.0625,0.0625,0.0625,0.0625,0.0625,0.0625,0.0625,0.0625,0.0625,0.0625,0.0625,0.0625,0.0625,0.0625,0.0625,0.0625]],
                   "h1": [[[1.0]]], "upper": []}}"#)
        .unwrap();
    fails_with(&["evaluate", p], &["does not match the world", "1 observations"]);
}

#[cfg(unix)]
#[test]
fn ctrl_c_saves_the_best_policy_so_far() {
    let path = temp("interrupted.json");
    let (status, stdout, stderr) = interrupt_when_ready(&[
        "optimize",
        "--case",
        "3",
        "--levels",
        "16,16",
        "--samples",
        "500",
        "--patience",
        "100000",
        "--eval-episodes",
        "100",
        "--out",
        path.to_str().unwrap(),
    ]);
    assert_eq!(status.code(), Some(130), "Ctrl-C exits with 130 after saving: {stderr}");
    assert!(stdout.starts_with("interrupted:"), "{stdout}");
    let doc: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
    assert_eq!(doc["provenance"]["interrupted"], true);
    assert!(doc["provenance"]["iterations"].as_u64().unwrap() >= 1);
}

#[cfg(unix)]
#[test]
fn sigterm_saves_the_best_policy_so_far_and_exits_143() {
    let path = temp("terminated.json");
    let (status, stdout, stderr) = common::signal_when_ready(
        "-TERM",
        &[
            "optimize",
            "--case",
            "3",
            "--levels",
            "16",
            "--samples",
            "500",
            "--patience",
            "100000",
            "--out",
            path.to_str().unwrap(),
        ],
    );
    assert_eq!(status.code(), Some(143), "SIGTERM exits with 143 after saving: {stderr}");
    assert!(stdout.starts_with("interrupted:"), "{stdout}");
    let doc: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
    assert_eq!(doc["provenance"]["interrupted"], true);
}

#[cfg(unix)]
#[test]
fn sigterm_then_resume_gives_the_uninterrupted_policy() {
    let (reference, resumed, checkpoint) = (temp("reference.json"), temp("resumed.json"), temp("run.ckpt"));
    let _ = std::fs::remove_file(&checkpoint);
    let run = |out: &std::path::Path| {
        [
            "optimize",
            "--case",
            "3",
            "--levels",
            "8,2",
            "--samples",
            "400",
            "--max-iterations",
            "40",
            "--eval-episodes",
            "200",
            "--out",
            out.to_str().unwrap(),
        ]
        .map(String::from)
        .to_vec()
    };
    let args = run(&reference);
    let out = ceworld(&[&args.iter().map(String::as_str).collect::<Vec<_>>()[..], &["--quiet"]].concat());
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let mut args = run(&resumed);
    args.extend(["--checkpoint", checkpoint.to_str().unwrap(), "--resume"].map(String::from));
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    let (status, _, stderr) = common::signal_when_ready("-TERM", &args);
    assert_eq!(status.code(), Some(143), "{stderr}");
    assert!(checkpoint.exists(), "the checkpoint is saved on SIGTERM");
    let out = ceworld(&[&args[..], &["--quiet"]].concat());
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let tables = |p: &std::path::Path| {
        let mut doc: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(p).unwrap()).unwrap();
        doc.as_object_mut().unwrap().remove("provenance");
        doc
    };
    assert_eq!(tables(&resumed), tables(&reference));
    fails_with(&["optimize", "--resume"], &["--checkpoint"]);
    fails_with(&[&args[..], &["--seed", "3"]].concat(), &["checkpoint", "seed"]);
}

#[cfg(unix)]
#[test]
fn a_checkpoint_that_cannot_be_written_does_not_cost_the_result() {
    // The checkpoint's folder is removed after the first save (a disk gone full or lost):
    // the run goes on, --out on another folder is written, and a warning says why.
    let out = temp("lost-disk.json");
    let dir = out.with_extension("disk");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let checkpoint = dir.join("run.ckpt");
    let args = [
        "optimize",
        "--case",
        "3",
        "--levels",
        "8,2",
        "--samples",
        "1000",
        "--max-iterations",
        "30",
        "--eval-episodes",
        "200",
        "--checkpoint-every",
        "0.001",
        "--checkpoint",
        checkpoint.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ];
    let (status, stdout, stderr) = common::act_when_ready(&args, |_| {
        // Once the first checkpoint is saved: the run is under way.
        while !checkpoint.exists() {
            std::thread::sleep(std::time::Duration::from_millis(5));
        }
        // The run may write its next checkpoint's temporary file meanwhile: try again then.
        while let Err(e) = std::fs::remove_dir_all(&dir) {
            assert_eq!(e.kind(), std::io::ErrorKind::DirectoryNotEmpty, "{e}");
        }
    });
    assert!(status.success(), "{stderr}");
    assert!(stdout.contains("max_iterations: 30 iterations"), "{stdout}");
    assert!(stderr.contains("warning: the last checkpoint could not be written ("), "{stderr}");
    assert!(stderr.contains("run.ckpt") && !stderr.contains(".tmp"), "{stderr}");
    let doc: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    assert_eq!(doc["provenance"]["iterations"], 30);
    assert!(!dir.exists());
}

#[test]
fn defaults_are_shown_as_they_are_written() {
    // `[default: 16 16]` was shown where only `16,16` is accepted.
    let out = ceworld(&["optimize", "--help"]);
    let help = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success() && help.contains("[default: 16,16]"), "{help}");
    fails_with(&["optimize", "--levels", "16 16"], &["--levels", "expected sizes separated by commas"]);
    // Sizes given apart were "unexpected argument '16'": now what is expected.
    fails_with(&["optimize", "--levels", "16", "16"], &["invalid --levels: 16 16", "commas", "--levels 16,16"]);
    fails_with(&["optimize", "--levels=8", "4", "2", "-q"], &["invalid --levels: 8 4 2", "--levels 8,4,2"]);
}

#[test]
fn the_help_lists_every_command_on_a_line_and_says_what_the_controller_search_takes() {
    let help = String::from_utf8_lossy(&ceworld(&["--help"]).stdout).into_owned();
    let listed: Vec<&str> =
        help.lines().skip_while(|l| *l != "Commands:").skip(1).take_while(|l| !l.is_empty()).collect();
    assert_eq!(listed.len(), 9, "{help}");
    assert!(listed.iter().all(|l| l.chars().count() < 120), "one short line a command: {help}");
    // Without a command: the same list, on stderr, exit 2.
    let bare = ceworld(&[]);
    assert_eq!(bare.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&bare.stderr).contains(listed[1]), "{bare:?}");
    let controller = String::from_utf8_lossy(&ceworld(&["controller", "--help"]).stdout).into_owned();
    assert!(!controller.contains("of a tabular world"), "{controller}");
    assert!(controller.contains("controller of any world") && controller.contains("--value sampled"), "{controller}");
}

#[test]
fn runs_keep_their_history_and_never_replace_a_result_unasked() {
    let (out, jsonl, csv) = (temp("kept.json"), temp("kept.jsonl"), temp("kept.csv"));
    let (o, j, c) = (out.to_str().unwrap(), jsonl.to_str().unwrap(), csv.to_str().unwrap());
    let run = ["optimize", "--case", "3", "--levels", "4", "--samples", "100", "--max-iterations", "5", "--quiet"];
    let done = ceworld(&[&run[..], &["--out", o, "--history", j]].concat());
    assert!(done.status.success(), "{}", String::from_utf8_lossy(&done.stderr));
    let lines: Vec<serde_json::Value> =
        std::fs::read_to_string(&jsonl).unwrap().lines().map(|l| serde_json::from_str(l).unwrap()).collect();
    assert_eq!(lines.len(), 5);
    assert!(lines.iter().enumerate().all(|(i, l)| l["iteration"] == i && l["mean"].is_number()), "{lines:?}");
    // The same run again: refused before it starts, unless --force.
    let again = ceworld(&[&run[..], &["--out", o]].concat());
    let stderr = String::from_utf8_lossy(&again.stderr);
    assert_eq!(again.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("--out") && stderr.contains("exists (give --force"), "{stderr}");
    let forced = ceworld(&[&run[..], &["--out", o, "--force", "--history", c]].concat());
    assert!(forced.status.success(), "{}", String::from_utf8_lossy(&forced.stderr));
    let table = std::fs::read_to_string(&csv).unwrap();
    let rows: Vec<&str> = table.lines().collect();
    assert_eq!(rows.len(), 6, "{table}");
    assert!(rows[0].split(',').any(|h| h == "elite_threshold"), "{table}");
    fails_with(&[&run[..], &["--out", o, "--force", "--history", "h.txt"]].concat(), &["--history", ".jsonl or .csv"]);
    // The controller search keeps its history too.
    let tiger = format!("{}/../../data/pomdp/tiger.95.POMDP", env!("CARGO_MANIFEST_DIR"));
    let search = ["controller", "--pomdp", &tiger, "--nodes", "2", "--max-iterations", "3", "--quiet", "--force"];
    let done = ceworld(&[&search[..], &["--out", o, "--history", j]].concat());
    assert!(done.status.success(), "{}", String::from_utf8_lossy(&done.stderr));
    let first: serde_json::Value =
        serde_json::from_str(std::fs::read_to_string(&jsonl).unwrap().lines().next().unwrap()).unwrap();
    assert!(first["best_so_far"].is_number() && first["restart"] == 0, "{first}");
}

#[test]
fn show_writes_the_most_likely_controller_of_a_stochastic_policy() {
    // The README trains this policy and then ran `show --pg`, which exited 2 (not deterministic).
    let (policy, pg) = (temp("stochastic.json"), temp("stochastic.pg"));
    let tiger = format!("{}/../../data/pomdp/tiger.95.POMDP", env!("CARGO_MANIFEST_DIR"));
    let learn = ["optimize", "--pomdp", &tiger, "--horizon", "60", "--param", "reward=belief", "--levels", "8,8"];
    let settings = ["--random-init", "--rho", "0.05", "--smoothing", "0.2", "--max-iterations", "5", "--quiet"];
    let out = ceworld(&[&learn[..], &settings[..], &["--out", policy.to_str().unwrap()]].concat());
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let dot = temp("stochastic.dot");
    let shown =
        ceworld(&["show", policy.to_str().unwrap(), "--pg", pg.to_str().unwrap(), "--dot", dot.to_str().unwrap()]);
    let stdout = String::from_utf8_lossy(&shown.stdout);
    assert!(shown.status.success(), "{}", String::from_utf8_lossy(&shown.stderr));
    assert!(stdout.contains("stochastic policy:") && stdout.contains("(the stochastic policy's: "), "{stdout}");
    let lines = std::fs::read_to_string(&pg).unwrap();
    // Node, action, then the next node on each of tiger's two observations.
    assert!(lines.lines().all(|l| l.split(' ').count() == 2 + 2), "{lines}");
    // The DOT text of the graph shown: a node per memory reached, a start arrow per initial node.
    let dot = std::fs::read_to_string(&dot).unwrap();
    let nodes = stdout.lines().filter(|l| l.starts_with("node ")).count();
    assert!(dot.starts_with("digraph policy {") && dot.trim_end().ends_with('}'), "{dot}");
    let node_line = |l: &&str| {
        let numbered = l.trim_start().strip_prefix('n').is_some_and(|r| r.starts_with(|c: char| c.is_ascii_digit()));
        numbered && !l.contains("->")
    };
    let declared = dot.lines().filter(node_line).count();
    assert_eq!(declared, nodes, "{dot}");
    fails_with(&["show", policy.to_str().unwrap(), "--prune", "1"], &["--prune", "0 <= p < 1"]);
}

/// `a` then `b`.
fn joined<'a>(a: &[&'a str], b: &[&'a str]) -> Vec<&'a str> {
    a.iter().chain(b).copied().collect()
}

#[test]
fn no_output_is_an_input_or_another_output_and_a_resume_replaces_only_its_own() {
    let dir = temp("outputs");
    let folder = dir.parent().unwrap();
    let path = |name: &str| folder.join(name).to_str().unwrap().to_string();
    let base = ["optimize", "--case", "1", "--levels", "2", "--samples", "60", "--quiet"];
    let run = joined(&base, &["--max-iterations", "2"]);
    // One file named twice: the policy would be lost under the history, the checkpoint broken.
    let (same, ck) = (path("same.jsonl"), path("ck.json"));
    fails_with(&joined(&run, &["--out", &same, "--history", &same]), &["--history", "--out", "same command"]);
    fails_with(
        &joined(&run, &["--out", &path("p.json"), "--history", &ck, "--checkpoint", &ck]),
        &["--checkpoint", "--history"],
    );
    fails_with(&joined(&run, &["--out", &ck, "--checkpoint", &ck]), &["--checkpoint", "--out"]);
    assert!(!folder.join("same.jsonl").exists() && !folder.join("ck.json").exists(), "nothing was written");
    // A run with its outputs recorded in its checkpoint.
    let (out, history, other) = (path("run.json"), path("run.jsonl"), path("other.jsonl"));
    let first = ceworld(&joined(&run, &["--out", &out, "--history", &history, "--checkpoint", &ck]));
    assert!(first.status.success(), "{}", String::from_utf8_lossy(&first.stderr));
    // An input is never an output (a link to it neither), whatever --force says.
    #[cfg(unix)]
    std::os::unix::fs::symlink(&out, folder.join("link.json")).unwrap();
    let init = ["optimize", "--case", "1", "--samples", "60", "--max-iterations", "1", "--quiet", "--init", &out];
    fails_with(&joined(&init, &["--out", &out, "--force"]), &["--out", "--init", "read by the same command"]);
    #[cfg(unix)]
    fails_with(&joined(&init, &["--out", &path("link.json"), "--force"]), &["--out", "--init"]);
    // Its resume may replace what it wrote, and nothing else.
    std::fs::write(&other, "another run's history\n").unwrap();
    let resume = joined(&base, &["--max-iterations", "3", "--checkpoint", &ck, "--resume", "--out", &out]);
    fails_with(&[&resume[..], &["--history", &other]].concat(), &["--history", "not an output of the run that wrote"]);
    assert_eq!(std::fs::read_to_string(&other).unwrap(), "another run's history\n");
    let resumed = ceworld(&[&resume[..], &["--history", &history]].concat());
    assert!(resumed.status.success(), "{}", String::from_utf8_lossy(&resumed.stderr));
    assert_eq!(std::fs::read_to_string(&history).unwrap().lines().count(), 3);
    // `show` writes no file over the policy it reads, nor over an existing file unasked.
    let tiger = format!("{}/../../data/pomdp/tiger.95.POMDP", env!("CARGO_MANIFEST_DIR"));
    let keep = path("keep.json");
    let search = ["controller", "--pomdp", &tiger, "--nodes", "2", "--max-iterations", "2", "--quiet", "--out", &keep];
    assert!(ceworld(&search).status.success());
    let kept = std::fs::read(&keep).unwrap();
    for option in ["--pg", "--dot", "--json"] {
        fails_with(&["show", &keep, option, &keep, "--force"], &[option, "FILE", "read by the same command"]);
    }
    fails_with(&["show", &keep, "--dot", &tiger, "--force"], &["--dot", "model file"]);
    assert_eq!(std::fs::read(&keep).unwrap(), kept, "the policy read is intact");
    let dot = path("keep.dot");
    assert!(ceworld(&["show", &keep, "--dot", &dot]).status.success());
    fails_with(&["show", &keep, "--dot", &dot], &["--dot", "exists (give --force"]);
    assert!(ceworld(&["show", &keep, "--dot", &dot, "--force"]).status.success());
    // The controller search's outputs obey the same rule.
    let both = [&search[..7], &["--out", &same, "--history", &same]].concat();
    fails_with(&both, &["--history", "--out"]);
}

#[test]
fn exact_values_refuse_a_tolerance_that_bounds_every_value() {
    let tiger = format!("{}/../../data/pomdp/tiger.95.POMDP", env!("CARGO_MANIFEST_DIR"));
    let policy = temp("tolerance.json");
    let p = policy.to_str().unwrap();
    let search = ["controller", "--pomdp", &tiger, "--nodes", "2", "--max-iterations", "2", "--quiet", "--out", p];
    assert!(ceworld(&search).status.success());
    fails_with(
        &["evaluate", p, "--exact", "--tolerance", "1.8e19"],
        &["tolerance", "18000000000000000000", "expected less than"],
    );
    let fine = ceworld(&["evaluate", p, "--exact", "--tolerance", "1e-3"]);
    assert!(String::from_utf8_lossy(&fine.stdout).contains("infinite-horizon value"));
    // Nothing else: no stray "(0.00s)" on stderr.
    assert!(fine.stderr.is_empty(), "{}", String::from_utf8_lossy(&fine.stderr));
    // Sampling options do not apply to an exact value: refused, not ignored.
    fails_with(&["evaluate", p, "--exact", "--episodes", "10"], &["invalid --episodes: 10", "with --exact"]);
    fails_with(&["evaluate", p, "--exact", "--seed", "3"], &["invalid --seed: 3", "with --exact"]);
}

#[test]
fn a_tiny_model_file_of_huge_tables_is_refused_at_once() {
    // 90 bytes asking for two dense tables of 2^28 entries (4 GiB) through wildcards.
    let model = temp("huge.pomdp");
    std::fs::write(
        &model,
        "states: 16384\nactions: 1\nobservations: 16384\nT: * uniform\nO: * uniform\nR: * : * : * : * 1\n",
    )
    .unwrap();
    // Refused by the header's check (the tables' size), not after building them.
    fails_with(&["optimize", "--pomdp", model.to_str().unwrap(), "--quiet"], &["16384", "67108864 entries"]);
}
