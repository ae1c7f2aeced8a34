//! Crafted `.pomdp` headers and bodies (issue "trust, second round"): sizes from 1 to 2^64 and
//! beyond, as counts or name lists, with wildcard-heavy bodies, loaded as worlds in a process
//! whose address space is limited (`RLIMIT_AS`: 1.5 GiB more than it maps at the start). Each file
//! is loaded or refused with an error; none may abort the process (an allocation past the limit
//! would), panic or hang. `POMDP_SIZES_ITERS` sets the number of files (default 100),
//! `POMDP_SIZES_SEED` the seed.

#[path = "cassandra/rng.rs"]
mod rng;
#[path = "common/temp.rs"]
mod temp;

use std::fmt::Write as _;
use std::time::{Duration, Instant};

use ceworld::{Error, PomdpWorld};
use rng::Rng;

/// Sizes of models that load.
const SMALL: &[&str] = &["1", "2", "3", "7", "60", "200"];

/// Sizes at the edges: the engine's limits (65535 observations and decisions), the dense
/// tables' cap, and past every integer type.
const EDGES: &[&str] =
    &["65535", "65536", "268435456", "4294967297", "18446744073709551616", "99999999999999999999999"];

/// Lines of a body, `{s}`, `{a}`, `{o}` standing for an index drawn below the size (or 0).
const LINES: &[&str] = &[
    "T: * uniform",
    "T: * identity",
    "T: * : * : * 1.0",
    "T: {a} : {s} : {s} 1.0",
    "O: * uniform",
    "O: * : * : * 1.0",
    "O: {a} : {s} : {o} 1.0",
    "R: * : * : * : * 1.5",
    "R: * : * : {s} : * 2",
    "R: {a} : {s} : * : {o} -1",
    "R: * : {s} : {s} : {o} 3",
];

fn iterations() -> usize {
    std::env::var("POMDP_SIZES_ITERS").ok().and_then(|v| v.parse().ok()).unwrap_or(100)
}

fn seed() -> u64 {
    std::env::var("POMDP_SIZES_SEED").ok().and_then(|v| v.parse().ok()).unwrap_or(19)
}

/// Limits the address space to what it maps now plus `extra` bytes.
#[cfg(target_os = "linux")]
fn limit_address_space(extra: u64) {
    let status = std::fs::read_to_string("/proc/self/status").unwrap();
    let kib: u64 = status
        .lines()
        .find_map(|l| l.strip_prefix("VmSize:"))
        .and_then(|v| v.split_whitespace().next())
        .and_then(|v| v.parse().ok())
        .unwrap();
    let limit = libc::rlimit { rlim_cur: kib * 1024 + extra, rlim_max: libc::RLIM_INFINITY };
    // SAFETY: setrlimit with a valid rlimit pointer; it only lowers this process's soft limit.
    assert_eq!(unsafe { libc::setrlimit(libc::RLIMIT_AS, &raw const limit) }, 0);
}

#[cfg(not(target_os = "linux"))]
fn limit_address_space(_: u64) {}

/// One crafted file: a header of sizes (counts or short name lists) and a few body lines.
fn crafted(rng: &mut Rng) -> String {
    let mut text = String::new();
    let mut bound = [1usize; 3];
    for (k, key) in ["states", "actions", "observations"].iter().enumerate() {
        if rng.chance(1, 5) {
            let n = 1 + rng.below(4);
            let names: Vec<String> = (0..n).map(|i| format!("{}{i}", &key[..1])).collect();
            let _ = writeln!(text, "{key}: {}", names.join(" "));
            bound[k] = n;
        } else {
            let sizes = if rng.chance(1, 4) { EDGES } else { SMALL };
            let size = *rng.pick(sizes);
            let _ = writeln!(text, "{key}: {size}");
            bound[k] = size.parse::<usize>().unwrap_or(1).clamp(1, 5000);
        }
    }
    if rng.chance(1, 2) {
        text.push_str("discount: 0.95\nvalues: reward\n");
    }
    if rng.chance(1, 3) {
        text.push_str("start: uniform\n");
    }
    // Mostly a model whose rows sum to 1, so that the sizes reach the world's own tables.
    if rng.chance(4, 5) {
        text.push_str(if rng.chance(1, 2) { "T: * uniform\n" } else { "T: * identity\n" });
    }
    if rng.chance(4, 5) {
        text.push_str("O: * uniform\n");
    }
    for _ in 0..rng.below(12) {
        let line = rng.pick(LINES);
        let line = line
            .replace("{s}", &rng.below(bound[0]).to_string())
            .replace("{a}", &rng.below(bound[1]).to_string())
            .replace("{o}", &rng.below(bound[2]).to_string());
        let _ = writeln!(text, "{line}");
    }
    text
}

#[test]
fn crafted_sizes_load_or_are_refused_within_the_memory_limit() {
    limit_address_space(3 << 29);
    let dir = temp::TempPath::new("ceworld-pomdp-sizes", "x");
    let mut rng = Rng::new(seed());
    let (mut loaded, mut refused, mut slowest) = (0, 0, Duration::ZERO);
    let mut kinds = std::collections::BTreeMap::<&str, usize>::new();
    for case in 0..iterations() {
        let text = crafted(&mut rng);
        let path = dir.with_file_name(format!("case{case}.pomdp"));
        std::fs::write(&path, &text).unwrap();
        let started = Instant::now();
        let result = PomdpWorld::from_file(path.to_str().unwrap(), 10, None);
        let took = started.elapsed();
        if took > slowest {
            slowest = took;
            if std::env::var("SHOW").is_ok() {
                println!("case {case}: {took:?}\n{text}");
            }
        }
        // A hang guard, not a speed target: the largest files take well under a second.
        assert!(took < Duration::from_secs(30), "case {case} took {took:?}:\n{text}");
        match result {
            Ok(_) => loaded += 1,
            Err(e) => {
                refused += 1;
                let kind = match e {
                    Error::ModelFormat(_) => "format",
                    Error::Memory { .. } => "memory",
                    Error::InvalidArgument { .. } => "invalid",
                    other => panic!("case {case}: unexpected error {other}:\n{text}"),
                };
                *kinds.entry(kind).or_default() += 1;
            }
        }
        let _ = std::fs::remove_file(&path);
    }
    println!("{loaded} loaded, {refused} refused {kinds:?}, slowest {slowest:?}");
    assert!(loaded > 0 && refused > 0, "{loaded} loaded, {refused} refused");
}
