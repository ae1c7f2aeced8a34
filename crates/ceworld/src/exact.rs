//! Exact evaluation of an HHMM policy on a tabular world (model §7): the expected reward at a
//! horizon `H`, by forward recursion over the joint law of the hidden state, the last
//! observation and the memory the policy carries, and for `γ < 1` the infinite-horizon value, by
//! the same recursion run until the geometric tail is below a stated tolerance.
//!
//! The policy's step (model §2) draws the memory top-down from the previous memory of the level
//! below, then `m_1` from the observation, then the decision: what one step carries to the next
//! is `(m_1, ..., m_{Λ-1})` (`K = |M_1|···|M_{Λ-1}|` values, one when `Λ = 1`). One step maps
//! the law of `(s, y, m_prev)` to the law of `(s, d, m)` through the policy's kernel, which
//! does not depend on `s`, and then to the law of `(s', o, m)` through the world's outcomes.

use serde::Serialize;

use crate::episodes::check_fits;
use crate::error::{Error, Result};
use crate::policy::Hhmm;
use crate::world::pomdp::PomdpWorld;

/// The most steps an infinite-horizon evaluation runs before it reports its tail bound.
pub const MAX_STEPS: usize = 1_000_000;
/// The default tolerance of the infinite-horizon value (absolute).
pub const DEFAULT_TOLERANCE: f64 = 1e-6;

/// An exact value and how it was reached.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ExactValue {
    /// The expected (discounted) reward.
    pub value: f64,
    /// Steps of the recursion.
    pub steps: usize,
    /// A bound on what the steps not taken could add (0 at a finite horizon).
    pub tail_bound: f64,
}

/// The policy's step as a kernel: for the observation `y` and the carried memory `k`, the law of
/// `(k', d)` (only positive entries).
struct Kernel<'a> {
    policy: &'a Hhmm,
    /// Sizes of the carried levels `1..Λ-1`.
    carried: Vec<usize>,
    /// `K`: the number of carried memory values.
    size: usize,
    /// Cache of the laws, index `(first · Y + y) · K + k`: each is computed once per run.
    rows: Vec<Option<Vec<(u32, u32, f64)>>>,
}

impl<'a> Kernel<'a> {
    fn new(policy: &'a Hhmm, n_obs: usize) -> Kernel<'a> {
        let levels = policy.levels();
        let carried = levels[..levels.len() - 1].to_vec();
        let size = carried.iter().product();
        Kernel { policy, carried, size, rows: vec![None; 2 * n_obs * size] }
    }

    /// The law of `(k', d)` after observation `y` with carried memory `k` (`first`: `t = 1`).
    fn law(&self, y: usize, k: usize, first: bool) -> Vec<(u32, u32, f64)> {
        let mut previous = vec![0u16; self.policy.levels().len()];
        let mut rest = k;
        for (slot, &size) in previous.iter_mut().zip(&self.carried) {
            *slot = (rest % size) as u16;
            rest /= size;
        }
        let n_actions = self.policy.layout().n_actions;
        let mut dense = vec![0.0; self.size * n_actions];
        for (memory, p) in self.policy.memory_law(y, &previous, first) {
            let keep = memory[..memory.len() - 1]
                .iter()
                .zip(&self.carried)
                .rev()
                .fold(0, |keep, (&value, &size)| keep * size + value as usize);
            for (d, &q) in self.policy.decision_law(memory[0] as usize).iter().enumerate() {
                dense[keep * n_actions + d] += p * q;
            }
        }
        dense
            .iter()
            .enumerate()
            .filter(|&(_, &p)| p > 0.0)
            .map(|(i, &p)| ((i / n_actions) as u32, (i % n_actions) as u32, p))
            .collect()
    }
}

/// The recursion for `steps` steps, or (`steps = None`, `γ < 1`) until the tail bound is below
/// `tolerance`.
fn recurse(world: &PomdpWorld, policy: &Hhmm, steps: Option<usize>, tolerance: f64) -> Result<ExactValue> {
    check_fits(world, policy)?;
    let t = world.tables();
    let (n_s, n_a, n_o) = (t.n_states(), t.n_actions(), t.n_observations());
    let y1 = n_o + 1;
    let mut kernel = Kernel::new(policy, y1);
    let k_size = kernel.size;
    let table_len = n_s.checked_mul(y1).and_then(|n| n.checked_mul(k_size)).filter(|&n| n <= 1 << 28);
    let Some(table_len) = table_len else {
        return Err(Error::invalid(
            "policy",
            "the joint law of state, observation and memory is too large to evaluate exactly",
        ));
    };
    let rewards: Vec<f64> = (0..n_s * n_a).map(|i| t.expected_reward(i / n_a, i % n_a)).collect();
    let r_max = t.max_abs_reward();
    let gamma = t.gamma;
    let mut dist = vec![0.0; table_len];
    for (s, &p) in t.start.iter().enumerate() {
        dist[(s * y1 + n_o) * k_size] = p;
    }
    let mut mass = vec![0.0; n_s * n_a * k_size];
    let (mut value, mut weight, mut step) = (0.0, 1.0, 0);
    loop {
        let tail = if gamma < 1.0 { weight * r_max / (1.0 - gamma) } else { f64::INFINITY };
        match steps {
            Some(h) if step >= h => return Ok(ExactValue { value, steps: step, tail_bound: 0.0 }),
            None if tail < tolerance || step >= MAX_STEPS => {
                return Ok(ExactValue { value, steps: step, tail_bound: tail });
            }
            _ => {}
        }
        let first = step == 0;
        mass.fill(0.0);
        for s in 0..n_s {
            for y in 0..y1 {
                for k in 0..k_size {
                    let p = dist[(s * y1 + y) * k_size + k];
                    if p == 0.0 {
                        continue;
                    }
                    let i = (usize::from(first) * y1 + y) * k_size + k;
                    if kernel.rows[i].is_none() {
                        kernel.rows[i] = Some(kernel.law(y, k, first));
                    }
                    for &(k2, d, q) in kernel.rows[i].as_ref().expect("just filled") {
                        mass[(s * n_a + d as usize) * k_size + k2 as usize] += p * q;
                    }
                }
            }
        }
        dist.fill(0.0);
        let mut expected = 0.0;
        for s in 0..n_s {
            for a in 0..n_a {
                let row = &mass[(s * n_a + a) * k_size..(s * n_a + a + 1) * k_size];
                let total: f64 = row.iter().sum();
                if total == 0.0 {
                    continue;
                }
                expected += total * rewards[s * n_a + a];
                for j in t.outcomes(s, a) {
                    let (s2, o) = t.next[j];
                    let base = (s2 as usize * y1 + o as usize) * k_size;
                    let p = t.prob[j];
                    for (k, &m) in row.iter().enumerate() {
                        dist[base + k] += m * p;
                    }
                }
            }
        }
        value += weight * expected;
        weight *= gamma;
        step += 1;
    }
}

/// The expected reward of an episode of `horizon` steps (the world's own when `None`).
pub fn finite_horizon(world: &PomdpWorld, policy: &Hhmm, horizon: Option<usize>) -> Result<ExactValue> {
    use crate::world::World;
    if horizon == Some(0) {
        return Err(Error::invalid("horizon", "0 (expected at least 1 step)"));
    }
    recurse(world, policy, Some(horizon.unwrap_or_else(|| world.horizon())), 0.0)
}

/// The infinite-horizon discounted value (`γ < 1`), to within `tolerance` (absolute).
pub fn infinite_horizon(world: &PomdpWorld, policy: &Hhmm, tolerance: f64) -> Result<ExactValue> {
    let gamma = world.tables().gamma;
    if gamma >= 1.0 {
        return Err(Error::invalid(
            "discount",
            format!("{gamma} (the infinite-horizon value needs a discount below 1)"),
        ));
    }
    if !(tolerance.is_finite() && tolerance > 0.0) {
        return Err(Error::invalid("tolerance", format!("{tolerance} (expected a positive finite number)")));
    }
    // At or past the bound of every value, no step would be computed: the value told would be 0.
    let bound = world.tables().max_abs_reward() / (1.0 - gamma);
    if bound > 0.0 && tolerance >= bound {
        return Err(Error::invalid(
            "tolerance",
            format!(
                "{tolerance} (expected less than {bound:.3e}, the largest reward over 1 - discount: a tolerance that large \
                 bounds every value, and none would be computed)"
            ),
        ));
    }
    recurse(world, policy, None, tolerance)
}
