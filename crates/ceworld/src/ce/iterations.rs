//! The loop over a run's iterations, the one every optimiser runs on: it runs the optimiser's
//! iteration (`Iterations::iterate`), shows its record to the observer (which may stop the
//! run), keeps what the closing evaluations will take of the time limit, applies the budgets
//! and the optimiser's own stop rules, and saves the run's state when due. An iteration cut by
//! an interrupt is dropped, its steps with it: the run's state is the one after the last whole
//! iteration, which a resume continues bit for bit.

use std::time::Instant;

use crate::ce::budget::{Budget, Meter};
use crate::ce::resume::{Resumable, Saver};
use crate::ce::runs::RunOf;
use crate::ce::stopping::{Observed, StopReason};
use crate::control::{Flow, Interrupt};
use crate::error::{Error, Result};
use crate::evaluate::closing_reserve;
use crate::policy::Hhmm;

/// A run's iterations, as the loop over them drives them.
pub(crate) trait Iterations {
    /// Its checkpoints (the run's state is their [`Resumable::Run`]).
    type Kind: Resumable;
    /// An iteration's record (its history entry).
    type Record;

    /// Whether `run` has an iteration behind it (a run cut before has nothing to keep).
    fn started(run: &RunOf<Self::Kind>) -> bool;
    /// The stop rule that holds for a resumed `run` (that of its last iteration: the same as
    /// before with the same settings; other stopping rules may let it go on), if any.
    fn resumed(&self, run: &RunOf<Self::Kind>) -> Option<StopReason>;
    /// Runs the next iteration of `run`, `reserve` seconds of the time limit kept for the
    /// closing evaluations as the last iteration ran: its record, also in `run`'s history.
    /// On an error `run` is left as it was.
    fn iterate(&mut self, run: &mut RunOf<Self::Kind>, reserve: f64) -> Result<Self::Record>;
    /// The best policy of `run` so far (made when asked: a copy of its tables).
    fn best(&self, run: &RunOf<Self::Kind>) -> Result<Hhmm>;
    /// The optimiser's own stop rule after iteration `record` of `run`, `reserve` seconds kept,
    /// if one holds.
    fn stop(&self, run: &RunOf<Self::Kind>, record: &Self::Record, reserve: f64) -> Option<StopReason>;
    /// The episodes iteration `record` ran and those the closing evaluations will run, from
    /// which the reserve is foreseen; `None` where nothing is kept (exact values).
    fn closing(&self, record: &Self::Record) -> Option<(usize, usize)>;
    /// `run` as the checkpoint keeps it.
    fn snapshot(&self, run: &RunOf<Self::Kind>) -> RunOf<Self::Kind> {
        run.clone()
    }
}

/// Where a run's iterations stand among the call's, and what limits them from outside.
pub(crate) struct Watch<'a> {
    /// The run among the restarts (from 0).
    pub run: usize,
    /// The iterations of the call's runs before this one.
    pub earlier: usize,
    /// The call's budgets.
    pub budget: &'a Budget,
    /// The world's steps learning has taken.
    pub meter: &'a dyn Meter,
    /// What may stop the run from outside.
    pub interrupt: Option<&'a Interrupt>,
    /// The seconds kept for the closing evaluations before the run's first iteration (as the
    /// last iteration of an earlier run ran; 0 for none).
    pub reserve: f64,
}

/// How a run's iterations ended.
pub(crate) struct Ended<R> {
    /// The run's state after its last whole iteration.
    pub run: R,
    /// Why it stopped.
    pub stop: StopReason,
    /// The seconds kept for the closing evaluations, as its last iteration ran.
    pub reserve: f64,
}

/// Runs the iterations of `run` until the observer, an interrupt, a budget or a stop rule of
/// `it` stops them; [`Error::Interrupted`] where it was cut before its first iteration.
pub(crate) fn iterate_run<I: Iterations>(
    it: &mut I,
    mut run: RunOf<I::Kind>,
    saver: &mut Saver<'_, I::Kind>,
    observe: &mut dyn FnMut(&Observed<'_, I::Record>) -> Flow,
    watch: &Watch<'_>,
) -> Result<Ended<RunOf<I::Kind>>> {
    let spent = || watch.budget.spent(watch.meter.steps()).then_some(StopReason::MaxEnvSteps);
    let mut stop = if I::started(&run) { spent().or_else(|| it.resumed(&run)) } else { None };
    let mut reserve = watch.reserve;
    while stop.is_none() {
        let (started, steps_before) = (Instant::now(), watch.meter.steps());
        let record = match it.iterate(&mut run, reserve) {
            Ok(record) => record,
            Err(Error::Interrupted) => {
                // Cut by an interrupt: the iteration is dropped (a resumed run draws it again).
                watch.meter.reset(steps_before);
                stop = Some(StopReason::Interrupted);
                if I::started(&run) {
                    saver.save_run(true, || it.snapshot(&run));
                }
                break;
            }
            Err(e) => return Err(e),
        };
        let best = || it.best(&run);
        let flow = observe(&Observed { step: &record, best: &best, run: watch.run, earlier: watch.earlier });
        if let Some((episodes, closing)) = it.closing(&record) {
            let per_episode = started.elapsed().as_secs_f64() / episodes.max(1) as f64;
            reserve = closing_reserve(watch.budget.time_limit, per_episode, closing);
        }
        let interrupted = watch.interrupt.is_some_and(Interrupt::stopping).then_some(StopReason::Interrupted);
        stop = interrupted.or(StopReason::asked(flow)).or_else(spent).or_else(|| it.stop(&run, &record, reserve));
        saver.state.env_steps = watch.meter.steps();
        saver.save_run(stop.is_some(), || it.snapshot(&run));
    }
    if !I::started(&run) {
        return Err(Error::Interrupted);
    }
    Ok(Ended { run, stop: stop.expect("the loop ends with a reason"), reserve })
}
