//! Every reader of a file the engine wrote (policy JSON, CE checkpoint, Q table) on damaged
//! copies of a good file: truncations, byte flips and random bytes, changed digits, deleted and
//! duplicated spans. Each is refused with a format error, or read as a valid file: never a
//! panic, never another kind of error. `READERS_FUZZ_ITERS` sets the mutations per reader
//! (default 300), `READERS_FUZZ_SEED` the seed; the counts are printed (`--nocapture`).

#[path = "common/rng.rs"]
mod rng;
#[path = "common/temp.rs"]
mod temp;

use rng::Rng;

use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::Path;

use ceworld::qlearn::{AnyLearner, QConfig};
use ceworld::{
    AnyWorld, CeCheckpoint, CeConfig, Checkpointing, Error, Flow, PolicyFile, TargetTracking, TrackingParams, optimize,
    optimize_with, random_policy,
};

fn temp(name: &str) -> temp::TempPath {
    temp::TempPath::new("ceworld-readers-fuzz", name)
}

fn iterations() -> usize {
    std::env::var("READERS_FUZZ_ITERS").ok().and_then(|v| v.parse().ok()).unwrap_or(300)
}

fn seed() -> u64 {
    std::env::var("READERS_FUZZ_SEED").ok().and_then(|v| v.parse().ok()).unwrap_or(0x5EED_F11E) | 1
}

/// One damage to `bytes`, within `bytes[..reach]` (where the structure is) or anywhere for a truncation.
fn mutate(bytes: &mut Vec<u8>, reach: usize, rng: &mut Rng) {
    if bytes.is_empty() {
        return;
    }
    let reach = reach.min(bytes.len()).max(1);
    match rng.below(6) {
        0 => bytes.truncate(rng.below(bytes.len())),
        1 => {
            let i = rng.below(reach);
            bytes[i] ^= 1 << rng.below(8);
        }
        2 => {
            let i = rng.below(reach);
            bytes[i] = rng.next() as u8;
        }
        3 => {
            let digits: Vec<usize> =
                bytes[..reach].iter().enumerate().filter(|(_, b)| b.is_ascii_digit()).map(|(i, _)| i).collect();
            if let Some(&i) = digits.get(rng.below(digits.len())) {
                bytes[i] = b'0' + (bytes[i] - b'0' + 1 + rng.below(9) as u8) % 10;
            }
        }
        4 => {
            let start = rng.below(reach);
            let end = (start + 1 + rng.below(40)).min(bytes.len());
            bytes.drain(start..end);
        }
        _ => {
            let start = rng.below(reach);
            let end = (start + 1 + rng.below(40)).min(bytes.len());
            let span = bytes[start..end].to_vec();
            let at = rng.below(reach);
            bytes.splice(at..at, span);
        }
    }
}

/// Runs `read` on `iterations()` damaged copies of `good`; returns (refused, read).
fn fuzz(name: &str, good: &[u8], reach: usize, read: impl Fn(&Path) -> Result<(), Error>) -> (usize, usize) {
    let path = temp(name);
    let mut rng = Rng(seed() ^ name.len() as u64);
    let (mut refused, mut read_ok) = (0, 0);
    for case in 0..iterations() {
        let mut bytes = good.to_vec();
        for _ in 0..=rng.below(3) {
            mutate(&mut bytes, reach, &mut rng);
        }
        std::fs::write(&path, &bytes).unwrap();
        let outcome = catch_unwind(AssertUnwindSafe(|| read(&path)));
        match outcome.unwrap_or_else(|_| panic!("{name}: case {case} panicked")) {
            Ok(()) => read_ok += 1,
            Err(
                Error::PolicyFormat { .. } | Error::CheckpointFormat { .. } | Error::Mismatch(_) | Error::Memory { .. },
            ) => {
                refused += 1;
            }
            Err(e) => panic!("{name}: case {case}: unexpected error kind: {e}"),
        }
    }
    println!("{name}: {} damaged files, {refused} refused, {read_ok} read, no panic", iterations());
    (refused, read_ok)
}

fn world() -> TargetTracking {
    TargetTracking::with_params(TrackingParams {
        width: 5,
        height: 5,
        start_b: [0, 4],
        start_c: [4, 4],
        target_rows: [0, 2],
        target_cell: [2, 2],
        horizon: 20,
        ..TrackingParams::default()
    })
    .unwrap()
}

#[test]
fn damaged_policy_files() {
    let w = world();
    let config = CeConfig { samples: 100, max_iterations: Some(2), eval_episodes: 50, ..CeConfig::default() };
    let result = optimize(&w, random_policy(&w, &[3, 2, 2], 1).unwrap(), &config, |_| Flow::Continue).unwrap();
    let path = temp("good.json");
    result.to_file(&w, &config).save(&path).unwrap();
    let good = std::fs::read(&path).unwrap();
    let (refused, _) = fuzz("policy", &good, good.len(), |p| PolicyFile::load(p).map(|_| ()));
    assert!(refused > iterations() / 2);
}

#[test]
fn damaged_checkpoints() {
    let w = world();
    let config = CeConfig { samples: 100, max_iterations: Some(3), eval_episodes: 50, ..CeConfig::default() };
    let path = temp("good.ckpt");
    let checkpointing = Checkpointing { path: path.to_path_buf(), every: 1e9, resume: false, outputs: Vec::new() };
    let initial = random_policy(&w, &[3, 2], 1).unwrap();
    optimize_with(&w, initial, &config, Some(&checkpointing), |_| Flow::Continue).unwrap();
    let good = std::fs::read(&path).unwrap();
    let (refused, _) = fuzz("checkpoint", &good, good.len(), |p| CeCheckpoint::load(p).map(|_| ()));
    assert!(refused > iterations() / 2);
    let other = temp("other.ckpt");
    std::fs::write(&other, b"{\"format\": \"cehmm-policy\"}").unwrap();
    let e = CeCheckpoint::load(&other).unwrap_err();
    assert!(e.to_string().contains("not a checkpoint"), "{e}");
}

#[test]
fn damaged_q_tables() {
    let mut learner = AnyLearner::new(AnyWorld::TargetTracking(world()), QConfig::default()).unwrap();
    let AnyLearner::TargetTracking(inner) = &mut learner;
    inner.run(1000);
    let path = temp("good.bin");
    inner.save(&path).unwrap();
    let good = std::fs::read(&path).unwrap();
    // The header (magic, length, JSON): where the structure is; the values are any f32.
    let header = 16 + u64::from_le_bytes(good[8..16].try_into().unwrap()) as usize;
    let (refused, _) = fuzz("q-table", &good, header, |p| AnyLearner::load(p).map(|_| ()));
    assert!(refused > iterations() / 2);
}

/// Every leaf of a JSON document, as a path of keys and indices.
fn leaves(value: &serde_json::Value, at: &mut Vec<String>, out: &mut Vec<Vec<String>>) {
    match value {
        serde_json::Value::Object(map) => {
            for (k, v) in map {
                at.push(k.clone());
                leaves(v, at, out);
                at.pop();
            }
        }
        serde_json::Value::Array(items) => {
            for (i, v) in items.iter().enumerate() {
                at.push(i.to_string());
                leaves(v, at, out);
                at.pop();
            }
        }
        _ => out.push(at.clone()),
    }
}

fn leaf<'a>(value: &'a mut serde_json::Value, path: &[String]) -> &'a mut serde_json::Value {
    path.iter().fold(value, |v, key| match v {
        serde_json::Value::Array(items) => &mut items[key.parse::<usize>().unwrap()],
        other => &mut other[key.as_str()],
    })
}

/// Another value of the same leaf: a number nudged, scaled, negated or extreme; a flag flipped;
/// a string changed; or a value of another type.
fn tampered(value: &serde_json::Value, rng: &mut Rng) -> serde_json::Value {
    use serde_json::json;
    match (value, rng.below(6)) {
        (serde_json::Value::Number(n), k) => {
            let x = n.as_f64().unwrap_or(0.0);
            match k {
                0 => json!(x + 1.0),
                1 => json!(x - 1.0),
                2 => json!(x * 2.0),
                3 => json!(-x),
                4 => json!(1e308),
                _ => json!(n.as_u64().map_or(0, |u| u + 5)),
            }
        }
        (serde_json::Value::Bool(b), _) => json!(!b),
        (serde_json::Value::String(s), 0) => json!(format!("{s}x")),
        (_, 1) => serde_json::Value::Null,
        (_, 2) => json!("0"),
        _ => json!([]),
    }
}

#[test]
fn tampered_checkpoints_are_refused_or_change_nothing() {
    // A checkpoint taken mid-run, one leaf changed (a number, a flag, a name), then resumed:
    // refused with a clean error, or a resume that ends with the uninterrupted run's policies
    // and evaluation (a leaf that does not steer the run, such as seconds). A tamper accepted that
    // changes the result is what this looks for: 17 of them were found by hand before.
    let w = world();
    let config =
        CeConfig { samples: 60, max_iterations: Some(6), eval_episodes: 30, restarts: 2, ..CeConfig::default() };
    let initial = random_policy(&w, &[3, 2], 1).unwrap();
    let reference = optimize(&w, initial.clone(), &config, |_| Flow::Continue).unwrap();
    let good = temp("mid.ckpt");
    let checkpointing = Checkpointing { path: good.to_path_buf(), every: 1e9, resume: true, outputs: Vec::new() };
    let mut seen = 0;
    let cut = optimize_with(&w, initial.clone(), &config, Some(&checkpointing), |_| {
        seen += 1;
        if seen == 9 { Flow::Stop } else { Flow::Continue }
    })
    .unwrap();
    assert!(cut.interrupted());
    let text = std::fs::read_to_string(&*good).unwrap();
    let document: serde_json::Value = serde_json::from_str(&text).unwrap();
    let mut paths = Vec::new();
    leaves(&document, &mut Vec::new(), &mut paths);
    let mut rng = Rng(seed() ^ 0x7a11);
    let (mut refused, mut harmless, mut changed) = (0, 0, Vec::new());
    let path = temp("tampered.ckpt");
    let tampered_checkpointing =
        Checkpointing { path: path.to_path_buf(), every: 1e9, resume: true, outputs: Vec::new() };
    // The tables' entries are most leaves: three times in four, a leaf that is not one.
    let (tables, others): (Vec<_>, Vec<_>) = paths.iter().partition(|p| p.iter().any(|k| k == "probs"));
    for case in 0..iterations() / 3 {
        let from = if rng.below(4) == 0 { &tables } else { &others };
        let at = from[rng.below(from.len())];
        let mut copy = document.clone();
        let slot = leaf(&mut copy, at);
        let new = tampered(slot, &mut rng);
        let before = std::mem::replace(slot, new.clone());
        std::fs::write(&*path, serde_json::to_vec(&copy).unwrap()).unwrap();
        let result = catch_unwind(AssertUnwindSafe(|| {
            optimize_with(&w, initial.clone(), &config, Some(&tampered_checkpointing), |_| Flow::Continue)
        }))
        .unwrap_or_else(|_| panic!("case {case}: a panic for {} = {new} (was {before})", at.join(".")));
        match result {
            Ok(r)
                if (&r.policy, &r.last_policy, &r.evaluation, &r.restart_scores, r.best_iteration)
                    == (
                        &reference.policy,
                        &reference.last_policy,
                        &reference.evaluation,
                        &reference.restart_scores,
                        reference.best_iteration,
                    ) =>
            {
                harmless += 1;
            }
            Ok(_) => changed.push(format!("{} = {new} (was {before})", at.join("."))),
            Err(
                Error::CheckpointFormat { .. }
                | Error::CheckpointMismatch(_)
                | Error::PolicyFormat { .. }
                | Error::InvalidArgument { .. }
                | Error::Mismatch(_),
            ) => refused += 1,
            Err(e) => panic!("case {case}: unexpected error kind for {}: {e}", at.join(".")),
        }
    }
    println!("tampered checkpoints: {refused} refused, {harmless} harmless, {} changed the result", changed.len());
    assert!(changed.is_empty(), "accepted and changed the result:\n{}", changed.join("\n"));
}
