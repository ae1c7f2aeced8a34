//! CE checkpoints (issue "trust"): a run stopped at any iteration and resumed from its checkpoint
//! ends with the policy of the uninterrupted run, bit for bit, with one run or several; a
//! checkpoint of another world or other settings is refused (damaged files: `readers_fuzz.rs`).

#[path = "common/temp.rs"]
mod temp;

use ceworld::{
    CeCheckpoint, CeConfig, CeResult, Checkpointing, Error, Flow, MemoryUpdate, StopReason, TargetTracking,
    TrackingParams, optimize, optimize_with, random_policy,
};

fn temp(name: &str) -> temp::TempPath {
    temp::TempPath::new("ceworld-checkpoint", name)
}

fn world() -> TargetTracking {
    TargetTracking::with_params(TrackingParams { horizon: 20, ..Default::default() }).unwrap()
}

fn config() -> CeConfig {
    CeConfig {
        samples: 200,
        rho: 0.1,
        smoothing: 0.5,
        max_iterations: Some(12),
        eval_episodes: 200,
        ..CeConfig::default()
    }
}

fn uninterrupted(config: &CeConfig) -> CeResult {
    let w = world();
    optimize(&w, random_policy(&w, &[4, 3], 1).unwrap(), config, |_| Flow::Continue).unwrap()
}

/// Runs with a checkpoint, stopping after `stops` observed iterations (counted over every
/// session), resuming until done; returns the final result and the number of sessions.
fn in_sessions(config: &CeConfig, path: &std::path::Path, stops: &[usize]) -> (CeResult, usize) {
    let w = world();
    let checkpointing = Checkpointing { path: path.to_path_buf(), every: 1e9, resume: true, outputs: Vec::new() };
    let mut seen = 0;
    let mut sessions = 0;
    loop {
        sessions += 1;
        let result = optimize_with(&w, random_policy(&w, &[4, 3], 1).unwrap(), config, Some(&checkpointing), |_| {
            seen += 1;
            if stops.contains(&seen) { Flow::Stop } else { Flow::Continue }
        })
        .unwrap();
        if !result.interrupted() {
            return (result, sessions);
        }
    }
}

fn assert_same(a: &CeResult, b: &CeResult) {
    assert_eq!(a.policy, b.policy, "best policy");
    assert_eq!(a.last_policy, b.last_policy, "last policy");
    assert_eq!(a.best_iteration, b.best_iteration);
    assert_eq!(a.stop, b.stop);
    assert_eq!(a.evaluation, b.evaluation);
    assert_eq!(a.restart, b.restart);
    assert_eq!(a.restart_scores, b.restart_scores);
    let means = |r: &CeResult| r.history.iter().map(|h| (h.mean.to_bits(), h.successful)).collect::<Vec<_>>();
    assert_eq!(means(a), means(b));
}

#[test]
fn a_resumed_run_ends_as_the_uninterrupted_one() {
    let config = config();
    let reference = uninterrupted(&config);
    assert_eq!(reference.stop, StopReason::MaxIterations);
    for stops in [vec![1], vec![5], vec![3, 7, 11], vec![12]] {
        let path = temp(&format!("single-{stops:?}.ckpt"));
        let (resumed, sessions) = in_sessions(&config, &path, &stops);
        assert_eq!(sessions, stops.len() + 1);
        assert_same(&resumed, &reference);
    }
}

#[test]
fn a_run_stopped_where_it_would_have_stopped_anyway_ends_at_once() {
    // Patience 2 from a uniform start: the stop at the iteration where patience runs out must
    // not buy an extra iteration on resume.
    let config = CeConfig { patience: 2, max_iterations: Some(40), ..config() };
    let reference = uninterrupted(&config);
    assert_eq!(reference.stop, StopReason::Patience);
    let last = reference.history.len();
    let path = temp("patience.ckpt");
    let (resumed, _) = in_sessions(&config, &path, &[last]);
    assert_same(&resumed, &reference);
}

#[test]
fn restarts_resume_inside_any_run() {
    let config = CeConfig { restarts: 3, max_iterations: Some(5), ..config() };
    let reference = uninterrupted(&config);
    assert_eq!(reference.restart_scores.len(), 3);
    // Iterations are counted over all runs: 3 is inside run 0, 5 its last, 8 inside run 1, 15 the very last.
    for stops in [vec![3], vec![5], vec![8], vec![2, 6, 11], vec![15]] {
        let path = temp(&format!("restarts-{stops:?}.ckpt"));
        let (resumed, _) = in_sessions(&config, &path, &stops);
        assert_same(&resumed, &reference);
    }
}

#[test]
fn forward_backward_runs_resume_too() {
    let config = CeConfig { memory_update: MemoryUpdate::ForwardBackward, max_iterations: Some(6), ..config() };
    let reference = uninterrupted(&config);
    let (resumed, _) = in_sessions(&config, &temp("fb.ckpt"), &[2, 4]);
    assert_same(&resumed, &reference);
}

#[test]
fn a_checkpoint_of_other_settings_or_another_world_is_refused() {
    let config = config();
    let path = temp("mismatch.ckpt");
    in_sessions(&config, &path, &[3]);
    let w = world();
    let resume = Checkpointing { path: path.to_path_buf(), every: 60.0, resume: true, outputs: Vec::new() };
    let run = |w: &TargetTracking, config: &CeConfig, levels: &[usize]| {
        optimize_with(w, random_policy(w, levels, 1).unwrap(), config, Some(&resume), |_| Flow::Continue)
    };
    let e = run(&w, &CeConfig { seed: 9, ..config.clone() }, &[4, 3]).unwrap_err();
    assert!(matches!(&e, Error::CheckpointMismatch(m) if m.contains("seed 0, not 9")), "{e}");
    let e = run(&w, &CeConfig { rho: 0.2, ..config.clone() }, &[4, 3]).unwrap_err();
    assert!(matches!(&e, Error::CheckpointMismatch(m) if m.contains("rho")), "{e}");
    let other = TargetTracking::with_params(TrackingParams { horizon: 21, ..Default::default() }).unwrap();
    let e = run(&other, &config, &[4, 3]).unwrap_err();
    assert!(matches!(&e, Error::CheckpointMismatch(m) if m.contains("world")), "{e}");
    let e = run(&w, &config, &[4, 4]).unwrap_err();
    assert!(matches!(&e, Error::CheckpointMismatch(m) if m.contains("levels")), "{e}");
    // Stopping rules and the time limit may change: here a longer run.
    let longer = CeConfig { max_iterations: Some(14), ..config.clone() };
    assert_eq!(run(&w, &longer, &[4, 3]).unwrap().history.len(), 14);
    // Without resume the file is overwritten by a fresh run.
    let fresh = Checkpointing { resume: false, ..resume.clone() };
    let r =
        optimize_with(&w, random_policy(&w, &[4, 3], 1).unwrap(), &config, Some(&fresh), |_| Flow::Continue).unwrap();
    assert_same(&r, &uninterrupted(&config));
    let bad = Checkpointing { every: 0.0, ..resume.clone() };
    let e =
        optimize_with(&w, random_policy(&w, &[4, 3], 1).unwrap(), &config, Some(&bad), |_| Flow::Continue).unwrap_err();
    assert!(matches!(&e, Error::InvalidArgument { name, .. } if name == "checkpoint_every"), "{e}");
}

/// A change made to a checkpoint's JSON.
type Edit = fn(&mut serde_json::Value);

#[test]
fn a_checkpoint_of_the_version_before_digests_resumes_unverified_and_says_so() {
    let path = temp("old.ckpt");
    let w = world();
    let config = CeConfig { max_iterations: Some(6), ..config() };
    let mut doc = stopped_after(&config, &path, 3);
    assert_eq!(CeCheckpoint::peek(&path).unwrap().unverified, None, "a file of this version is verified");
    assert_eq!(doc["version"], 2);
    doc.as_object_mut().unwrap().remove("digest");
    doc["version"] = 1.into();
    std::fs::write(&*path, serde_json::to_vec(&doc).unwrap()).unwrap();
    let warning = CeCheckpoint::peek(&path).unwrap().unverified.expect("an unverified file is named");
    assert!(warning.contains("version 1") && warning.contains("unverified"), "{warning}");
    let checkpointing = Checkpointing { path: path.to_path_buf(), every: 1e9, resume: true, outputs: Vec::new() };
    let resumed =
        optimize_with(&w, random_policy(&w, &[4, 3], 1).unwrap(), &config, Some(&checkpointing), |_| Flow::Continue)
            .unwrap();
    assert_same(&resumed, &uninterrupted(&config));
    doc["version"] = 0.into();
    std::fs::write(&*path, serde_json::to_vec(&doc).unwrap()).unwrap();
    let e = CeCheckpoint::peek(&path).unwrap_err().to_string();
    assert!(e.contains("version 0 (expected 1 to 2)"), "{e}");
}

/// The checkpoint of a run of `config` stopped after `stops` observed iterations, as JSON.
fn stopped_after(config: &CeConfig, path: &std::path::Path, stops: usize) -> serde_json::Value {
    let w = world();
    let checkpointing = Checkpointing { path: path.to_path_buf(), every: 1e9, resume: true, outputs: Vec::new() };
    let mut seen = 0;
    let out = optimize_with(&w, random_policy(&w, &[4, 3], 1).unwrap(), config, Some(&checkpointing), |_| {
        seen += 1;
        if seen == stops { Flow::Stop } else { Flow::Continue }
    })
    .unwrap();
    assert!(out.interrupted());
    serde_json::from_slice(&std::fs::read(path).unwrap()).unwrap()
}

/// A checkpoint stopped in the second of two runs, as JSON.
fn stopped_in_the_second_run(path: &std::path::Path) -> serde_json::Value {
    stopped_after(&CeConfig { restarts: 2, max_iterations: Some(5), ..config() }, path, 8)
}

#[test]
fn a_tampered_checkpoint_is_refused_by_what_is_inconsistent() {
    let path = temp("tampered.ckpt");
    let saved = stopped_in_the_second_run(&path);
    assert_eq!((saved["restart"].as_u64(), saved["run"]["history"].as_array().map(Vec::len)), (Some(1), Some(3)));
    let w = world();
    let config = CeConfig { restarts: 2, max_iterations: Some(5), ..config() };
    let checkpointing = Checkpointing { path: path.to_path_buf(), every: 1e9, resume: true, outputs: Vec::new() };
    let edits: [(&str, Edit, &str); 8] = [
        ("the run index", |c| c["restart"] = 5.into(), "run 5"),
        ("a finished run dropped", |c| c["finished"] = serde_json::json!([]), "runs finished"),
        ("an iteration dropped", |c| drop(c["run"]["history"].as_array_mut().unwrap().remove(0)), "iteration"),
        ("the best iteration", |c| c["run"]["best"]["iteration"] = 99.into(), "best iteration 99"),
        ("the unsuccessful count", |c| c["run"]["unsuccessful"] = 50.into(), "50 unsuccessful"),
        ("a success flag", |c| c["run"]["history"][0]["successful"] = false.into(), "marked successful"),
        ("the seconds", |c| c["seconds"] = (-1.0).into(), "seconds -1"),
        ("a finished run's best", |c| c["finished"][0]["result"]["best_iteration"] = 77.into(), "best iteration 77"),
    ];
    // A file changed since it was written no longer matches its digest, whatever changed.
    let mut c = saved.clone();
    c["seconds"] = 12345.0.into();
    std::fs::write(&*path, serde_json::to_vec(&c).unwrap()).unwrap();
    match optimize_with(&w, random_policy(&w, &[4, 3], 1).unwrap(), &config, Some(&checkpointing), |_| Flow::Continue) {
        Err(Error::CheckpointFormat { message, .. }) => {
            assert!(message.contains("does not match its digest"), "{message}");
        }
        other => panic!("a changed file: {other:?}"),
    }
    // A file of the current version stripped of its digest is refused, whatever else it holds.
    let mut c = saved.clone();
    c.as_object_mut().unwrap().remove("digest").expect("a digest");
    std::fs::write(&*path, serde_json::to_vec(&c).unwrap()).unwrap();
    match optimize_with(&w, random_policy(&w, &[4, 3], 1).unwrap(), &config, Some(&checkpointing), |_| Flow::Continue) {
        Err(Error::CheckpointFormat { message, .. }) => assert!(message.contains("has no \"digest\""), "{message}"),
        other => panic!("a file without its digest: {other:?}"),
    }
    // A file of the version before digests were required (read, unverified), or one whose
    // digest was made again: the state itself is checked.
    for (what, edit, needle) in edits {
        let mut c = saved.clone();
        c.as_object_mut().unwrap().remove("digest").expect("a digest");
        c["version"] = 1.into();
        edit(&mut c);
        std::fs::write(&*path, serde_json::to_vec(&c).unwrap()).unwrap();
        match optimize_with(&w, random_policy(&w, &[4, 3], 1).unwrap(), &config, Some(&checkpointing), |_| {
            Flow::Continue
        }) {
            Err(Error::CheckpointFormat { message, .. }) => assert!(message.contains(needle), "{what}: {message}"),
            other => panic!("{what}: {other:?}"),
        }
    }
    // The runs yet to start would start from another policy: refused.
    std::fs::write(&*path, serde_json::to_vec(&saved).unwrap()).unwrap();
    let other = random_policy(&w, &[4, 3], 2).unwrap();
    match optimize_with(&w, other, &config, Some(&checkpointing), |_| Flow::Continue) {
        Err(Error::CheckpointMismatch(message)) => assert!(message.contains("initial policy"), "{message}"),
        other => panic!("another initial policy: {other:?}"),
    }
    // The file as saved still resumes.
    assert!(
        optimize_with(&w, random_policy(&w, &[4, 3], 1).unwrap(), &config, Some(&checkpointing), |_| Flow::Continue)
            .is_ok()
    );
}
