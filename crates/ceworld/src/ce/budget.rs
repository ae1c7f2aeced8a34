//! What a call to an optimiser may spend, whatever the optimiser: seconds and the world's steps.
//! Each budget has one meaning, written here once; every optimiser's config holds a [`Budget`]
//! (flattened: its settings keep their names on the command line, in Python, in checkpoints and
//! in policy files), and every optimiser counts the world's steps through a [`Metered`] world.

use std::sync::atomic::{AtomicU64, Ordering};

use serde::{Deserialize, Serialize};
use serde_json::Value;

use crate::ce::stopping::StopReason;
use crate::control::Interrupt;
use crate::episodes::credit::StepCredit;
use crate::episodes::{Batch, Episodes, Remote, Shape, Streams};
use crate::error::{Error, Result};
use crate::policy::Hhmm;
use crate::policy::controller::Controller;
use crate::settings::Setting;
use crate::world::pomdp::PomdpWorld;

/// The budgets of a call, by the optimiser's config (SB3's `total_timesteps` is
/// `max_env_steps`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "cli", derive(clap::Args))]
pub struct Budget {
    /// Stop after this many seconds, every run and every session together, the final
    /// evaluation included: the iterations stop early by what the closing evaluations would
    /// take (at most half the limit), and an evaluation that does not fit is cut at the limit,
    /// with fewer episodes. Checked between iterations, and inside one where the optimiser can
    /// cut it (the controller search: between controllers on exact values, between groups of
    /// episodes on sampled ones).
    #[cfg_attr(feature = "cli", arg(long))]
    pub time_limit: Option<f64>,
    /// Stop once learning has taken this many of the world's steps (the steps of the episodes
    /// sampled to learn, every run and every session together; the final evaluation's are counted
    /// apart). An iteration that would cross it is cut where the steps left run out ([`Groups`];
    /// and so is a run's score between restarts), so the count passes it by one batch at most (the
    /// result says so: stop `max_env_steps`); the controller search and the model search keep the
    /// steps of their selection, and stop short of it where the steps left no longer cover one. The
    /// count is the same for any thread or worker count. Refused on a world valued exactly (it
    /// takes no steps).
    #[cfg_attr(feature = "cli", arg(long))]
    pub max_env_steps: Option<u64>,
}

impl Budget {
    /// The names of its settings.
    pub const NAMES: [&'static str; 2] = ["time_limit", "max_env_steps"];

    /// A time limit of `seconds` alone.
    pub fn seconds(seconds: f64) -> Budget {
        Budget { time_limit: Some(seconds), max_env_steps: None }
    }

    /// A budget of `steps` of the world alone.
    pub fn steps(steps: u64) -> Budget {
        Budget { time_limit: None, max_env_steps: Some(steps) }
    }

    /// Sets the budget `s.name` (one of [`Budget::NAMES`]).
    pub fn set(&mut self, s: &Setting<'_>) -> Result<()> {
        match s.name {
            "time_limit" => self.time_limit = s.optional_real()?,
            "max_env_steps" => self.max_env_steps = s.optional_count()?.map(|n| n as u64),
            other => return Err(Error::Internal(format!("{other:?} is not a budget"))),
        }
        Ok(())
    }

    /// Refuses a budget out of its domain, naming it.
    pub fn validate(&self) -> Result<()> {
        if let Some(t) = self.time_limit
            && !(t > 0.0 && t.is_finite())
        {
            return Err(Error::invalid("time_limit", format!("{t} (expected a positive number of seconds)")));
        }
        if self.max_env_steps == Some(0) {
            return Err(Error::invalid("max_env_steps", "0 (expected at least 1 step, or none)"));
        }
        Ok(())
    }

    /// Refuses a budget in steps where the values are exact (no step is taken to learn).
    pub fn check_sampled(&self, what: &str) -> Result<()> {
        match self.max_env_steps {
            Some(n) => Err(Error::invalid(
                "max_env_steps",
                format!(
                    "{n} on {what} (expected none: exact values take no step of the world; use time_limit or max_iterations)"
                ),
            )),
            None => Ok(()),
        }
    }

    /// Whether `steps` of the world spend the budget in steps.
    pub fn spent(&self, steps: u64) -> bool {
        self.max_env_steps.is_some_and(|m| steps >= m)
    }

    /// The steps of the world the budget in steps leaves after `steps` (`None` without one).
    pub fn left(&self, steps: u64) -> Option<u64> {
        self.max_env_steps.map(|m| m.saturating_sub(steps))
    }

    /// Which budget `seconds` and `steps` have spent, if one is: the time limit first.
    pub fn exhausted(&self, seconds: f64, steps: u64) -> Option<StopReason> {
        if self.time_limit.is_some_and(|t| seconds >= t) {
            Some(StopReason::TimeLimit)
        } else {
            self.spent(steps).then_some(StopReason::MaxEnvSteps)
        }
    }
}

/// About how many episodes an iteration runs between two looks at a budget in steps, where the
/// steps left do not bound it first ([`Groups`]).
pub const CUT_EPISODES: usize = 256;

/// About how many episodes the controller searches value in one group of controllers, where the
/// steps left do not bound it ([`Groups`]): between two groups the time limit and a budget in
/// steps may cut an iteration.
pub const GROUP_EPISODES: usize = 1024;

/// The groups in which an iteration runs its episodes: `runs` runs of `episodes` episodes each (a
/// controller's, or one episode of a policy), a group whole batches of the world (the least one
/// holds), at most `full` runs. Between two groups a spent budget cuts the iteration, and under a
/// budget in steps a group holds no more runs than the steps left cover, foreseen from the mean
/// length of the iteration's episodes so far (before any, the world's horizon): the count passes
/// the budget by one batch at most, as foreseen. The first group always runs. The groups depend on
/// the steps alone, not on threads or workers.
pub struct Groups {
    /// Runs in one batch of the world.
    unit: usize,
    /// Runs in a group where the steps left do not bound it.
    full: usize,
    episodes: usize,
    horizon: usize,
    runs: usize,
    /// Runs handed out so far.
    next: usize,
    /// Steps the groups handed out took.
    steps: u64,
}

impl Groups {
    /// The groups of `runs` runs of `episodes` episodes on a world that runs `batch` episodes
    /// together and whose episodes last `horizon` steps at most, `full` episodes a group at most
    /// (whole batches, one at least).
    pub fn new(runs: usize, episodes: usize, batch: usize, full: usize, horizon: usize) -> Groups {
        let (batch, episodes) = (batch.max(1), episodes.max(1));
        let unit = if episodes <= batch { batch / episodes } else { 1 };
        let full = unit * full.div_ceil(unit * episodes).max(1);
        Groups { unit, full, episodes, horizon, runs, next: 0, steps: 0 }
    }

    /// The runs of the next group, or `None` where the iteration is over: every run handed out,
    /// or, after the first group, no step `left` to learn (`None`: no budget in steps).
    pub fn next(&mut self, left: Option<u64>) -> Option<std::ops::Range<usize>> {
        if self.next >= self.runs {
            return None;
        }
        let mut size = self.full;
        if let Some(left) = left {
            if left == 0 && self.next > 0 {
                return None;
            }
            // The runs the steps left cover, the last one partly.
            let covered = left.div_ceil(self.foreseen(self.episodes).max(1));
            let covered = usize::try_from(covered).unwrap_or(usize::MAX);
            size = size.min(covered.div_ceil(self.unit).max(1).saturating_mul(self.unit));
        }
        let end = self.runs.min(self.next + size);
        let group = self.next..end;
        self.next = end;
        Some(group)
    }

    /// Counts the steps the last group took.
    pub fn took(&mut self, steps: u64) {
        self.steps += steps;
    }

    /// The episodes of each of `runs` runs that `left` steps cover, as foreseen
    /// ([`Groups::foreseen`]): `most` at most, one at least; `most` without a budget in steps.
    pub fn covered(&self, left: Option<u64>, runs: usize, most: usize) -> usize {
        let Some(left) = left else { return most };
        let each = self.foreseen(runs).max(1);
        usize::try_from(left / each).unwrap_or(usize::MAX).min(most).max(1)
    }

    /// The steps `episodes` episodes are foreseen to take: the mean length of the episodes run
    /// so far, or the horizon before any.
    pub fn foreseen(&self, episodes: usize) -> u64 {
        let run = (self.next * self.episodes) as u64;
        if run == 0 { (episodes * self.horizon) as u64 } else { (episodes as u64 * self.steps).div_ceil(run) }
    }
}

/// A world whose steps are counted: every optimiser samples its episodes to learn through one,
/// so that the count is the engine's (worlds in Python, Gymnasium's and a backend's workers
/// included) and the same for any thread or worker count. A backend's replay of the elite to
/// count it is not counted again: its episodes are those already counted.
pub struct Metered<'a, E: ?Sized> {
    episodes: &'a E,
    steps: AtomicU64,
}

impl<'a, E: Episodes + ?Sized> Metered<'a, E> {
    /// `episodes`, its count starting at `steps` (the steps of the sessions before).
    pub fn new(episodes: &'a E, steps: u64) -> Self {
        Metered { episodes, steps: AtomicU64::new(steps) }
    }

    /// The steps counted so far.
    pub fn steps(&self) -> u64 {
        self.steps.load(Ordering::Relaxed)
    }

    /// Sets the count back to `steps` (where an iteration cut by an interrupt is dropped: a
    /// resumed run draws it again).
    pub fn reset(&self, steps: u64) {
        self.steps.store(steps, Ordering::Relaxed);
    }

    /// The world counted.
    pub fn inner(&self) -> &'a E {
        self.episodes
    }

    fn add(&self, steps: u64) -> u64 {
        self.steps.fetch_add(steps, Ordering::Relaxed);
        steps
    }
}

/// What counts a world's steps, whatever the world ([`Metered`]).
pub trait Meter: Sync {
    /// The steps counted so far.
    fn steps(&self) -> u64;
    /// Sets the count back to `steps` (an iteration cut by an interrupt is dropped).
    fn reset(&self, steps: u64);
}

impl<E: Episodes + ?Sized> Meter for Metered<'_, E> {
    fn steps(&self) -> u64 {
        Metered::steps(self)
    }

    fn reset(&self, steps: u64) {
        Metered::reset(self, steps);
    }
}

impl<E: Episodes + ?Sized> Episodes for Metered<'_, E> {
    fn shape(&self) -> Shape {
        self.episodes.shape()
    }

    fn additive(&self) -> bool {
        self.episodes.additive()
    }

    fn description(&self) -> Value {
        self.episodes.description()
    }

    fn run(&self, policy: &Hhmm, streams: Streams, first: usize, batch: Batch<'_>) -> Result<u64> {
        self.episodes.run(policy, streams, first, batch).map(|s| self.add(s))
    }

    fn run_controllers(
        &self,
        controllers: &[Controller],
        streams: Streams,
        episodes: usize,
        values: &mut [f64],
    ) -> Result<u64> {
        self.episodes.run_controllers(controllers, streams, episodes, values).map(|s| self.add(s))
    }

    fn run_controllers_credited(
        &self,
        controllers: &[Controller],
        streams: Streams,
        episodes: usize,
        values: &mut [f64],
        credit: &mut StepCredit,
    ) -> Result<(u64, bool)> {
        let (steps, credited) =
            self.episodes.run_controllers_credited(controllers, streams, episodes, values, credit)?;
        Ok((self.add(steps), credited))
    }

    fn interrupt(&self) -> Option<&Interrupt> {
        self.episodes.interrupt()
    }

    fn slice(&self) -> usize {
        self.episodes.slice()
    }

    fn batch(&self) -> usize {
        self.episodes.batch()
    }

    fn remote(&self) -> Option<&dyn Remote> {
        self.episodes.remote()
    }

    fn tabular(&self) -> Option<&PomdpWorld> {
        self.episodes.tabular()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::settings::Given;

    #[test]
    fn budgets_are_set_by_name_and_refused_out_of_their_domain() {
        let mut b = Budget::default();
        let set = |b: &mut Budget, name, value| b.set(&Setting { name, value, shown: String::new() });
        set(&mut b, "max_env_steps", Given::Int(5000)).unwrap();
        set(&mut b, "time_limit", Given::Real(2.5)).unwrap();
        assert_eq!(b, Budget { time_limit: Some(2.5), max_env_steps: Some(5000) });
        assert!(b.validate().is_ok() && !b.spent(4999) && b.spent(5000) && !Budget::default().spent(u64::MAX));
        assert_eq!([b.left(4999), b.left(6000), Budget::default().left(7)], [Some(1), Some(0), None]);
        for bad in [Budget::steps(0), Budget::seconds(0.0), Budget::seconds(f64::INFINITY), Budget::seconds(f64::NAN)] {
            assert!(bad.validate().is_err(), "{bad:?}");
        }
        let e = Budget::steps(10).check_sampled("exact values").unwrap_err().to_string();
        assert!(e.contains("max_env_steps") && e.contains("10 on exact values"), "{e}");
        assert!(Budget::seconds(1.0).check_sampled("exact values").is_ok());
        let both = Budget { time_limit: Some(2.0), max_env_steps: Some(10) };
        let exhausted = [(1.0, 9), (2.0, 10), (1.0, 10)].map(|(t, n)| both.exhausted(t, n));
        assert_eq!(exhausted, [None, Some(StopReason::TimeLimit), Some(StopReason::MaxEnvSteps)]);
    }

    /// Hands out every group of `groups`, each run taking `length` steps an episode, under a
    /// budget of `budget` steps: the groups' sizes and the steps taken.
    fn hand_out(mut groups: Groups, budget: Option<u64>, length: u64) -> (Vec<usize>, u64) {
        let (mut sizes, mut steps) = (Vec::new(), 0);
        while let Some(g) = groups.next(budget.map(|b| b.saturating_sub(steps))) {
            let took = (g.len() * groups.episodes) as u64 * length;
            sizes.push(g.len());
            groups.took(took);
            steps += took;
        }
        (sizes, steps)
    }

    #[test]
    fn groups_are_whole_batches_and_the_steps_left_bound_them() {
        // Controllers of 20 episodes on a world that runs its episodes one by one: groups of
        // 1024 episodes (52 controllers) without a budget in steps.
        let groups = || Groups::new(200, 20, 1, 1024, 50);
        assert_eq!(hand_out(groups(), None, 10), (vec![52, 52, 52, 44], 200 * 20 * 10));
        // 5,000 steps: the first group is foreseen at the horizon (50 steps an episode: 5
        // controllers), the next at the mean length (10: 20 controllers cover the 4,000 steps
        // left).
        assert_eq!(hand_out(groups(), Some(5000), 10), (vec![5, 20], 5000));
        // A budget spent before the iteration: its first group is one batch.
        assert_eq!(hand_out(groups(), Some(0), 10), (vec![1], 200));
        // Episodes 7 steps long: the last group covers the steps left partly (the count passes
        // the budget by less than a batch).
        let (sizes, steps) = hand_out(groups(), Some(5000), 7);
        assert!((5000..5000 + 20 * 7).contains(&steps), "{sizes:?} {steps}");
        // A world that runs 64 episodes together: a batch is 3 controllers, and every group is
        // whole batches.
        let (sizes, _) = hand_out(Groups::new(200, 20, 64, 1024, 50), Some(5000), 7);
        assert!(sizes[..sizes.len() - 1].iter().all(|s| s % 3 == 0), "{sizes:?}");
        // Episodes one by one (episode CE), on a world of batch 100: 256 episodes are 300.
        let (sizes, _) = hand_out(Groups::new(1000, 1, 100, CUT_EPISODES, 50), None, 10);
        assert_eq!(sizes, vec![300, 300, 300, 100]);
        // The episodes each of 4 runs may have: 50 steps foreseen an episode before any ran.
        let g = Groups::new(10, 20, 1, 1024, 50);
        assert_eq!([g.covered(None, 4, 200), g.covered(Some(2000), 4, 200), g.covered(Some(10), 4, 200)], [200, 10, 1]);
    }
}
