//! The loop over an optimiser's runs (its restarts), the one every optimiser runs on: each run
//! starts from the checkpoint's state or afresh; no later run starts once a budget is spent
//! ([`crate::ce::budget`]) or the caller stopped the search; the runs over are kept in the
//! checkpoint; the first run with the highest score is chosen. What a run does between its
//! start and its end is the optimiser's (`Runs::run`, on the iteration loop of
//! [`crate::ce::iterations`]).

use crate::ce::resume::{Resumable, Saver};
use crate::ce::stopping::StopReason;
use crate::error::{Error, Result};

/// A run in progress, as `K`'s checkpoints keep it.
pub type RunOf<K> = <K as Resumable>::Run;
/// A run over, as `K`'s checkpoints keep it.
pub type FinishedOf<K> = <K as Resumable>::Finished;

/// An optimiser's runs, as the loop over them drives them.
pub(crate) trait Runs {
    /// Its checkpoints.
    type Kind: Resumable;
    /// Whether a search of one run keeps it in progress once it is over, so that a resume
    /// with other stopping rules continues it (episode CE, the stepped optimisers); else it is
    /// kept over, as the runs of a search of several are (the controller search).
    const CONTINUED: bool = true;
    /// Runs run `restart` to its end, from the checkpoint's state `resume` where there is one,
    /// saving its checkpoints through `saver`: the run over (its stop [`StopReason::halted`]
    /// where the caller cut it: its state stays in the checkpoint, to be continued), or
    /// [`Error::Interrupted`] where it was cut before its first iteration ended.
    fn run(
        &mut self,
        restart: usize,
        resume: Option<RunOf<Self::Kind>>,
        saver: &mut Saver<'_, Self::Kind>,
    ) -> Result<FinishedOf<Self::Kind>>;
    /// Why a run stopped.
    fn stop(run: &FinishedOf<Self::Kind>) -> StopReason;
    /// Why no later run may start, if none may: a budget spent (checked before each run after
    /// the first; the first always runs).
    fn spent(&self, saver: &Saver<'_, Self::Kind>) -> Option<StopReason>;
    /// Whether the runs end after `run` though more were asked for (by default, never).
    fn last(&self, run: &FinishedOf<Self::Kind>) -> bool {
        let _ = run;
        false
    }
    /// Whether the caller asked to abort (nothing goes on, not even the choice among the runs
    /// over).
    fn aborted(&self) -> bool;
    /// The world's steps learning has taken so far (saved with the runs over).
    fn steps(&self) -> u64;
}

/// The runs of a search once the loop is over.
pub(crate) struct Chosen<F> {
    /// The run the checkpoint keeps in progress, if any: the one the caller cut, or the only
    /// run of a search of one ([`Runs::CONTINUED`]).
    pub open: Option<F>,
    /// Why the search ended before its runs were over, if it did.
    pub ended: Option<StopReason>,
}

impl<F> Chosen<F> {
    /// Every run, `finished` (the checkpoint's runs over) then the open one, and the index of
    /// the first with the highest `score` (what a run is worth in the choice: NaN least).
    pub fn all<'a>(&'a self, finished: &'a [F], score: impl Fn(&F) -> f64) -> (Vec<&'a F>, usize) {
        let runs: Vec<&F> = finished.iter().chain(self.open.as_ref()).collect();
        let best = runs.iter().enumerate().fold(0, |b, (i, r)| {
            let (s, t) = (score(r), score(runs[b]));
            if s > t || t.is_nan() { i } else { b }
        });
        (runs, best)
    }

    /// Why the search stopped: why it ended early, else why its last run stopped.
    pub fn stop(&self, finished: &[F], stop: impl Fn(&F) -> StopReason) -> StopReason {
        let last = self.open.as_ref().or(finished.last()).expect("at least one run");
        self.ended.unwrap_or_else(|| stop(last))
    }
}

/// Runs the `restarts` runs of `runs` (from the checkpoint in `saver`), until they are over, a
/// budget is spent, the caller stops them, or a run ends them.
pub(crate) fn over_runs<R: Runs>(
    runs: &mut R,
    restarts: usize,
    saver: &mut Saver<'_, R::Kind>,
) -> Result<Chosen<FinishedOf<R::Kind>>> {
    let mut chosen = Chosen { open: None, ended: None };
    while saver.state.restart < restarts {
        let restart = saver.state.restart;
        let resume = saver.state.run.take();
        if restart > 0
            && resume.is_none()
            && let Some(why) = runs.spent(saver)
        {
            chosen.ended = Some(why);
            break;
        }
        let run = match runs.run(restart, resume, saver) {
            // Cut before its first iteration: the runs over are what there is.
            Err(Error::Interrupted) if !saver.state.finished.is_empty() && !runs.aborted() => {
                chosen.ended = Some(StopReason::Interrupted);
                break;
            }
            run => run?,
        };
        if (restarts == 1 && R::CONTINUED) || R::stop(&run).halted() {
            chosen.open = Some(run);
            break;
        }
        let last = runs.last(&run);
        saver.state.finished.push(run);
        saver.state.restart += 1;
        saver.state.env_steps = runs.steps();
        saver.save(true);
        if last {
            break;
        }
    }
    Ok(chosen)
}
