//! Where an optimisation starts when no policy is given: uniform, random or clock tables
//! sized for a world (model §3).

use std::str::FromStr;

use crate::episodes::Episodes;
use crate::error::{Error, Result};
use crate::policy::Hhmm;
use crate::rng::{Purpose, stream};

/// The starting tables of an optimisation.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Init {
    /// Every row uniform (the paper's starting point).
    #[default]
    Uniform,
    /// Random rows drawn from the run's seed (stream `(seed, Init, 0, 0)`).
    Random,
    /// A two-level clock: the memory counts the steps, `h0` uniform (see [`Hhmm::clock`]).
    Clock,
}

impl Init {
    /// Every kind, in the order of [`Init::as_str`]'s documentation.
    pub const ALL: [Init; 3] = [Init::Uniform, Init::Random, Init::Clock];

    /// `"uniform"`, `"random"` or `"clock"`.
    pub const fn as_str(self) -> &'static str {
        match self {
            Init::Uniform => "uniform",
            Init::Random => "random",
            Init::Clock => "clock",
        }
    }

    /// The starting policy for `levels` sized for `world` (`seed` draws random tables).
    pub fn policy<E: Episodes + ?Sized>(self, world: &E, levels: &[usize], seed: u64) -> Result<Hhmm> {
        match self {
            Init::Uniform => uniform_policy(world, levels),
            Init::Random => random_policy(world, levels, seed),
            Init::Clock => clock_policy(world, levels),
        }
    }
}

impl FromStr for Init {
    type Err = Error;

    fn from_str(text: &str) -> Result<Init> {
        Init::ALL
            .into_iter()
            .find(|i| i.as_str() == text)
            .ok_or_else(|| Error::invalid("init", format!("{text:?} (expected \"uniform\", \"random\" or \"clock\")")))
    }
}

/// A uniform policy for `levels` sized for `world`.
pub fn uniform_policy<E: Episodes + ?Sized>(world: &E, levels: &[usize]) -> Result<Hhmm> {
    Hhmm::uniform(world.shape().observations, world.shape().decisions, levels)
}

/// A clock policy (see [`Hhmm::clock`]) for `levels` sized for `world`.
pub fn clock_policy<E: Episodes + ?Sized>(world: &E, levels: &[usize]) -> Result<Hhmm> {
    Hhmm::clock(world.shape().observations, world.shape().decisions, levels)
}

/// A random policy for `levels` sized for `world`, drawn from `seed`.
pub fn random_policy<E: Episodes + ?Sized>(world: &E, levels: &[usize], seed: u64) -> Result<Hhmm> {
    Hhmm::random(world.shape().observations, world.shape().decisions, levels, &mut stream(seed, Purpose::Init, 0, 0))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn init_names_round_trip_and_each_makes_its_policy() {
        let world = crate::TargetTracking::new(1).unwrap();
        for init in Init::ALL {
            assert_eq!(init.as_str().parse::<Init>().unwrap(), init);
        }
        let e = "zeros".parse::<Init>().unwrap_err().to_string();
        assert!(e.contains("init") && e.contains("\"zeros\"") && e.contains("clock"), "{e}");
        assert_eq!(Init::Uniform.policy(&world, &[3], 5).unwrap(), uniform_policy(&world, &[3]).unwrap());
        assert_eq!(Init::Random.policy(&world, &[3], 5).unwrap(), random_policy(&world, &[3], 5).unwrap());
        assert_ne!(Init::Random.policy(&world, &[3], 5).unwrap(), random_policy(&world, &[3], 6).unwrap());
        assert_eq!(Init::Clock.policy(&world, &[4, 4], 5).unwrap(), clock_policy(&world, &[4, 4]).unwrap());
    }
}
