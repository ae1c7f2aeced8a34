//! What a run of the command line writes, every optimiser alike: the policy (`--out`), its
//! per-iteration history (`--history`, JSON lines or CSV), its checkpoints, and whether it may
//! replace files that exist (`--force`). Every path is checked before the run starts; an
//! existing result is never replaced silently.

use std::path::{Path, PathBuf};

use serde::Serialize;
use serde_json::Value;

use crate::ce::resume::{Checkpoint, Peek, Resumable};
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
    /// Refuses, before the run, an output that cannot be written, that is the same file as an
    /// input (`inputs`: `(option, path)`) or as another output, or that would replace a file
    /// unasked (an existing --out or --history is replaced with --force, or by the resume of
    /// the run that wrote them, which its checkpoint records), and a history file of an unknown
    /// kind; warns of a checkpoint resumed unverified. `K` is the optimiser whose checkpoint
    /// --checkpoint names.
    pub fn check<K: Resumable>(&self, inputs: &[(&str, &Path)]) -> Result<()> {
        self.check_peeked(inputs, Checkpoint::<K>::peek)
    }

    /// [`OutputArgs::check`], the checkpoint read by `peek`.
    pub fn check_peeked(&self, inputs: &[(&str, &Path)], peek: fn(&Path) -> Result<Peek>) -> Result<()> {
        let checkpoint = self.checkpoint.checkpoint.as_deref();
        let resumed = match checkpoint {
            Some(path) if self.checkpoint.resuming() => Some(peek(path)?),
            _ => None,
        };
        let mut outputs = vec![("--out", self.out.as_path())];
        outputs.extend(self.history.as_deref().map(|h| ("--history", h)));
        outputs.extend(checkpoint.map(|c| ("--checkpoint", c)));
        crate::files::check_distinct(inputs, &outputs)?;
        for (option, path) in [("--out", Some(&self.out)), ("--history", self.history.as_ref())] {
            let Some(path) = path else { continue };
            let recorded = resumed.as_ref().is_some_and(|r| r.outputs.contains(&crate::files::resolved(path)));
            if !self.force && !recorded {
                let how = match (&resumed, checkpoint) {
                    (Some(_), Some(c)) => {
                        format!("not an output of the run that wrote {}: give --force", c.display())
                    }
                    _ => "give --force".into(),
                };
                crate::files::check_new(option, path, &how)?;
            }
            crate::files::check_writable(option, path)?;
        }
        if let Some(path) = &self.history {
            history_format(path)?;
        }
        if let Some(warning) = resumed.and_then(|r| r.unverified) {
            eprintln!("{}: warning: {warning}", crate::cli::program());
        }
        Ok(())
    }

    /// The checkpoints asked for, checked, recording this run's outputs; says when a run
    /// resumes (unless --quiet).
    pub fn checkpointing(&self) -> Result<Option<crate::Checkpointing>> {
        let mut outputs = vec![self.out.clone()];
        outputs.extend(self.history.clone());
        self.checkpoint.checkpointing(self.quiet, outputs)
    }

    /// How a run of the command line is watched: progress unless --quiet, `checkpointing`, and
    /// a stop on SIGINT or SIGTERM.
    pub fn run_options<'a>(&self, checkpointing: Option<&'a crate::Checkpointing>) -> crate::run::RunOptions<'a> {
        crate::run::RunOptions { progress: !self.quiet, checkpointing, stop: &crate::cli::stop::flow, callback: None }
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
