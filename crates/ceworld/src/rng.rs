//! Random streams: every episode's generator is derived from (seed, purpose, iteration, index),
//! so results never depend on how the work is split between threads (model §3, reproducibility).

use rand::SeedableRng;
use rand::rngs::Xoshiro256PlusPlus;

/// The generator used everywhere in the engine (fast, 256-bit state, reproducible by algorithm).
pub type EngineRng = Xoshiro256PlusPlus;

/// What a stream is used for; distinct purposes never share a stream.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u64)]
pub enum Purpose {
    /// Episodes sampled by the optimiser.
    Optimise = 1,
    /// Random keys breaking ties between equal rewards in the elite selection.
    TieBreak = 2,
    /// Fresh episodes for an evaluation.
    Evaluate = 3,
    /// Random initial tables.
    Init = 4,
    /// The single sequential stream of a Q-learning run (its state is saved in checkpoints).
    QLearning = 5,
    /// Seeds of the restarts of an optimisation after the first.
    Restart = 6,
    /// Episodes that choose the best of several restarts (disjoint from `Evaluate`'s).
    Select = 7,
    /// The draws of a policy acting in an outside loop ([`crate::policy::agent::Agent`]).
    Agent = 8,
    /// Episodes of a world stepped from outside ([`crate::world::session::Session`]).
    Session = 9,
    /// The seed a world outside the engine draws a batch of episodes from
    /// ([`crate::episodes::outside`]).
    Outside = 10,
    /// The episodes of a controller search's sampled values, shared by every controller of an
    /// iteration (common random numbers; [`crate::ce::controller`]).
    Controllers = 11,
}

impl Purpose {
    /// The purposes of episodes that may be run elsewhere (a shard of an iteration, of an
    /// evaluation, of a restart's or a controller's selection, of a controller search's
    /// iteration), by name.
    pub const OF_EPISODES: [(&'static str, Purpose); 4] = [
        ("optimise", Purpose::Optimise),
        ("evaluate", Purpose::Evaluate),
        ("select", Purpose::Select),
        ("controllers", Purpose::Controllers),
    ];

    /// The name of a purpose of [`Purpose::OF_EPISODES`] (`None` for the others).
    pub fn episodes_name(self) -> Option<&'static str> {
        Purpose::OF_EPISODES.iter().find(|(_, p)| *p == self).map(|&(n, _)| n)
    }

    /// The purpose of episodes named `name` (one of [`Purpose::OF_EPISODES`]).
    pub fn of_episodes(name: &str) -> crate::error::Result<Purpose> {
        Purpose::OF_EPISODES.iter().find(|(n, _)| *n == name).map(|&(_, p)| p).ok_or_else(|| {
            let names: Vec<&str> = Purpose::OF_EPISODES.iter().map(|(n, _)| *n).collect();
            crate::error::Error::invalid("purpose", format!("{name:?} (expected one of {names:?})"))
        })
    }
}

/// `SplitMix64`'s finaliser: a bijective 64-bit mixer with good avalanche.
#[inline]
pub fn mix64(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// A 64-bit key for (seed, purpose, iteration, index), well mixed in every argument.
#[inline]
pub fn stream_key(seed: u64, purpose: Purpose, iteration: u64, index: u64) -> u64 {
    let mut h = mix64(seed ^ 0x9e37_79b9_7f4a_7c15);
    h = mix64(h ^ (purpose as u64).wrapping_mul(0xd6e8_feb8_6659_fd93));
    h = mix64(h ^ iteration.wrapping_mul(0xa076_1d64_78bd_642f));
    mix64(h ^ index.wrapping_mul(0xe703_7ed1_a0b4_28db))
}

/// The seed of run `restart` of an optimisation with `seed`: the seed itself for run 0, a key
/// of its own for each later run.
pub fn restart_seed(seed: u64, restart: usize) -> u64 {
    if restart == 0 { seed } else { stream_key(seed, Purpose::Restart, restart as u64, 0) }
}

/// The generator of one stream.
#[inline]
pub fn stream(seed: u64, purpose: Purpose, iteration: u64, index: u64) -> EngineRng {
    EngineRng::seed_from_u64(stream_key(seed, purpose, iteration, index))
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::RngExt;

    #[test]
    fn streams_are_distinct_and_reproducible() {
        let a: u64 = stream(0, Purpose::Optimise, 0, 0).random();
        let b: u64 = stream(0, Purpose::Optimise, 0, 0).random();
        let c: u64 = stream(0, Purpose::Optimise, 0, 1).random();
        let d: u64 = stream(0, Purpose::Evaluate, 0, 0).random();
        let e: u64 = stream(1, Purpose::Optimise, 0, 0).random();
        assert_eq!(a, b);
        assert!(a != c && a != d && a != e && c != d);
    }
}
