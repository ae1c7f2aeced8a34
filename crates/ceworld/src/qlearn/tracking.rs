//! Target tracking as a continuing world with a known state (what Q-learning needs of it).

use super::ContinuingWorld;
use super::KnownState;
use crate::error::Error;
use crate::error::Result;
use crate::rng::EngineRng;
use crate::world::World;
use crate::world::tracking::Mobile;
use crate::world::tracking::TargetTracking;
use crate::world::tracking::TrackingState;

/// Index of a mobile's configuration `(j·width + i)·4 + heading`.
#[inline]
fn configuration(m: Mobile, width: i32) -> usize {
    ((m.j * width + m.i) * 4 + m.heading as i32) as usize
}

impl ContinuingWorld for TargetTracking {
    #[inline]
    fn step_reward(&self, state: &mut TrackingState, decision: usize, rng: &mut EngineRng) -> f64 {
        // The score counts this one step only, so it never overflows however long the run.
        state.score = 0;
        self.step(state, decision, rng);
        let reward = state.score;
        state.score = 0;
        reward as f64
    }
}

impl KnownState for TargetTracking {
    /// `Y · (4·width·height)²`: 16 × 1600 × 1600 = 40,960,000 on the paper's grid.
    fn n_states(&self) -> Result<usize> {
        let p = self.params();
        let configurations = p.width as u128 * p.height as u128 * 4;
        let n = self.n_observations() as u128 * configurations * configurations;
        usize::try_from(n)
            .map_err(|_| Error::invalid("world", format!("{n} known states (more than this machine can address)")))
    }

    /// `(y · P + B) · P + C` with `P = 4·width·height` and `B`, `C` each mobile's
    /// `(j·width + i)·4 + heading`.
    #[inline]
    fn known_state(&self, state: &TrackingState, y: usize) -> usize {
        let p = self.params();
        let configurations = (p.width * p.height * 4) as usize;
        (y * configurations + configuration(state.b, p.width)) * configurations + configuration(state.c, p.width)
    }

    fn restore(&self, values: &[i64]) -> Result<TrackingState> {
        let p = self.params();
        let bad = || {
            Error::format(format!(
                "world state {values:?} (expected b_i, b_j, b_heading, c_i, c_j, c_heading, target_i, target_j on the {}×{} grid)",
                p.width, p.height
            ))
        };
        let &[bi, bj, bh, ci, cj, ch, ti, tj] = values else { return Err(bad()) };
        let column = |v: i64| (0..p.width as i64).contains(&v);
        let row = |v: i64| (0..p.height as i64).contains(&v);
        let heading = |v: i64| (0..4).contains(&v);
        if !(column(bi) && row(bj) && heading(bh) && column(ci) && row(cj) && heading(ch) && column(ti) && row(tj)) {
            return Err(bad());
        }
        Ok(TrackingState {
            b: Mobile { i: bi as i32, j: bj as i32, heading: bh as u8 },
            c: Mobile { i: ci as i32, j: cj as i32, heading: ch as u8 },
            target: [ti as i32, tj as i32],
            score: 0,
        })
    }
}
