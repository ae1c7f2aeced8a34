//! Progress of long runs on stderr, one renderer for the CLI and the Python module: on a
//! terminal, one live line rewritten in place (at most ten times a second); on a pipe or a file,
//! a plain line when the run starts and then every few seconds, never a carriage return or an
//! escape code.

use std::io::{IsTerminal, Write};
use std::time::{Duration, Instant};

use crate::ce::controller::ControllerIteration;
use crate::ce::record::IterationRecord;
use crate::evaluate::Evaluation;
use crate::qlearn::{WindowReport, percent};

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

/// What the progress line shows of one iteration, for every optimiser: its record, the score
/// its result is chosen by, and what else it shows.
pub trait Step {
    /// The iteration's statistics (`iteration` is 0 again at each restart).
    fn record(&self) -> &IterationRecord;
    /// The score the result is chosen by, as of this iteration (its maximum over the run so
    /// far is the line's "best").
    fn score(&self) -> f64;
    /// What `score` is, in a few words ("best mean", "best value").
    fn score_name(&self) -> &'static str;
    /// What else this optimiser shows, at the end of the line (empty: nothing).
    fn detail(&self) -> String {
        String::new()
    }
}

/// The progress of an optimisation: iteration, mean, elite threshold, the best score so far
/// and its iteration, the iterations without gain against the patience, the seconds; a line of
/// its own at each restart.
pub struct Progress {
    line: LiveLine,
    patience: usize,
    restarts: usize,
    runs: usize,
    best: (f64, usize),
    since: usize,
}

impl Progress {
    /// Progress of a run with `patience` and `restarts` runs (0: as many as a time limit
    /// allows) on `line`.
    pub fn new(patience: usize, restarts: usize, line: LiveLine) -> Progress {
        Progress { line, patience, restarts, runs: 0, best: (f64::NEG_INFINITY, 0), since: 0 }
    }

    /// Takes one iteration's record (a new run starts the counts afresh).
    pub fn update(&mut self, step: &impl Step) {
        let r = step.record();
        if r.iteration == 0 {
            self.runs += 1;
            if self.runs > 1 {
                // 0 runs: as many as the time limit allows.
                let of = if self.restarts == 0 { String::new() } else { format!(" of {}", self.restarts) };
                self.line.note(&format!("restart {}{of}", self.runs));
            }
            self.best = (f64::NEG_INFINITY, 0);
            self.since = 0;
        }
        if step.score() > self.best.0 {
            self.best = (step.score(), r.iteration);
        }
        self.since = if r.successful { 0 } else { self.since + 1 };
        let text = self.text(step);
        self.line.update(text);
    }

    /// The line for `r` given the best iteration so far.
    pub fn text(&self, step: &impl Step) -> String {
        let (r, detail) = (step.record(), step.detail());
        // The world's steps learning has taken, where it takes any (not on exact values).
        let steps = if r.env_steps > 0 { format!("  {} steps", steps(r.env_steps)) } else { String::new() };
        format!(
            "iter {:>5}  mean {:>9.3}  elite>= {:>9.3}  {} {:>9.3} (iter {})  no gain {:>3}/{}  {:>6.1}s{steps}{}{detail}",
            r.iteration,
            r.mean,
            r.elite_threshold,
            step.score_name(),
            self.best.0,
            self.best.1,
            self.since,
            self.patience,
            r.seconds,
            if detail.is_empty() { "" } else { "  " },
        )
    }

    /// Writes the last iteration's line and ends it.
    pub fn finish(self) {
        self.line.finish();
    }
}

impl Step for IterationRecord {
    fn record(&self) -> &IterationRecord {
        self
    }
    fn score(&self) -> f64 {
        self.mean
    }
    fn score_name(&self) -> &'static str {
        "best mean"
    }
}

impl Step for ControllerIteration {
    fn record(&self) -> &IterationRecord {
        &self.record
    }
    fn score(&self) -> f64 {
        self.best_so_far
    }
    fn score_name(&self) -> &'static str {
        "best value"
    }
    fn detail(&self) -> String {
        let escape = match (self.injected, self.grown) {
            (true, _) => "  escape: injection",
            (_, true) => "  escape: growth",
            _ => "",
        };
        format!("concentration {:.3}{escape}", self.concentration)
    }
}

/// A count of steps in a few characters: `950`, `12.3k`, `4.56M`, `7.89G`.
pub fn steps(n: u64) -> String {
    let x = n as f64;
    match n {
        0..1_000 => n.to_string(),
        1_000..1_000_000 => format!("{:.1}k", x / 1e3),
        1_000_000..1_000_000_000 => format!("{:.2}M", x / 1e6),
        _ => format!("{:.2}G", x / 1e9),
    }
}

/// Decimals that show an estimate to the precision of its standard error `se` (two significant
/// digits of it, at most 12); 3 where it is 0 or not finite (an exact or a single value).
pub fn decimals(se: f64) -> usize {
    if !(se.is_finite() && se > 0.0) {
        return 3;
    }
    (1.0 - se.log10().floor()).clamp(0.0, 12.0) as usize
}

/// `x` with `decimals` decimals.
pub fn fixed(x: f64, decimals: usize) -> String {
    format!("{x:.decimals$}")
}

/// An evaluation in a line (`Evaluation(...)` in Python shows it): every figure to the
/// precision of the standard error.
pub fn evaluation(e: &Evaluation) -> String {
    let median = e.quantiles.iter().find(|(q, _)| *q == 0.5).map_or(f64::NAN, |&(_, v)| v);
    let f = |x: f64| fixed(x, decimals(e.std_error));
    format!(
        "mean={} ± {}, episodes={}, std={}, min={}, max={}, median={}",
        f(e.mean),
        f(e.std_error),
        e.episodes,
        f(e.std),
        f(e.min),
        f(e.max),
        f(median)
    )
}

/// Windows of a policy's runs in a line, in % of `reference` (`WindowEvaluation(...)`).
pub fn windows(report: &WindowReport, reference: f64) -> String {
    let p = |e: &Evaluation| (percent(e.min, reference), percent(e.mean, reference), percent(e.max, reference));
    let (a, b) = (p(&report.from_start), p(&report.continuing));
    format!(
        "from_start: worst/mean/best {:.0}/{:.0}/{:.0} % over {} windows; continuing: {:.0}/{:.0}/{:.0} % over {} \
         windows; of {reference}",
        a.0, a.1, a.2, report.from_start.episodes, b.0, b.1, b.2, report.continuing.episodes
    )
}

#[cfg(test)]
mod tests {
    #[test]
    fn estimates_are_shown_to_two_significant_digits_of_their_standard_error() {
        assert_eq!((decimals(0.49), decimals(0.081), decimals(3.2), decimals(45.0)), (2, 3, 1, 0));
        assert_eq!((decimals(0.0), decimals(f64::NAN), decimals(1e-300)), (3, 3, 12));
        assert_eq!(fixed(-1.114_641_921_751_159, decimals(0.0112)), "-1.115");
    }

    use super::*;
    use crate::ce::record::IterationRecord;

    fn record(iteration: usize, mean: f64, successful: bool) -> IterationRecord {
        IterationRecord {
            iteration,
            mean,
            best: mean,
            elite_threshold: mean,
            elite_mean: mean,
            seconds: 0.5,
            successful,
            env_steps: 0,
        }
    }

    #[test]
    fn the_line_names_the_best_iteration_and_the_iterations_without_gain() {
        let mut p = Progress::new(100, 1, LiveLine::new(false));
        p.update(&record(0, 1.0, true));
        p.update(&record(1, 3.0, true));
        p.update(&record(2, 2.0, false));
        let text = p.text(&record(3, 2.5, false));
        assert!(text.contains("best mean     3.000 (iter 1)") && text.contains("no gain   1/100"), "{text}");
        assert!(!text.contains('\r') && !text.contains('\x1b'));
    }

    #[test]
    fn the_line_shows_the_world_s_steps_where_learning_takes_any() {
        let p = Progress::new(100, 1, LiveLine::new(false));
        assert!(!p.text(&record(0, 1.0, true)).contains("steps"));
        let taken = IterationRecord { env_steps: 1_234_567, ..record(0, 1.0, true) };
        assert!(p.text(&taken).contains("s  1.23M steps"), "{}", p.text(&taken));
        let shown: Vec<String> = [999, 12_345, 4_560_000, 7_890_000_000].into_iter().map(steps).collect();
        assert_eq!(shown, ["999", "12.3k", "4.56M", "7.89G"]);
    }

    #[test]
    fn a_restart_starts_the_counts_afresh() {
        let mut p = Progress::new(10, 2, LiveLine::new(false));
        p.update(&record(0, 5.0, true));
        p.update(&record(1, 4.0, false));
        p.update(&record(0, 1.0, true));
        assert_eq!(p.runs, 2);
        assert!(p.text(&record(1, 0.5, false)).contains("best mean     1.000 (iter 0)"));
    }
}
