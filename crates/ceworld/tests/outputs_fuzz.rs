//! The files of a command on random names (issue 29): `optimize`, `controller` and `show` given
//! --init, --out, --history, --checkpoint, --resume, --force and show's outputs drawn from a pool
//! of names (files, symbolic links to them, a hard link, a dangling link, a link to a folder,
//! names to be created) either run, writing only their outputs, each a distinct file, or are
//! refused (exit 2, one line naming an option) having written nothing: no input is ever
//! changed, no output ever lands on another. `OUTPUTS_FUZZ_ITERS` sets the commands (default
//! 40), `OUTPUTS_FUZZ_SEED` the seed; the counts are printed (`--nocapture`).

#[path = "common/rng.rs"]
mod rng;
#[path = "common/temp.rs"]
mod temp;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Command;

use rng::Rng;

fn iterations() -> usize {
    std::env::var("OUTPUTS_FUZZ_ITERS").ok().and_then(|v| v.parse().ok()).unwrap_or(40)
}

fn seed() -> u64 {
    std::env::var("OUTPUTS_FUZZ_SEED").ok().and_then(|v| v.parse().ok()).unwrap_or(0x0D7_F11E5) | 1
}

fn ceworld(dir: &Path, args: &[String]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_ceworld")).current_dir(dir).args(args).output().expect("the binary runs")
}

/// Every file below `dir` (links not followed) and its bytes; links as `-> target`.
fn snapshot(dir: &Path) -> BTreeMap<PathBuf, Vec<u8>> {
    let mut files = BTreeMap::new();
    for entry in std::fs::read_dir(dir).unwrap().flatten() {
        let path = entry.path();
        let meta = std::fs::symlink_metadata(&path).unwrap();
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        if name.starts_with('.') {
            continue; // a writer's temporary file: never left, checked apart
        }
        if meta.file_type().is_symlink() {
            let target = std::fs::read_link(&path).unwrap();
            files.insert(path, format!("-> {}", target.display()).into_bytes());
        } else if meta.is_file() {
            files.insert(path, std::fs::read(entry.path()).unwrap());
        }
    }
    files
}

/// The pool of names, made afresh in `dir`: a policy (`policy.json`), a tiger model, a history,
/// links of every kind, and names that do not exist yet.
fn lay_out(dir: &Path, tiger: &Path, policy: &[u8]) -> Vec<&'static str> {
    let _ = std::fs::remove_dir_all(dir);
    std::fs::create_dir_all(dir.join("sub")).unwrap();
    std::fs::write(dir.join("policy.json"), policy).unwrap();
    std::fs::copy(tiger, dir.join("tiger.pomdp")).unwrap();
    std::fs::write(dir.join("old.jsonl"), b"{\"iteration\":0}\n").unwrap();
    #[cfg(unix)]
    {
        use std::os::unix::fs::symlink;
        symlink("policy.json", dir.join("link.json")).unwrap();
        symlink("tiger.pomdp", dir.join("link.pomdp")).unwrap();
        symlink("new.json", dir.join("dangling.json")).unwrap();
        symlink("sub", dir.join("subdir")).unwrap();
        std::fs::hard_link(dir.join("old.jsonl"), dir.join("hard.jsonl")).unwrap();
    }
    vec![
        "policy.json",
        "link.json",
        "tiger.pomdp",
        "link.pomdp",
        "old.jsonl",
        "hard.jsonl",
        "dangling.json",
        "new.json",
        "new.jsonl",
        "new.csv",
        "run.ckpt",
        "sub/../new.json",
        "subdir/new.json",
        "sub",
    ]
}

/// A command on names drawn from `names`: its arguments, the names it reads, the names it writes.
fn draw(rng: &mut Rng, names: &[&str]) -> (Vec<String>, Vec<String>, Vec<String>) {
    let pick = |rng: &mut Rng| names[rng.below(names.len())].to_string();
    let mut args: Vec<String> = Vec::new();
    let mut inputs: Vec<String> = Vec::new();
    let mut outputs: Vec<String> = Vec::new();
    let option = |args: &mut Vec<String>, name: &str, value: String| {
        args.push(name.into());
        args.push(value);
    };
    match rng.below(3) {
        0 => {
            args.extend(
                ["optimize", "--case", "1", "--samples", "30", "--max-iterations", "1", "-q"].map(String::from),
            );
            if rng.below(2) == 0 {
                let init = pick(rng);
                inputs.push(init.clone());
                option(&mut args, "--init", init);
            } else {
                args.extend(["--levels", "2"].map(String::from));
            }
        }
        1 => {
            let model = pick(rng);
            inputs.push(model.clone());
            args.extend(["controller", "--nodes", "2", "--max-iterations", "1", "-q"].map(String::from));
            option(&mut args, "--pomdp", model);
        }
        _ => {
            let file = pick(rng);
            inputs.push(file.clone());
            inputs.push("tiger.pomdp".into());
            args.extend(["show".to_string(), file]);
            for name in ["--pg", "--dot", "--json"] {
                if rng.below(2) == 0 {
                    let out = pick(rng);
                    outputs.push(out.clone());
                    option(&mut args, name, out);
                }
            }
        }
    }
    if args[0] != "show" {
        let out = pick(rng);
        outputs.push(out.clone());
        option(&mut args, "--out", out);
        if rng.below(2) == 0 {
            let history = pick(rng);
            outputs.push(history.clone());
            option(&mut args, "--history", history);
        }
        if rng.below(2) == 0 {
            let checkpoint = pick(rng);
            outputs.push(checkpoint.clone());
            option(&mut args, "--checkpoint", checkpoint);
            if rng.below(2) == 0 {
                args.push("--resume".into());
            }
        }
    }
    if rng.below(3) == 0 {
        args.push("--force".into());
    }
    (args, inputs, outputs)
}

#[test]
fn commands_on_random_names_never_write_over_an_input_or_each_other() {
    let root = temp::TempPath::new("ceworld-outputs-fuzz", "work");
    let dir = root.to_path_buf();
    let tiger = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/pomdp/tiger.95.POMDP");
    // A policy of the tiger model to read (by --init and by show), its model named as in the
    // pool (so that show reads it there).
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::copy(&tiger, dir.join("tiger.pomdp")).unwrap();
    let search =
        ["controller", "--pomdp", "tiger.pomdp", "--nodes", "2", "--max-iterations", "1", "-q", "--out", "p.json"];
    let made = ceworld(&dir, &search.map(String::from));
    assert!(made.status.success(), "{}", String::from_utf8_lossy(&made.stderr));
    let policy = std::fs::read(dir.join("p.json")).unwrap();
    let mut rng = Rng(seed());
    let (mut ran, mut refused) = (0, 0);
    for _ in 0..iterations() {
        let names = lay_out(&dir, &tiger, &policy);
        let (args, inputs, outputs) = draw(&mut rng, &names);
        let before = snapshot(&dir);
        let out = ceworld(&dir, &args);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(!stderr.contains("panicked"), "{args:?}: {stderr}");
        let after = snapshot(&dir);
        let resolved = |name: &String| ceworld::files::resolved(&dir.join(name));
        let written: Vec<PathBuf> = outputs.iter().map(resolved).collect();
        // No input changed, whatever happened (an input named as an output too is refused).
        for input in &inputs {
            let path = resolved(input);
            if !written.contains(&path) {
                let (b, a) = (before.get(&path), after.get(&path));
                assert_eq!(b, a, "{args:?} changed the input {input}: {stderr}");
            }
        }
        match out.status.code() {
            Some(0) => {
                ran += 1;
                // Its outputs are distinct files, and no input is one of them.
                for (i, w) in written.iter().enumerate() {
                    assert!(!written[..i].contains(w), "{args:?} wrote {} twice", w.display());
                    assert!(!inputs.iter().map(resolved).any(|p| &p == w), "{args:?} wrote its input {}", w.display());
                }
                // Every file it changed is one of its outputs.
                for (path, bytes) in &after {
                    if before.get(path) != Some(bytes) {
                        let p = ceworld::files::resolved(path);
                        assert!(written.contains(&p), "{args:?} changed {}, not an output", path.display());
                    }
                }
            }
            Some(2) => {
                refused += 1;
                assert_eq!(stderr.lines().count(), 1, "{args:?}: one line: {stderr}");
                assert!(stderr.contains("error:"), "{args:?}: {stderr}");
                for (path, bytes) in &before {
                    // A refused resume writes nothing; only a checkpoint it started may be new.
                    assert_eq!(after.get(path), Some(bytes), "{args:?} was refused but changed {}", path.display());
                }
            }
            other => panic!("{args:?}: exit {other:?}: {stderr}"),
        }
    }
    println!("outputs fuzz: {ran} commands ran, {refused} refused");
    assert!(ran > 0 && refused > 0, "both kinds of outcome are reached ({ran} ran, {refused} refused)");
}
