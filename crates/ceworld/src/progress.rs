//! Progress of long runs on stderr, one renderer for the CLI and the Python module: on a
//! terminal, one live line rewritten in place (at most ten times a second); on a pipe or a file,
//! a plain line when the run starts and then every few seconds, never a carriage return or an
//! escape code.

use std::io::{IsTerminal, Write};
use std::time::{Duration, Instant};

use crate::ce::record::IterationRecord;

/// Seconds between two plain lines when stderr is not a terminal.
pub const PLAIN_EVERY: Duration = Duration::from_secs(5);
/// Time between two rewrites of the live line on a terminal.
pub const LIVE_EVERY: Duration = Duration::from_millis(100);

/// A line of progress on stderr, rewritten in place on a terminal, printed plainly elsewhere.
pub struct LiveLine {
    terminal: bool,
    last: Option<Instant>,
    pending: Option<String>,
    shown: bool,
}

impl LiveLine {
    /// A line on stderr, live when stderr is a terminal.
    pub fn stderr() -> LiveLine {
        LiveLine::new(std::io::stderr().is_terminal())
    }

    /// A line that is live (`terminal`) or plain.
    pub fn new(terminal: bool) -> LiveLine {
        LiveLine { terminal, last: None, pending: None, shown: false }
    }

    /// Offers the newest text; it is written if enough time has passed since the last one.
    pub fn update(&mut self, text: String) {
        self.pending = Some(text);
        let every = if self.terminal { LIVE_EVERY } else { PLAIN_EVERY };
        if self.last.is_none_or(|t| t.elapsed() >= every) {
            self.flush();
        }
    }

    /// Writes a line of its own (e.g. "restart 2 of 3"), after the pending text.
    pub fn note(&mut self, text: &str) {
        self.flush();
        if self.terminal && self.shown {
            eprintln!();
        }
        eprintln!("{text}");
        self.shown = false;
    }

    /// Writes the pending text and ends the line.
    pub fn finish(mut self) {
        self.flush();
        if self.terminal && self.shown {
            eprintln!();
        }
    }

    fn flush(&mut self) {
        if let Some(text) = self.pending.take() {
            self.last = Some(Instant::now());
            self.shown = true;
            let mut err = std::io::stderr().lock();
            let _ = if self.terminal { write!(err, "\r\x1b[K{text}") } else { writeln!(err, "{text}") };
            let _ = err.flush();
        }
    }
}

/// The progress of a CE optimisation: iteration, mean, elite threshold, best mean so far and
/// the iterations without gain against the patience.
pub struct CeProgress {
    line: LiveLine,
    patience: usize,
    best: (f64, usize),
    since: usize,
}

impl CeProgress {
    /// Progress of a run with `patience` on `line`.
    pub fn new(patience: usize, line: LiveLine) -> CeProgress {
        CeProgress { line, patience, best: (f64::NEG_INFINITY, 0), since: 0 }
    }

    /// Takes one iteration's record (a new restart starts the counts afresh).
    pub fn update(&mut self, r: &IterationRecord) {
        if r.iteration == 0 {
            self.best = (f64::NEG_INFINITY, 0);
            self.since = 0;
        }
        if r.successful {
            self.best = (r.mean, r.iteration);
            self.since = 0;
        } else {
            self.since += 1;
        }
        let text = self.text(r);
        self.line.update(text);
    }

    /// The line for `r` given the best iteration so far.
    pub fn text(&self, r: &IterationRecord) -> String {
        format!(
            "iter {:>5}  mean {:>7.2}  elite>= {:>6.1}  best mean {:>7.2} (iter {})  no gain {:>3}/{}  {:>6.1}s",
            r.iteration, r.mean, r.elite_threshold, self.best.0, self.best.1, self.since, self.patience, r.seconds
        )
    }

    /// A line of its own (e.g. "restart 2 of 3").
    pub fn note(&mut self, text: &str) {
        self.line.note(text);
    }

    /// Writes the last iteration's line and ends it.
    pub fn finish(self) {
        self.line.finish();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn record(iteration: usize, mean: f64, successful: bool) -> IterationRecord {
        IterationRecord {
            iteration,
            mean,
            best: mean,
            elite_threshold: mean,
            elite_mean: mean,
            seconds: 0.5,
            successful,
        }
    }

    #[test]
    fn the_line_names_the_best_iteration_and_the_iterations_without_gain() {
        let mut p = CeProgress::new(100, LiveLine::new(false));
        p.update(&record(0, 1.0, true));
        p.update(&record(1, 3.0, true));
        p.update(&record(2, 2.0, false));
        let text = p.text(&record(3, 2.5, false));
        assert!(text.contains("best mean    3.00 (iter 1)") && text.contains("no gain   1/100"), "{text}");
        assert!(!text.contains('\r') && !text.contains('\x1b'));
    }

    #[test]
    fn a_restart_starts_the_counts_afresh() {
        let mut p = CeProgress::new(10, LiveLine::new(false));
        p.update(&record(0, 5.0, true));
        p.update(&record(1, 4.0, false));
        p.update(&record(0, 1.0, true));
        assert!(p.text(&record(1, 0.5, false)).contains("best mean    1.00 (iter 0)"));
    }
}
