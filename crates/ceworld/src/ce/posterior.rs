//! Expected sufficient statistics of an episode's memory given its observations and decisions
//! (forward–backward), an alternative to counting the memory states that were sampled.
//!
//! The reward depends on `(d, y, x)` only; the memory `m` is a means. Counting the sampled `m`
//! (model §3, the paper) fits the tables to one arbitrary explanation of each elite episode's
//! decisions; replacing those counts by their posterior expectation under the current policy,
//! `E[counts | y, d]`, maximises the elite's likelihood of `d` given `y` with the memory
//! marginalised (one EM step), so the memory can be re-assigned to whatever explains the good
//! decisions best. Exact for `Λ ≤ 2` in `O(T·|M_1|·|M_2|)` per episode.

use crate::error::{Error, Result};
use crate::policy::{Hhmm, Layout};

/// Reused buffers of one worker.
#[derive(Default)]
pub struct Scratch {
    alpha: Vec<f64>,
    beta: Vec<f64>,
    prior: Vec<f64>,
    scale: Vec<f64>,
    gamma: Vec<f64>,
}

/// Checks that forward–backward supports this policy (`Λ ≤ 2`).
pub fn check_supported(layout: &Layout) -> Result<()> {
    if layout.depth() > 2 {
        return Err(Error::invalid(
            "memory_update",
            format!(
                "forward-backward needs at most 2 levels, the policy has {:?} (use the sampled memory)",
                layout.levels
            ),
        ));
    }
    Ok(())
}

/// Adds the posterior expected counts of one recorded episode (`[y, d, m...]` per step; the
/// sampled `m` are ignored) to `counts`, laid out as the policy's tables. Each step adds
/// probability mass 1 to `h0` and `h1`, and to `start2`/`step2` when `Λ = 2`.
pub fn add_expected_counts(policy: &Hhmm, record: &[u16], counts: &mut [f64], s: &mut Scratch) {
    let layout = policy.layout();
    let width = layout.record_width();
    let steps = record.len() / width;
    let m1 = layout.levels[0];
    let m2 = if layout.depth() == 2 { layout.levels[1] } else { 1 };
    let (h0, h1) = (policy.table(0), policy.table(1));
    let d_count = layout.n_actions;
    let (start, step) = if layout.depth() == 2 { (policy.table(2), policy.table(3)) } else { (&[1.0][..], &[][..]) };
    let y_of = |t: usize| record[t * width] as usize;
    let d_of = |t: usize| record[t * width + 1] as usize;
    // emission(t, m1) = h0[m1][d_t]; input(t, u, m1) = h1[y_t][u][m1]
    s.alpha.clear();
    s.alpha.resize(steps * m1, 0.0);
    s.beta.clear();
    s.beta.resize(steps * m1, 0.0);
    s.prior.clear();
    s.prior.resize(steps * m2, 0.0);
    s.scale.clear();
    s.scale.resize(steps, 0.0);
    s.gamma.resize(m2, 0.0);
    // Forward: prior[t][u] = P(m2[t] = u | d_<t), alpha[t][m1] ∝ P(m1[t] = m1 | d_≤t).
    for t in 0..steps {
        let (y, d) = (y_of(t), d_of(t));
        {
            let prior = &mut s.prior[t * m2..(t + 1) * m2];
            if t == 0 || m2 == 1 {
                prior.copy_from_slice(&start[..m2]);
                if m2 == 1 {
                    prior[0] = 1.0;
                }
            } else {
                prior.fill(0.0);
                for p in 0..m1 {
                    let a = s.alpha[(t - 1) * m1 + p];
                    if a != 0.0 {
                        for (u, x) in prior.iter_mut().enumerate() {
                            *x += a * step[p * m2 + u];
                        }
                    }
                }
            }
        }
        let mut total = 0.0;
        for m in 0..m1 {
            let mut x = 0.0;
            for u in 0..m2 {
                x += s.prior[t * m2 + u] * h1[(y * m2 + u) * m1 + m];
            }
            x *= h0[m * d_count + d];
            s.alpha[t * m1 + m] = x;
            total += x;
        }
        // The episode was drawn from this policy, so its decisions have positive probability.
        let inv = if total > 0.0 { 1.0 / total } else { 0.0 };
        s.scale[t] = total;
        s.alpha[t * m1..(t + 1) * m1].iter_mut().for_each(|a| *a *= inv);
    }
    // Backward, with the expected counts as they come.
    let (o0, o1) = (layout.tables[0].offset, layout.tables[1].offset);
    s.beta[(steps - 1) * m1..].fill(1.0);
    for t in (0..steps).rev() {
        let (y, d) = (y_of(t), d_of(t));
        let inv = if s.scale[t] > 0.0 { 1.0 / s.scale[t] } else { 0.0 };
        // h0: P(m1[t] | all) = alpha·beta
        for m in 0..m1 {
            let p = s.alpha[t * m1 + m] * s.beta[t * m1 + m];
            counts[o0 + m * d_count + d] += p;
        }
        // gamma[u] = Σ_m1 h1[y][u][m1]·h0[m1][d]·beta[t][m1] / c_t
        for u in 0..m2 {
            let mut g = 0.0;
            for m in 0..m1 {
                let w = h1[(y * m2 + u) * m1 + m] * h0[m * d_count + d] * s.beta[t * m1 + m] * inv;
                counts[o1 + (y * m2 + u) * m1 + m] += s.prior[t * m2 + u] * w;
                g += w;
            }
            s.gamma[u] = g;
        }
        if m2 > 1 {
            if t == 0 {
                let o = layout.tables[2].offset;
                for u in 0..m2 {
                    counts[o + u] += s.prior[u] * s.gamma[u];
                }
            } else {
                let o = layout.tables[3].offset;
                for p in 0..m1 {
                    let a = s.alpha[(t - 1) * m1 + p];
                    let mut b = 0.0;
                    for u in 0..m2 {
                        let w = step[p * m2 + u] * s.gamma[u];
                        counts[o + p * m2 + u] += a * w;
                        b += w;
                    }
                    s.beta[(t - 1) * m1 + p] = b;
                }
            }
        } else if t > 0 {
            // Λ = 1: steps are independent given y and d.
            s.beta[(t - 1) * m1..t * m1].fill(1.0);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ce::counting::count_episode;

    #[test]
    fn deterministic_policy_gives_the_sampled_counts() {
        // A policy whose every row is one-hot: the memory is a function of (y, d) history, so
        // the posterior puts mass 1 on the sampled memory and both counts agree.
        let layout = Layout::new(2, 2, &[2, 2]).unwrap();
        let mut probs = vec![0.0; layout.len];
        for t in &layout.tables {
            for r in 0..t.rows {
                probs[t.offset + r * t.cols + (r % t.cols)] = 1.0;
            }
        }
        let h = Hhmm::from_flat(layout.clone(), probs).unwrap();
        let mut rng = crate::rng::stream(1, crate::rng::Purpose::Evaluate, 0, 0);
        let mut record = vec![0u16; 5 * 4];
        let mut memory = [0u16; 2];
        for t in 0..5 {
            let y = t % 2;
            let d = h.step(y, &mut memory, t == 0, &mut rng);
            record[t * 4..t * 4 + 4].copy_from_slice(&[y as u16, d as u16, memory[0], memory[1]]);
        }
        let mut sampled = vec![0u32; layout.len];
        count_episode(&layout, &record, &mut sampled);
        let mut expected = vec![0.0; layout.len];
        add_expected_counts(&h, &record, &mut expected, &mut Scratch::default());
        for (k, (&a, &b)) in sampled.iter().zip(&expected).enumerate() {
            assert!((a as f64 - b).abs() < 1e-12, "entry {k}: sampled {a}, expected {b}");
        }
    }

    #[test]
    fn posterior_of_a_two_state_memory_by_hand() {
        // Λ = 1, one observation, M1 = 2, D = 2: h1 = [0.5, 0.5], h0[0] = [0.9, 0.1], h0[1] = [0.2, 0.8].
        // Seeing d = 0: P(m1 = 0 | d) = 0.45 / (0.45 + 0.1) = 9/11.
        let layout = Layout::new(1, 2, &[2]).unwrap();
        let probs = vec![0.9, 0.1, 0.2, 0.8, 0.5, 0.5];
        let h = Hhmm::from_flat(layout.clone(), probs).unwrap();
        let record = [0u16, 0, 1]; // y = 0, d = 0, sampled m1 = 1 (ignored)
        let mut counts = vec![0.0; layout.len];
        add_expected_counts(&h, &record, &mut counts, &mut Scratch::default());
        let want = [9.0 / 11.0, 0.0, 2.0 / 11.0, 0.0, 9.0 / 11.0, 2.0 / 11.0];
        for (g, w) in counts.iter().zip(want) {
            assert!((g - w).abs() < 1e-12, "{counts:?}");
        }
    }

    #[test]
    fn two_level_posterior_matches_brute_force() {
        // Enumerate every memory path of a 3-step episode and compare the expected counts.
        let layout = Layout::new(2, 3, &[2, 3]).unwrap();
        let mut rng = crate::rng::stream(4, crate::rng::Purpose::Init, 0, 0);
        let h = Hhmm::random(2, 3, &[2, 3], &mut rng).unwrap();
        let ys = [1usize, 0, 1];
        let ds = [2usize, 0, 1];
        let mut record = vec![0u16; 3 * 4];
        for t in 0..3 {
            record[t * 4] = ys[t] as u16;
            record[t * 4 + 1] = ds[t] as u16;
        }
        let mut brute = vec![0.0; layout.len];
        let mut z = 0.0;
        let paths: Vec<[usize; 6]> = (0..(6usize.pow(3)))
            .map(|mut k| {
                let mut p = [0usize; 6];
                for t in 0..3 {
                    p[2 * t] = k % 2; // m1[t]
                    p[2 * t + 1] = (k / 2) % 3; // m2[t]
                    k /= 6;
                }
                p
            })
            .collect();
        for p in &paths {
            let mut rec = record.clone();
            for t in 0..3 {
                rec[t * 4 + 2] = p[2 * t] as u16;
                rec[t * 4 + 3] = p[2 * t + 1] as u16;
            }
            // P(m, d | y) as the product of the table entries the counts would touch
            let mut c = vec![0u32; layout.len];
            count_episode(&layout, &rec, &mut c);
            let w: f64 = c.iter().zip(h.probs()).filter(|(n, _)| **n > 0).map(|(&n, &q)| q.powi(n as i32)).product();
            z += w;
            for (b, &n) in brute.iter_mut().zip(&c) {
                *b += w * n as f64;
            }
        }
        for b in &mut brute {
            *b /= z;
        }
        let mut fb = vec![0.0; layout.len];
        add_expected_counts(&h, &record, &mut fb, &mut Scratch::default());
        for (k, (a, b)) in brute.iter().zip(&fb).enumerate() {
            assert!((a - b).abs() < 1e-9, "entry {k}: brute force {a}, forward-backward {b}");
        }
    }
}
