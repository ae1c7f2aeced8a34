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
}
