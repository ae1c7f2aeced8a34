//! Helpers shared by the CLI tests.

use std::process::Command;

/// Starts `ceworld ARGS`, waits for its first line on stderr (printed once its Ctrl-C handler is
/// installed: a readiness signal, not a guess at how long start-up takes), sends SIGINT, and
/// returns (exit status, stdout, stderr).
#[cfg(unix)]
pub fn interrupt_when_ready(args: &[&str]) -> (std::process::ExitStatus, String, String) {
    signal_when_ready("-INT", args)
}

/// As [`interrupt_when_ready`], with the signal `signal` (as `kill` takes it: `-TERM`, ...).
pub fn signal_when_ready(signal: &str, args: &[&str]) -> (std::process::ExitStatus, String, String) {
    act_when_ready(args, |pid| {
        let status = Command::new("kill").args([signal, &pid.to_string()]).status().unwrap();
        assert!(status.success());
    })
}

/// Starts `ceworld ARGS`, waits for its first line on stderr, calls `act` with its process id,
/// and returns (exit status, stdout, stderr).
pub fn act_when_ready(args: &[&str], act: impl FnOnce(u32)) -> (std::process::ExitStatus, String, String) {
    use std::io::{BufRead, Read};
    let mut child = Command::new(env!("CARGO_BIN_EXE_ceworld"))
        .args(args)
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let mut stderr = std::io::BufReader::new(child.stderr.take().unwrap());
    let mut first = Vec::new();
    stderr.read_until(b'\n', &mut first).unwrap();
    assert!(first.ends_with(b"\n"), "no start line: {}", String::from_utf8_lossy(&first));
    act(child.id());
    let mut rest = String::new();
    stderr.read_to_string(&mut rest).unwrap();
    let mut stdout = String::new();
    child.stdout.take().unwrap().read_to_string(&mut stdout).unwrap();
    let status = child.wait().unwrap();
    (status, stdout, String::from_utf8_lossy(&first).into_owned() + &rest)
}
