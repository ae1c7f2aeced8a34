//! Cross-entropy over deterministic controllers of a tabular world (model §8).
//!
//! The paper's CE (model §3) samples *episodes* and counts the decisions and memory of the
//! elite. On a tabular world the value of a whole controller is computable exactly, so the CE
//! method can also run in the space of machines, as Rubinstein states it for combinatorial
//! problems (and as DICE does for decentralised POMDPs: Oliehoek, Kooi & Vlassis, 2008): draw
//! `N` deterministic `n`-node controllers from independent categorical laws (one per node for its
//! action, one per node and observation for its successor), compute each one's exact value, keep
//! the best `⌈ρN⌉`, refit the laws to the elite's frequencies (smoothed by α), repeat. Ranking by
//! exact values removes the sampling noise of the episodes; the price is one value computation
//! per controller, `O(|S|·n·outcomes)` per sweep.
//!
//! A controller is a Moore machine: node `q` takes action `act[q]`; after observation `y` it
//! moves to `next[q][y]`; the first node is `next[0][|O|]` (`|O|` the start symbol). As an HHMM
//! (model §2) it is the two-level policy `[n, n]` with one-hot tables `h0[q] = act[q]`,
//! `h1[y][u] = next[u][y]`, `start = 0`, `step[p] = p`, so evaluation, exact values, graphs and
//! policy files take it as it is.

use std::time::Instant;

use rand::RngExt;
use rayon::prelude::*;
use serde::Serialize;

use crate::ce::optimize::StopReason;
use crate::control::{Flow, thread_pool};
use crate::error::{Error, Result};
use crate::exact::MAX_STEPS;
use crate::policy::{Hhmm, Layout};
use crate::rng::{Purpose, restart_seed, stream};
use crate::world::World;
use crate::world::pomdp::PomdpWorld;

/// Most controllers of one iteration.
pub const MAX_SAMPLES: usize = 10_000_000;
/// Most runs of one search.
pub const MAX_RESTARTS: usize = 10_000;

/// The settings of a controller search; `Default` gives settings that suit the small files of
/// `data/pomdp/` (model §8).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ControllerConfig {
    /// Nodes of the controller, `n`.
    pub nodes: usize,
    /// Controllers drawn per iteration, `N`.
    pub samples: usize,
    /// Selective rate ρ in (0, 1): the best `ceil(ρN)` controllers refit the laws.
    pub rho: f64,
    /// Smoothing α in (0, 1]: `p := α·elite frequency + (1 − α)·p`.
    pub smoothing: f64,
    /// Stop after this many iterations in a row without progress: neither a better controller
    /// nor a higher elite threshold.
    pub patience: usize,
    /// Stop after this many iterations.
    pub max_iterations: Option<usize>,
    /// Stop after this many seconds (checked before each controller's evaluation: an
    /// iteration cut by it does not refit the laws).
    pub time_limit: Option<f64>,
    /// Absolute tolerance of each controller's infinite-horizon value (`γ < 1`).
    pub tolerance: f64,
    /// Seed of every random stream.
    pub seed: u64,
    /// Worker threads (`None`: one per core). Results do not depend on it.
    pub threads: Option<usize>,
    /// Independent runs (the first with `seed`, the others with seeds derived from it); the best
    /// controller of all is returned. The time limit is shared by all the runs.
    pub restarts: usize,
}

impl Default for ControllerConfig {
    fn default() -> Self {
        ControllerConfig {
            nodes: 8,
            samples: 2000,
            rho: 0.02,
            smoothing: 0.1,
            patience: 50,
            max_iterations: None,
            time_limit: None,
            tolerance: 1e-6,
            seed: 0,
            threads: None,
            restarts: 1,
        }
    }
}

impl ControllerConfig {
    /// Number of elite controllers, `ceil(ρN)`.
    pub fn elite_count(&self) -> usize {
        ((self.rho * self.samples as f64).ceil() as usize).clamp(1, self.samples)
    }

    /// Refuses settings out of range, naming the value and what was expected.
    pub fn validate(&self) -> Result<()> {
        if self.nodes == 0 || self.nodes > crate::policy::MAX_LEVEL_SIZE {
            return Err(Error::invalid(
                "nodes",
                format!("{} (expected 1..={})", self.nodes, crate::policy::MAX_LEVEL_SIZE),
            ));
        }
        if self.samples == 0 || self.samples > MAX_SAMPLES {
            return Err(Error::invalid("samples", format!("{} (expected 1..={MAX_SAMPLES})", self.samples)));
        }
        if !(self.rho > 0.0 && self.rho < 1.0) {
            return Err(Error::invalid("rho", format!("{} (expected 0 < rho < 1)", self.rho)));
        }
        if !(self.smoothing > 0.0 && self.smoothing <= 1.0) {
            return Err(Error::invalid("smoothing", format!("{} (expected 0 < smoothing <= 1)", self.smoothing)));
        }
        if self.patience == 0 {
            return Err(Error::invalid("patience", "0 (expected at least 1)"));
        }
        if self.max_iterations == Some(0) {
            return Err(Error::invalid("max_iterations", "0 (expected at least 1, or none)"));
        }
        if let Some(t) = self.time_limit
            && !(t > 0.0 && t.is_finite())
        {
            return Err(Error::invalid("time_limit", format!("{t} (expected a positive number of seconds)")));
        }
        if !(self.tolerance > 0.0 && self.tolerance.is_finite()) {
            return Err(Error::invalid("tolerance", format!("{} (expected a positive number)", self.tolerance)));
        }
        if let Some(n) = self.threads {
            crate::control::check_threads(n)?;
        }
        if self.restarts == 0 || self.restarts > MAX_RESTARTS {
            return Err(Error::invalid("restarts", format!("{} (expected 1..={MAX_RESTARTS})", self.restarts)));
        }
        Ok(())
    }
}

/// One iteration of a controller search.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ControllerIteration {
    /// The run (0-based; see `restarts`).
    pub restart: usize,
    /// 0-based, within the run.
    pub iteration: usize,
    /// Mean exact value of the iteration's controllers.
    pub mean: f64,
    /// The worst value kept in the elite.
    pub elite_min: f64,
    /// The iteration's best value.
    pub max: f64,
    /// The best value so far.
    pub best: f64,
    /// Mean over the laws' rows of their largest probability (1: every draw is the same controller).
    pub concentration: f64,
    /// Controllers evaluated (fewer than `samples` when the time limit cut the iteration).
    pub evaluated: usize,
    /// Seconds since the start.
    pub seconds: f64,
}

/// The outcome of a controller search.
#[derive(Clone, Debug)]
pub struct ControllerOutcome {
    /// The best controller found, as a two-level one-hot HHMM.
    pub policy: Hhmm,
    /// Its exact value (infinite-horizon for `γ < 1`, else at the world's horizon).
    pub value: f64,
    /// The iteration that drew it, within its run.
    pub best_iteration: usize,
    /// The run that found it.
    pub restart: usize,
    /// The best value of each run, in order.
    pub run_values: Vec<f64>,
    /// One record per iteration, run after run.
    pub history: Vec<ControllerIteration>,
    /// Why the last run stopped.
    pub stop: StopReason,
    /// Seconds taken.
    pub seconds: f64,
}

/// A deterministic controller: `act[q]` and `next[q·(|O|+1) + y]`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Controller {
    /// The action of each node.
    pub act: Vec<u32>,
    /// The successor of node `q` after observation `y` at `q·(|O|+1) + y` (`y = |O|`: the start symbol).
    pub next: Vec<u32>,
}

impl Controller {
    /// The two-level one-hot HHMM of this controller (module docs).
    pub fn to_hhmm(&self, n_obs: usize, n_actions: usize) -> Result<Hhmm> {
        let n = self.act.len();
        let layout = Layout::new(n_obs, n_actions, &[n, n])?.fits_in_memory()?;
        let mut probs = vec![0.0; layout.len];
        let t = &layout.tables;
        for (q, &a) in self.act.iter().enumerate() {
            probs[t[0].offset + q * n_actions + a as usize] = 1.0;
        }
        for y in 0..n_obs {
            for u in 0..n {
                probs[t[1].offset + (y * n + u) * n + self.next[u * n_obs + y] as usize] = 1.0;
            }
        }
        probs[t[2].offset] = 1.0;
        for p in 0..n {
            probs[t[3].offset + p * n + p] = 1.0;
        }
        Hhmm::from_flat(layout, probs)
    }
}

/// Exact values of controllers on one world.
pub struct ControllerValue<'a> {
    world: &'a PomdpWorld,
    /// `None`: infinite horizon, iterated to `tolerance`.
    horizon: Option<usize>,
    tolerance: f64,
}

impl<'a> ControllerValue<'a> {
    /// Values on `world`: infinite-horizon to `tolerance` when its discount is below 1, else at
    /// its horizon.
    pub fn new(world: &'a PomdpWorld, tolerance: f64) -> ControllerValue<'a> {
        let horizon = (world.tables().gamma >= 1.0).then(|| world.horizon());
        ControllerValue { world, horizon, tolerance }
    }

    /// The value of `c` from the start law; `v` and `w` are scratch space.
    pub fn value(&self, c: &Controller, v: &mut Vec<f64>, w: &mut Vec<f64>) -> f64 {
        let t = self.world.tables();
        let (n_s, n) = (t.n_states(), c.act.len());
        let y1 = t.n_observations() + 1;
        let gamma = t.gamma;
        v.clear();
        v.resize(n_s * n, 0.0);
        w.clear();
        w.resize(n_s * n, 0.0);
        let sweeps = self.horizon.unwrap_or(MAX_STEPS);
        // ||w − V*|| ≤ γ/(1 − γ)·||w − v|| for a γ-contraction.
        let factor = if gamma < 1.0 { gamma / (1.0 - gamma) } else { f64::INFINITY };
        for _ in 0..sweeps {
            let mut change: f64 = 0.0;
            for s in 0..n_s {
                for q in 0..n {
                    let a = c.act[q] as usize;
                    let mut x = t.expected_reward(s, a);
                    let mut future = 0.0;
                    for j in t.outcomes(s, a) {
                        let (s2, o) = t.next[j];
                        future += t.prob[j] * v[s2 as usize * n + c.next[q * y1 + o as usize] as usize];
                    }
                    x += gamma * future;
                    change = change.max((x - v[s * n + q]).abs());
                    w[s * n + q] = x;
                }
            }
            std::mem::swap(v, w);
            if self.horizon.is_none() && change * factor <= self.tolerance {
                break;
            }
        }
        let first = c.next[y1 - 1] as usize;
        t.start.iter().enumerate().map(|(s, &p)| p * v[s * n + first]).sum()
    }
}

/// The categorical laws the controllers are drawn from.
struct Laws {
    n: usize,
    n_actions: usize,
    y1: usize,
    /// `act[q·A + a]`.
    act: Vec<f64>,
    /// `next[(q·(|O|+1) + y)·n + q']`.
    next: Vec<f64>,
}

impl Laws {
    fn uniform(n: usize, n_actions: usize, y1: usize) -> Laws {
        Laws {
            n,
            n_actions,
            y1,
            act: vec![1.0 / n_actions as f64; n * n_actions],
            next: vec![1.0 / n as f64; n * y1 * n],
        }
    }

    fn draw(&self, rng: &mut crate::rng::EngineRng) -> Controller {
        let act = self.act.chunks(self.n_actions).map(|row| pick(row, rng.random())).collect();
        let next = self.next.chunks(self.n).map(|row| pick(row, rng.random())).collect();
        Controller { act, next }
    }

    /// `p := α·frequency + (1 − α)·p` over the elite.
    fn refit(&mut self, elite: &[&Controller], alpha: f64) {
        let weight = alpha / elite.len() as f64;
        for p in self.act.iter_mut().chain(self.next.iter_mut()) {
            *p *= 1.0 - alpha;
        }
        for c in elite {
            for (q, &a) in c.act.iter().enumerate() {
                self.act[q * self.n_actions + a as usize] += weight;
            }
            for (row, &q2) in c.next.iter().enumerate() {
                self.next[row * self.n + q2 as usize] += weight;
            }
        }
    }

    /// Mean over rows of the largest probability.
    fn concentration(&self) -> f64 {
        let rows = self.act.chunks(self.n_actions).chain(self.next.chunks(self.n));
        let count = self.n + self.n * self.y1;
        rows.map(|r| r.iter().copied().fold(0.0, f64::max)).sum::<f64>() / count as f64
    }
}

/// The index drawn from `row` by the uniform number `u` (the last positive entry if rounding
/// leaves `u` past the total).
fn pick(row: &[f64], u: f64) -> u32 {
    let mut acc = 0.0;
    let mut last = 0;
    for (i, &p) in row.iter().enumerate() {
        if p > 0.0 {
            acc += p;
            last = i;
            if u < acc {
                return i as u32;
            }
        }
    }
    last as u32
}

/// Searches deterministic `config.nodes`-node controllers of `world` by the cross-entropy method
/// (module docs), `config.restarts` times; `observe` sees every iteration of every run and may
/// stop the search. The best controller of all the runs is returned (values are exact, so the
/// choice has no selection bias).
pub fn optimize_controller(
    world: &PomdpWorld,
    config: &ControllerConfig,
    mut observe: impl FnMut(&ControllerIteration) -> Flow,
) -> Result<ControllerOutcome> {
    config.validate()?;
    let t = world.tables();
    let (n_actions, y1) = (t.n_actions(), t.n_observations() + 1);
    // The policy must fit before any work.
    Layout::new(y1, n_actions, &[config.nodes, config.nodes])?.fits_in_memory()?;
    let pool = thread_pool(config.threads)?;
    let search = Search { config, values: ControllerValue::new(world, config.tolerance), y1, n_actions, pool };
    let started = Instant::now();
    let mut outcome: Option<ControllerOutcome> = None;
    for restart in 0..config.restarts {
        let run = search.run(restart_seed(config.seed, restart), restart, started, &mut observe)?;
        let stop = run.stop;
        outcome = Some(match outcome {
            Some(mut kept) => {
                kept.run_values.push(run.value);
                if run.value > kept.value {
                    kept.policy = run.policy;
                    kept.value = run.value;
                    kept.best_iteration = run.best_iteration;
                    kept.restart = restart;
                }
                kept.history.extend(run.history);
                kept.stop = stop;
                kept
            }
            None => run,
        });
        if matches!(stop, StopReason::Interrupted | StopReason::TimeLimit) {
            break;
        }
    }
    let mut outcome = outcome.expect("at least one run");
    outcome.seconds = started.elapsed().as_secs_f64();
    Ok(outcome)
}

/// What every run of a search shares.
struct Search<'a> {
    config: &'a ControllerConfig,
    values: ControllerValue<'a>,
    y1: usize,
    n_actions: usize,
    pool: rayon::ThreadPool,
}

impl Search<'_> {
    /// One run from uniform laws with `seed`.
    fn run(
        &self,
        seed: u64,
        restart: usize,
        started: Instant,
        observe: &mut impl FnMut(&ControllerIteration) -> Flow,
    ) -> Result<ControllerOutcome> {
        let config = self.config;
        let elite_size = config.elite_count();
        let mut laws = Laws::uniform(config.nodes, self.n_actions, self.y1);
        let mut best: Option<(f64, Controller, usize)> = None;
        let mut history = Vec::new();
        let mut since_progress = 0;
        let mut best_threshold = f64::NEG_INFINITY;
        let stop = loop {
            let iteration = history.len();
            let over_time = || config.time_limit.is_some_and(|s| started.elapsed().as_secs_f64() >= s);
            // Past the time limit, the controllers not yet evaluated are left out (the first
            // always counts): an iteration may be long on a large model or a discount near 1.
            let drawn: Vec<Option<(f64, Controller)>> = self.pool.install(|| {
                (0..config.samples)
                    .into_par_iter()
                    .map_init(
                        || (Vec::new(), Vec::new()),
                        |(v, w), k| {
                            if k > 0 && over_time() {
                                return None;
                            }
                            let mut rng = stream(seed, Purpose::Optimise, iteration as u64, k as u64);
                            let c = laws.draw(&mut rng);
                            Some((self.values.value(&c, v, w), c))
                        },
                    )
                    .collect()
            });
            let cut = drawn.iter().any(Option::is_none);
            let drawn: Vec<(f64, Controller)> = drawn.into_iter().flatten().collect();
            let elite_size = elite_size.min(drawn.len());
            let mut order: Vec<usize> = (0..drawn.len()).collect();
            // Highest value first; equal values keep their draw order (deterministic).
            order.sort_by(|&i, &j| drawn[j].0.total_cmp(&drawn[i].0).then(i.cmp(&j)));
            let top = order[0];
            let threshold = drawn[order[elite_size - 1]].0;
            // Progress is a better controller or a higher elite threshold (Rubinstein's γ_t): a
            // lucky early draw must not stop a search whose laws are still climbing.
            let mut progress = threshold > best_threshold + config.tolerance;
            best_threshold = best_threshold.max(threshold);
            if best.as_ref().is_none_or(|(b, _, _)| drawn[top].0 > *b + config.tolerance) {
                best = Some((drawn[top].0, drawn[top].1.clone(), iteration));
                progress = true;
            }
            since_progress = if progress { 0 } else { since_progress + 1 };
            // Ties at the threshold are left out when some controllers beat it: a plateau of
            // equal values (e.g. tiger's "always listen") would otherwise fill the elite and hold
            // the laws there.
            let above = order[..elite_size].iter().take_while(|&&i| drawn[i].0 > threshold).count();
            let kept = if above > 0 { above } else { elite_size };
            if !cut {
                // A cut iteration's elite would favour whichever controllers came first.
                let elite: Vec<&Controller> = order[..kept].iter().map(|&i| &drawn[i].1).collect();
                laws.refit(&elite, config.smoothing);
            }
            let record = ControllerIteration {
                restart,
                iteration,
                mean: drawn.iter().map(|d| d.0).sum::<f64>() / drawn.len() as f64,
                elite_min: threshold,
                max: drawn[top].0,
                best: best.as_ref().map_or(f64::NAN, |b| b.0),
                concentration: laws.concentration(),
                evaluated: drawn.len(),
                seconds: started.elapsed().as_secs_f64(),
            };
            let flow = observe(&record);
            history.push(record);
            if flow == Flow::Stop {
                break StopReason::Interrupted;
            }
            if since_progress >= config.patience {
                break StopReason::Patience;
            }
            if config.max_iterations.is_some_and(|m| history.len() >= m) {
                break StopReason::MaxIterations;
            }
            if cut || over_time() {
                break StopReason::TimeLimit;
            }
        };
        let (value, controller, best_iteration) = best.expect("at least one iteration");
        Ok(ControllerOutcome {
            policy: controller.to_hhmm(self.y1, self.n_actions)?,
            value,
            best_iteration,
            restart,
            run_values: vec![value],
            history,
            stop,
            seconds: started.elapsed().as_secs_f64(),
        })
    }
}
