//! What a run of the command line writes, every optimiser alike: the policy (`--out`), its
//! per-iteration history (`--history`, JSON lines or CSV), its checkpoints, and whether it may
//! replace files that exist (`--force`). Every path is checked before the run starts; an
//! existing result is never replaced silently.

use std::path::{Path, PathBuf};

use serde::Serialize;
use serde_json::Value;

use crate::cli::CheckpointArgs;
use crate::error::{Error, Result};
use crate::policy::file::PolicyFile;

/// The files a run writes.
#[derive(clap::Args)]
pub(crate) struct OutputArgs {
    /// Where to save the result (a policy file, model §6). An existing file is not replaced
    /// unless --force is given (or --resume continues the run that wrote it).
    #[arg(long, default_value = "policy.json", value_name = "FILE.json")]
    pub out: PathBuf,
    /// Also save the run's history, one record per iteration (mean, best, elite threshold,
    /// elite mean, seconds, ...): JSON lines for FILE.jsonl, CSV for FILE.csv (`cehmm plot`
    /// draws either).
    #[arg(long, value_name = "FILE.jsonl|FILE.csv")]
    pub history: Option<PathBuf>,
    /// Replace --out and --history when they exist.
    #[arg(long)]
    pub force: bool,
    #[command(flatten)]
    pub checkpoint: CheckpointArgs,
    /// No progress line.
    #[arg(long, short)]
    pub quiet: bool,
}

/// How a history file is written, from its name.
#[derive(Clone, Copy, PartialEq, Eq)]
enum HistoryFormat {
    JsonLines,
    Csv,
}

impl OutputArgs {
    /// Refuses, before the run, an output that cannot be written or would replace a file
    /// unasked, and a history file of an unknown kind.
    pub fn check(&self) -> Result<()> {
        let resuming = self.checkpoint.resuming();
        for (option, path) in [("--out", Some(&self.out)), ("--history", self.history.as_ref())] {
            let Some(path) = path else { continue };
            // A resumed run replaces what its earlier sessions wrote.
            if path.exists() && !self.force && !resuming {
                return Err(Error::invalid(
                    option,
                    format!("{} exists (give --force to replace it, or another name)", path.display()),
                ));
            }
            crate::files::check_writable(path)?;
        }
        if let Some(path) = &self.history {
            history_format(path)?;
        }
        Ok(())
    }

    /// Saves a run's result: the policy `file` to --out, its `history` to --history if given,
    /// and a warning where its last checkpoint could not be written (`checkpoint_error`).
    pub fn save<T: Serialize>(&self, file: &PolicyFile, history: &[T], checkpoint_error: Option<&str>) -> Result<()> {
        file.save(&self.out)?;
        self.write_history(history)?;
        warn_checkpoint(checkpoint_error, &self.out);
        Ok(())
    }

    /// Writes `records` to --history, if given (through a temporary file renamed over it).
    fn write_history<T: Serialize>(&self, records: &[T]) -> Result<()> {
        let Some(path) = &self.history else { return Ok(()) };
        let rows: Vec<Value> = records.iter().map(|r| serde_json::to_value(r).unwrap_or(Value::Null)).collect();
        let text = match history_format(path)? {
            HistoryFormat::JsonLines => rows.iter().fold(String::new(), |mut text, r| {
                text += &r.to_string();
                text.push('\n');
                text
            }),
            HistoryFormat::Csv => csv(&rows),
        };
        crate::files::write_atomic(path, |out| std::io::Write::write_all(out, text.as_bytes()))
    }
}

/// Tells that the last checkpoint could not be written (the run went on, its result is in `out`).
pub(crate) fn warn_checkpoint(error: Option<&str>, out: &Path) {
    if let Some(error) = error {
        eprintln!(
            "warning: {} and its result is saved in {}",
            crate::ce::resume::checkpoint_warning(error),
            out.display()
        );
    }
}

fn history_format(path: &Path) -> Result<HistoryFormat> {
    match path.extension().and_then(|e| e.to_str()) {
        Some("jsonl") => Ok(HistoryFormat::JsonLines),
        Some("csv") => Ok(HistoryFormat::Csv),
        _ => Err(Error::invalid("--history", format!("{} (expected a name ending in .jsonl or .csv)", path.display()))),
    }
}

/// Flat records as CSV: a header of the first record's keys (in its order), then one line each.
fn csv(rows: &[Value]) -> String {
    let Some(Value::Object(first)) = rows.first() else { return String::new() };
    let keys: Vec<&String> = first.keys().collect();
    let mut text = keys.iter().map(|k| k.as_str()).collect::<Vec<_>>().join(",") + "\n";
    for row in rows {
        let cells: Vec<String> = keys
            .iter()
            .map(|k| match row.get(k.as_str()) {
                Some(Value::String(s)) => format!("\"{}\"", s.replace('"', "\"\"")),
                Some(Value::Null) | None => String::new(),
                Some(v) => v.to_string(),
            })
            .collect();
        text += &cells.join(",");
        text.push('\n');
    }
    text
}
