//! Every reader of a file the engine wrote (policy JSON, CE checkpoint, Q table) on damaged
//! copies of a good file: truncations, byte flips and random bytes, changed digits, deleted and
//! duplicated spans. Each is refused with a format error, or read as a valid file: never a
//! panic, never another kind of error. `READERS_FUZZ_ITERS` sets the mutations per reader
//! (default 300), `READERS_FUZZ_SEED` the seed; the counts are printed (`--nocapture`).

#[path = "common/temp.rs"]
mod temp;

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

/// xorshift64: a small deterministic generator for the mutations.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0
    }

    fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }
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
    let checkpointing = Checkpointing { path: path.to_path_buf(), every: 1e9, resume: false };
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
