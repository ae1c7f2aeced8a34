//! Credit within episodes for the decisions of controllers (model §8): where an episode's value
//! is the discounted sum of its steps' rewards, the decision of step `t` can change only the
//! part still to come, `V − (r_1 + γ r_2 + … + γ^{t−2} r_{t−1})`. Summed per decision row
//! (the node of a Moore machine, the node and observation of a Mealy machine) it tells which
//! decision pays in that row, from every step of every controller's episodes rather than from
//! a ranking of whole controllers.

use crate::episodes::trace::Traces;
use crate::error::{Error, Result};
use crate::policy::controller::Controller;

/// The credit of the decision rows of a set of controllers (all of one shape): for controller
/// `c` and its row `r`, the steps that decided in that row (`visits[c·rows + r]`) and the sum
/// over them of the value still to come (`sums[c·rows + r]`).
#[derive(Clone, Debug, PartialEq)]
pub struct StepCredit {
    /// Decision rows per controller.
    pub rows: usize,
    /// Steps per (controller, row).
    pub visits: Vec<u32>,
    /// Summed value still to come per (controller, row).
    pub sums: Vec<f64>,
    /// Where kept, every episode's steps ([`Traces`]): what a learner of memory from every step
    /// asks for ([`StepCredit::traced`]).
    pub traces: Option<Traces>,
}

impl StepCredit {
    /// No credit yet for `controllers` controllers of `rows` decision rows.
    pub fn new(controllers: usize, rows: usize) -> StepCredit {
        StepCredit { rows, visits: vec![0; controllers * rows], sums: vec![0.0; controllers * rows], traces: None }
    }

    /// [`StepCredit::new`], keeping every episode's steps too; of 0 rows, the steps alone (no
    /// credit is counted: what a learner that reads only the steps asks for).
    pub fn traced(controllers: usize, rows: usize) -> StepCredit {
        StepCredit { traces: Some(Traces::default()), ..StepCredit::new(controllers, rows) }
    }

    /// The decision rows of `c` ([`Controller::decisions`]).
    pub fn rows_of(c: &Controller) -> usize {
        c.decisions().len()
    }

    /// Adds episode `episode` of controller `c` (index `index` in the set), of value `value`:
    /// its steps' (observation, reward), the rewards discounted by `gamma`. The nodes are the
    /// controller's own (an explorer's draws change its decisions, not its nodes): they are run
    /// again here.
    #[allow(clippy::too_many_arguments)]
    pub fn add(
        &mut self,
        index: usize,
        episode: u64,
        c: &Controller,
        n_obs: usize,
        steps: impl Iterator<Item = (usize, f64)> + Clone,
        gamma: f64,
        value: f64,
    ) {
        if let Some(traces) = self.traces.as_mut() {
            traces.gamma = gamma;
            traces.add(c, n_obs, episode, steps.clone());
        }
        if self.rows == 0 {
            return;
        }
        let base = index * self.rows;
        to_come(c, n_obs, steps, gamma, value, |_, row, credit| {
            self.visits[base + row] += 1;
            self.sums[base + row] += credit;
        });
    }

    /// Numbers per controller of [`StepCredit::to_blocks`]: whether credited, the values of its
    /// `episodes` episodes, its rows' visits, their sums.
    pub fn block(episodes: usize, rows: usize) -> usize {
        1 + episodes + 2 * rows
    }

    /// Values and credit as one list of numbers, controller after controller
    /// ([`StepCredit::block`]): what a backend's worker answers (model §9).
    pub fn to_blocks(&self, credited: bool, values: &[f64], episodes: usize) -> Vec<f64> {
        let rows = self.rows;
        let mut out = Vec::with_capacity(values.len() / episodes.max(1) * StepCredit::block(episodes, rows));
        for (c, v) in values.chunks(episodes).enumerate() {
            out.push(f64::from(u8::from(credited)));
            out.extend_from_slice(v);
            out.extend(self.visits[c * rows..(c + 1) * rows].iter().map(|&n| f64::from(n)));
            out.extend_from_slice(&self.sums[c * rows..(c + 1) * rows]);
        }
        out
    }

    /// Reads [`StepCredit::to_blocks`]'s numbers into `values` and adds their credit to this;
    /// whether every controller was credited.
    pub fn add_blocks(&mut self, blocks: &[f64], values: &mut [f64], episodes: usize) -> bool {
        let rows = self.rows;
        let mut credited = true;
        for (c, b) in blocks.chunks(StepCredit::block(episodes, rows)).enumerate() {
            credited &= b[0] == 1.0;
            values[c * episodes..(c + 1) * episodes].copy_from_slice(&b[1..=episodes]);
            for r in 0..rows {
                self.visits[c * rows + r] += b[1 + episodes + r] as u32;
                self.sums[c * rows + r] += b[1 + episodes + rows + r];
            }
        }
        credited
    }

    /// Values and every kept step as one list of numbers, episode after episode (episode `k` of
    /// controller `c` at `c·episodes + k`, as `values`): its value, 1.0 where credited (else 0.0),
    /// the discount, its length `L`, its `L` observations, its `L` rewards. What a backend's
    /// worker answers where the learner keeps steps (model §10); the decisions are the
    /// controllers' own, taken again where the numbers are read ([`StepCredit::add_steps`]).
    pub fn to_steps(&self, credited: bool, values: &[f64]) -> Vec<f64> {
        let traces = self.traces.as_ref().filter(|t| credited && t.ends.len() == values.len());
        let mut ranges = traces.map(Traces::episodes);
        let mut out = Vec::with_capacity(4 * values.len() + 2 * traces.map_or(0, Traces::steps));
        let gamma = traces.map_or(1.0, |t| t.gamma);
        for &value in values {
            let range = ranges.as_mut().and_then(Iterator::next).unwrap_or(0..0);
            out.extend([value, f64::from(u8::from(traces.is_some())), gamma, range.len() as f64]);
            if let Some(t) = traces {
                out.extend(t.obs[range.clone()].iter().map(|&y| f64::from(y)));
                out.extend_from_slice(&t.rew[range]);
            }
        }
        out
    }

    /// Reads [`StepCredit::to_steps`]'s numbers of `controllers`' episodes (`episodes` each)
    /// into `values` and adds each credited episode's steps to this, as run here; whether every
    /// episode was credited. Numbers that are not such records are refused.
    pub fn add_steps(
        &mut self,
        numbers: &[f64],
        controllers: &[Controller],
        n_obs: usize,
        values: &mut [f64],
        episodes: usize,
    ) -> Result<bool> {
        let bad = |why: String| Error::World(format!("the steps a backend's worker gave: {why}"));
        let (mut at, mut credited) = (0, true);
        for (i, value) in values.iter_mut().enumerate() {
            let Some(&[v, flag, gamma, length]) = numbers.get(at..at + 4) else {
                return Err(bad(format!("{} numbers end within episode {i}'s record", numbers.len())));
            };
            let n = length as usize;
            if length.fract() != 0.0 || !(0.0..=(numbers.len() - at) as f64).contains(&length) {
                return Err(bad(format!("episode {i} of {length} steps (expected a whole number that fits)")));
            }
            let (obs, rew) = match numbers.get(at + 4..at + 4 + 2 * n) {
                Some(steps) => steps.split_at(n),
                None => return Err(bad(format!("episode {i}'s {n} steps run past the {} numbers", numbers.len()))),
            };
            if let Some(y) = obs.iter().find(|&&y| !(y.fract() == 0.0 && y >= 0.0 && y < n_obs as f64)) {
                return Err(bad(format!("observation {y} (expected a whole number below {n_obs})")));
            }
            *value = v;
            credited &= flag == 1.0;
            if flag == 1.0 {
                let c = &controllers[i / episodes];
                let steps = obs.iter().map(|&y| y as usize).zip(rew.iter().copied());
                self.add(i / episodes, (i % episodes) as u64, c, n_obs, steps, gamma, v);
            }
            at += 4 + 2 * n;
        }
        if at != numbers.len() {
            return Err(bad(format!("{} numbers after the {} episodes' records", numbers.len() - at, values.len())));
        }
        Ok(credited)
    }

    /// `other`'s controllers after these.
    pub fn append(&mut self, other: StepCredit) {
        debug_assert_eq!(self.rows, other.rows);
        self.visits.extend(other.visits);
        self.sums.extend(other.sums);
        if let (Some(traces), Some(more)) = (self.traces.as_mut(), other.traces) {
            traces.append(more);
        }
    }

    /// For each decision row, the decision whose steps had the highest mean credit over all
    /// `controllers` (those these credits are of, in order; `decisions` reads a controller's
    /// decision rows) among the `n_actions` decisions; `None` where no step decided in the row.
    /// Equal means keep the lower decision.
    pub fn best<'c>(
        &self,
        controllers: impl Iterator<Item = (usize, &'c [u32])>,
        n_actions: usize,
    ) -> Vec<Option<u32>> {
        let mut visits = vec![0u64; self.rows * n_actions];
        let mut sums = vec![0.0; self.rows * n_actions];
        for (c, decisions) in controllers {
            for (r, &a) in decisions.iter().enumerate() {
                let at = r * n_actions + a as usize;
                visits[at] += u64::from(self.visits[c * self.rows + r]);
                sums[at] += self.sums[c * self.rows + r];
            }
        }
        best_means(&visits, &sums, n_actions)
    }

    /// [`StepCredit::best`] over the decisions the steps took: for each decision row of `c`, the
    /// decision of highest mean credit over `episodes` of `traces` (episodes of `c`'s machine,
    /// whose decisions an explorer's draws changed, [`crate::policy::controller::Explore`]).
    pub fn best_taken(
        c: &Controller,
        traces: &Traces,
        episodes: impl Iterator<Item = std::ops::Range<usize>>,
        n_obs: usize,
        n_actions: usize,
    ) -> Vec<Option<u32>> {
        let rows = StepCredit::rows_of(c);
        let mut visits = vec![0u64; rows * n_actions];
        let mut sums = vec![0.0; rows * n_actions];
        for episode in episodes {
            let steps = episode.clone().map(|t| (traces.obs[t] as usize, traces.rew[t]));
            let value = steps.clone().rev().fold(0.0, |ahead, (_, r)| r + traces.gamma * ahead);
            to_come(c, n_obs, steps, traces.gamma, value, |i, row, credit| {
                let at = row * n_actions + traces.dec[episode.start + i] as usize;
                visits[at] += 1;
                sums[at] += credit;
            });
        }
        best_means(&visits, &sums, n_actions)
    }
}

/// Runs `c`'s machine through an episode of value `value` (its steps' (observation, reward), the
/// rewards discounted by `gamma`) and calls `credit(step, row, value still to come)` at each step.
fn to_come(
    c: &Controller,
    n_obs: usize,
    steps: impl Iterator<Item = (usize, f64)>,
    gamma: f64,
    value: f64,
    mut credit: impl FnMut(usize, usize, f64),
) {
    let (mut node, mut before, mut factor) = (0u32, 0.0, 1.0);
    for (i, (y, r)) in steps.enumerate() {
        let from = node as usize;
        c.step(&mut node, y, n_obs);
        // A Mealy machine decides in the node it left, a Moore machine in the one it enters.
        let row = if c.is_mealy() { from * n_obs + y } else { node as usize };
        credit(i, row, value - before);
        before += factor * r;
        factor *= gamma;
    }
}

/// For each row of `visits` and `sums` (`n_actions` columns), the decision of highest mean, the
/// lower of equals; `None` where none was visited.
fn best_means(visits: &[u64], sums: &[f64], n_actions: usize) -> Vec<Option<u32>> {
    (0..visits.len() / n_actions.max(1))
        .map(|r| {
            let mean = |a: usize| sums[r * n_actions + a] / visits[r * n_actions + a] as f64;
            let visited = (0..n_actions).filter(|&a| visits[r * n_actions + a] > 0);
            visited
                .fold(None, |b: Option<usize>, a| if b.is_none_or(|b| mean(a) > mean(b)) { Some(a) } else { b })
                .map(|a| a as u32)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_step_is_credited_with_what_is_still_to_come_in_its_row() {
        // Two observations; a Mealy machine that moves to node y after y: node 0 on y = 1
        // (row 1), then node 1 on y = 0 (row 2), then node 0 on y = 1 (row 1) again.
        let c = Controller::mealy(vec![0, 1, 1, 0], vec![0, 1, 0, 1], 2);
        let mut credit = StepCredit::new(2, StepCredit::rows_of(&c));
        let rewards = [1.0, 2.0, 4.0];
        let value = 1.0 + 0.5 * 2.0 + 0.25 * 4.0;
        credit.add(1, 0, &c, 2, [1, 0, 1].into_iter().zip(rewards), 0.5, value);
        assert_eq!(credit.visits, vec![0, 0, 0, 0, 0, 2, 1, 0]);
        // Row 1: the whole value (3), then what the last step still pays (3 − 1 − 1); row 2: 3 − 1.
        assert_eq!(credit.sums, vec![0.0, 0.0, 0.0, 0.0, 0.0, 4.0, 2.0, 0.0]);
        // A Moore machine's row is the node it moves to: 0 → 1 → 0 on these observations.
        let moore = Controller::moore(vec![0, 1], vec![1, 0, 0, 1]);
        let mut credit = StepCredit::new(1, StepCredit::rows_of(&moore));
        credit.add(0, 0, &moore, 2, [(0, 1.0), (0, 1.0)].into_iter(), 1.0, 2.0);
        assert_eq!((credit.visits, credit.sums), (vec![1, 1], vec![1.0, 2.0]));
    }

    #[test]
    fn the_best_decision_of_a_row_has_the_highest_mean_over_every_controller() {
        // Three controllers of two rows, three decisions: row 0 decided 1, 1, 2 (means 2 and
        // 3, so 2); row 1 decided 0, 0, 0 (1 visit), and never visited by the third.
        let credit = StepCredit {
            rows: 2,
            visits: vec![2, 1, 2, 0, 1, 0],
            sums: vec![4.0, 1.0, 4.0, 0.0, 3.0, 0.0],
            traces: None,
        };
        let decisions: [&[u32]; 3] = [&[1, 0], &[1, 0], &[2, 0]];
        assert_eq!(credit.best(decisions.into_iter().enumerate(), 3), vec![Some(2), Some(0)]);
        let mut two = StepCredit::new(1, 2);
        two.append(StepCredit { rows: 2, visits: vec![0, 0], sums: vec![0.0, 0.0], traces: None });
        assert_eq!(two.best([&[0, 1][..], &[1, 1]].into_iter().enumerate(), 2), vec![None, None]);
        assert_eq!(two.visits.len(), 4);
    }

    #[test]
    fn kept_steps_travel_as_numbers_and_come_back_as_run_here() {
        // Two controllers of two episodes, traced here.
        let echo = Controller::mealy(vec![0, 1, 1, 0], vec![0, 1, 0, 1], 2);
        // The second an explorer: its draws are taken again where the numbers are read.
        let explore = Some(crate::policy::controller::Explore { rate: 0.5, actions: 2, key: 7 });
        let hold = Controller { explore, ..Controller::moore(vec![1], vec![0, 0]) };
        let controllers = [echo.clone(), hold.clone()];
        let episodes: [(usize, Vec<(usize, f64)>); 4] =
            [(0, vec![(1, 1.0), (0, 2.0)]), (0, vec![(0, -1.0)]), (1, vec![]), (1, vec![(1, 0.5), (1, 0.5), (0, 4.0)])];
        let mut here = StepCredit::traced(2, 4);
        let mut values = [0.0; 4];
        for (i, (c, steps)) in episodes.iter().enumerate() {
            values[i] = steps.iter().map(|s| s.1).sum::<f64>() + i as f64;
            here.add(*c, (i % 2) as u64, &controllers[*c], 2, steps.iter().copied(), 0.9, values[i]);
        }
        let numbers = here.to_steps(true, &values);
        assert_eq!(numbers.len(), 4 * 4 + 2 * 6);
        assert_eq!(&numbers[..8], &[values[0], 1.0, 0.9, 2.0, 1.0, 0.0, 1.0, 2.0]);
        let (mut there, mut read) = (StepCredit::traced(2, 4), [0.0; 4]);
        assert!(there.add_steps(&numbers, &controllers, 2, &mut read, 2).unwrap());
        assert_eq!((there, read), (here.clone(), values));
        // Not credited: the values only.
        let plain = here.to_steps(false, &values);
        let mut none = StepCredit::traced(2, 4);
        assert!(!none.add_steps(&plain, &controllers, 2, &mut read, 2).unwrap());
        assert_eq!((none.visits.iter().sum::<u32>(), none.traces.unwrap().steps()), (0, 0));
        // Records that are not whole, or observations out of range, are refused.
        let mut bad = StepCredit::traced(2, 4);
        let refused = |numbers: &[f64], bad: &mut StepCredit| {
            bad.add_steps(numbers, &controllers, 2, &mut [0.0; 4], 2).unwrap_err().to_string()
        };
        assert!(refused(&numbers[..numbers.len() - 1], &mut bad).contains("run past"));
        let mut far = numbers.clone();
        far[4] = 2.0;
        assert!(refused(&far, &mut bad).contains("observation 2"));
        let mut more = numbers.clone();
        more.push(0.0);
        assert!(refused(&more, &mut bad).contains("1 numbers after"));
        let mut half = numbers.clone();
        half[3] = 1.5;
        assert!(refused(&half, &mut bad).contains("1.5 steps"));
    }

    #[test]
    fn values_and_credit_travel_as_blocks_and_come_back_the_same() {
        let credit = StepCredit { rows: 2, visits: vec![1, 2, 3, 4], sums: vec![0.5, -1.0, 2.5, 0.0], traces: None };
        let values = [1.0, 2.0, 3.0, 4.0, 5.0, 6.0];
        let blocks = credit.to_blocks(true, &values, 3);
        assert_eq!(blocks.len(), 2 * StepCredit::block(3, 2));
        assert_eq!(&blocks[..8], &[1.0, 1.0, 2.0, 3.0, 1.0, 2.0, 0.5, -1.0]);
        let (mut back, mut read) = (StepCredit::new(2, 2), [0.0; 6]);
        assert!(back.add_blocks(&blocks, &mut read, 3));
        assert_eq!((back, read), (credit.clone(), values));
        assert!(!StepCredit::new(2, 2).add_blocks(&credit.to_blocks(false, &values, 3), &mut read, 3));
    }
}
