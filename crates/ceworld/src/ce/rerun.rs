//! The elite's counts from the episodes' numbers alone: each episode re-run from its own random
//! stream (`streams.episode(k)`), recorded and counted. The re-run is the very episode the
//! iteration sampled, so these counts are those the optimiser takes from its records, bit for
//! bit: what a worker that sampled a shard of an iteration's episodes elsewhere sends back
//! instead of their trajectories (only the episodes' numbers go there, only counts come back).
//!
//! This holds where episode `k` depends on its stream alone: the engine's worlds and worlds
//! written in Python with the episode protocol. A batched world draws a batch's randomness
//! together (`reset(n, seed)`), so one of its episodes re-run alone is another episode: its
//! counts must be taken where its records were kept.

use rayon::prelude::*;

use crate::ce::counting::count_episode;
use crate::episodes::{Batch, Episodes, Streams};
use crate::error::Result;
use crate::policy::Hhmm;

/// Episodes re-run per task: large enough to amortise a task, small enough to share the elite.
const CHUNK: usize = 64;

/// The sampled counts (model §3, laid out as `policy`'s flat tables) of episodes `episodes` of
/// `streams` under `policy`, each re-run and recorded; on the current rayon pool. Integer sums,
/// so neither the order of `episodes` nor the thread count changes them.
pub fn rerun_counts<E: Episodes + ?Sized>(
    world: &E,
    policy: &Hhmm,
    streams: Streams,
    episodes: &[usize],
) -> Result<Vec<u32>> {
    crate::evaluate::check_fits(world, policy)?;
    let layout = policy.layout();
    let stride = Episodes::shape(world).horizon * layout.record_width();
    let counted: Result<Vec<Vec<u32>>> = episodes
        .par_chunks(CHUNK)
        .map(|chunk| {
            let mut counts = vec![0u32; layout.len];
            let (mut record, mut length, mut value) = (vec![0u16; stride], [0u32], [0.0f64]);
            for &k in chunk {
                let batch = Batch { values: &mut value, records: Some((&mut record, &mut length)) };
                world.run(policy, streams, k, batch)?;
                count_episode(layout, &record[..length[0] as usize * layout.record_width()], &mut counts);
            }
            Ok(counts)
        })
        .collect();
    let mut total = vec![0u32; layout.len];
    for counts in counted? {
        total.iter_mut().zip(&counts).for_each(|(t, c)| *t += c);
    }
    Ok(total)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Purpose;
    use crate::{TargetTracking, random_policy};

    #[test]
    fn re_run_episodes_count_as_their_records_do() {
        let world = TargetTracking::new(3).unwrap();
        // A policy far from uniform, so that the episodes differ.
        let policy = random_policy(&world, &[4, 3], 1).unwrap();
        let (n, streams) = (300, Streams { seed: 7, purpose: Purpose::Optimise, iteration: 3 });
        let stride = Episodes::shape(&world).horizon * policy.layout().record_width();
        let (mut values, mut records, mut lengths) = (vec![0.0; n], vec![0u16; n * stride], vec![0u32; n]);
        world
            .run(&policy, streams, 0, Batch { values: &mut values, records: Some((&mut records, &mut lengths)) })
            .unwrap();
        let elite = [299usize, 3, 17, 0, 150, 151, 42];
        let mut expected = vec![0u32; policy.layout().len];
        for &k in &elite {
            let record = &records[k * stride..k * stride + lengths[k] as usize * policy.layout().record_width()];
            count_episode(policy.layout(), record, &mut expected);
        }
        assert_eq!(rerun_counts(&world, &policy, streams, &elite).unwrap(), expected);
        // Any order, any split: the same integers.
        let (a, b) = elite.split_at(3);
        let mut split = rerun_counts(&world, &policy, streams, b).unwrap();
        split.iter_mut().zip(rerun_counts(&world, &policy, streams, a).unwrap()).for_each(|(s, c)| *s += c);
        assert_eq!(split, expected);
        // Another iteration's streams are other episodes.
        let other = Streams { iteration: 4, ..streams };
        assert_ne!(rerun_counts(&world, &policy, other, &elite).unwrap(), expected);
    }

    /// A world whose episodes are run without records and whose elite is counted by re-running
    /// it, as a backend elsewhere does: in shards of `shard` episodes, the last ones first.
    struct Elsewhere<W> {
        world: W,
        shard: usize,
    }

    impl<W: crate::World> Episodes for Elsewhere<W> {
        fn shape(&self) -> crate::episodes::Shape {
            Episodes::shape(&self.world)
        }
        fn description(&self) -> serde_json::Value {
            Episodes::description(&self.world)
        }
        fn run(&self, policy: &Hhmm, streams: Streams, first: usize, batch: Batch<'_>) -> Result<u64> {
            assert!(batch.records.is_none(), "episodes sampled elsewhere are run without records");
            let mut steps = 0;
            for (k, values) in batch.values.chunks_mut(self.shard).enumerate() {
                let part = Batch { values, records: None };
                steps += Episodes::run(&self.world, policy, streams, first + k * self.shard, part)?;
            }
            Ok(steps)
        }
        fn run_controllers(
            &self,
            controllers: &[crate::policy::controller::Controller],
            streams: Streams,
            episodes: usize,
            values: &mut [f64],
        ) -> Result<u64> {
            Episodes::run_controllers(&self.world, controllers, streams, episodes, values)
        }
        fn remote(&self) -> Option<&dyn crate::episodes::Remote> {
            Some(self)
        }
    }

    impl<W: crate::World> crate::episodes::Remote for Elsewhere<W> {
        fn counts(&self, policy: &Hhmm, streams: Streams, episodes: &[usize]) -> Result<Vec<u32>> {
            let mut total = vec![0u32; policy.layout().len];
            for shard in episodes.chunks(self.shard).rev() {
                let counts = rerun_counts(&self.world, policy, streams, shard)?;
                total.iter_mut().zip(&counts).for_each(|(t, c)| *t += c);
            }
            Ok(total)
        }
    }

    #[test]
    fn an_optimisation_sampled_elsewhere_is_the_local_one() {
        use crate::{CeConfig, Flow, MemoryUpdate, optimize};
        let world = TargetTracking::new(1).unwrap();
        let initial = random_policy(&world, &[3, 2], 5).unwrap();
        let config = CeConfig {
            samples: 120,
            rho: 0.2,
            max_iterations: Some(4),
            eval_episodes: 50,
            seed: 3,
            ..CeConfig::default()
        };
        let local = optimize(&world, initial.clone(), &config, |_| Flow::Continue).unwrap();
        for shard in [1, 7, 500] {
            let remote = Elsewhere { world: TargetTracking::new(1).unwrap(), shard };
            let elsewhere = optimize(&remote, initial.clone(), &config, |_| Flow::Continue).unwrap();
            assert_eq!(elsewhere.policy, local.policy);
            assert_eq!(elsewhere.last_policy, local.last_policy);
            assert_eq!(elsewhere.evaluation, local.evaluation);
            let means = |r: &crate::CeResult| r.history.iter().map(|h| h.mean).collect::<Vec<_>>();
            assert_eq!(means(&elsewhere), means(&local));
        }
        // Forward–backward counts are taken from the records: refused elsewhere, by name.
        let remote = Elsewhere { world, shard: 10 };
        let fb = CeConfig { memory_update: MemoryUpdate::ForwardBackward, ..config };
        let e = optimize(&remote, initial, &fb, |_| Flow::Continue).unwrap_err().to_string();
        assert!(e.contains("memory_update") && e.contains("forward-backward"), "{e}");
    }
}
