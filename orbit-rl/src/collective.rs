//! Data-parallel training: the one collective operation the learner needs from a distributed
//! engine, and the reductions built on it.
//!
//! Each process (a *rank*) steps its own envs and holds a replica of the learner. As in
//! RSL-RL's multi-GPU training, the replicas start from rank 0's parameters and average their
//! gradients and KL divergences every minibatch; here the observation and return statistics
//! and the advantage normalisation are pooled too, so the replicas stay identical bit for bit.
//! Every reduction gathers all ranks' values and combines them on each rank in rank order:
//! the result does not depend on how the engine routes its messages, and every rank computes
//! the same bits.

/// A group of ranks training one policy (implemented on MPI by `orbit-distributed`).
pub trait Collective {
    /// This process's rank, `0..world_size()`.
    fn rank(&self) -> usize;
    /// Number of ranks.
    fn world_size(&self) -> usize;
    /// Gathers every rank's `local` bytes into `out`, in rank order. Every rank calls it at the
    /// same point with the same length; `out.len() == world_size() · local.len()`.
    fn all_gather(&self, local: &[u8], out: &mut [u8]);
}

/// Every rank's `local` values (the same length on every rank), one `Vec` per rank in rank
/// order.
pub(crate) fn gather_f64(c: &dyn Collective, local: &[f64]) -> Vec<Vec<f64>> {
    gather(c, local, f64::to_le_bytes, f64::from_le_bytes)
}

/// Every rank's `local` values, one `Vec` per rank in rank order.
pub(crate) fn gather_f32(c: &dyn Collective, local: &[f32]) -> Vec<Vec<f32>> {
    gather(c, local, f32::to_le_bytes, f32::from_le_bytes)
}

/// Every rank's `local` values, sent as their `N` little-endian bytes each.
fn gather<T: Copy, const N: usize>(
    c: &dyn Collective,
    local: &[T],
    to_bytes: fn(T) -> [u8; N],
    from_bytes: fn([u8; N]) -> T,
) -> Vec<Vec<T>> {
    let bytes: Vec<u8> = local.iter().flat_map(|&v| to_bytes(v)).collect();
    let mut all = vec![0u8; bytes.len() * c.world_size()];
    c.all_gather(&bytes, &mut all);
    (0..c.world_size())
        .map(|rank| {
            all[rank * bytes.len()..(rank + 1) * bytes.len()]
                .chunks_exact(N)
                .map(|b| from_bytes(b.try_into().expect("N bytes")))
                .collect()
        })
        .collect()
}

/// The element-wise mean of every rank's `local` values, summed in `f64` in rank order.
pub(crate) fn mean_f32(c: &dyn Collective, local: &[f32]) -> Vec<f32> {
    let ranks = gather_f32(c, local);
    let scale = 1.0 / ranks.len() as f64;
    (0..local.len())
        .map(|i| (ranks.iter().map(|r| f64::from(r[i])).sum::<f64>() * scale) as f32)
        .collect()
}

/// Rank 0's `local` values (every rank passes the same length).
pub(crate) fn from_rank_0(c: &dyn Collective, local: &[f32]) -> Vec<f32> {
    gather_f32(c, local).swap_remove(0)
}

/// Every rank's `local` bytes, one `Vec` per rank in rank order.
fn gather_bytes(c: &dyn Collective, local: &[u8]) -> Vec<Vec<u8>> {
    gather(c, local, |b| [b], |[b]| b)
}

/// Whether `flag` is set on any rank.
pub(crate) fn any(c: &dyn Collective, flag: bool) -> bool {
    gather_bytes(c, &[u8::from(flag)]).iter().any(|f| f[0] != 0)
}

/// The ranks whose `value` differs from this rank's (every rank passes a value of the same
/// length): ranks that must agree on something compare it with this.
pub fn ranks_differing(c: &dyn Collective, value: &[u8]) -> Vec<usize> {
    let ranks = gather_bytes(c, value);
    (0..ranks.len()).filter(|&r| ranks[r] != value).collect()
}

/// Normalises `x` to mean 0 and unbiased standard deviation 1 over every rank's values, as
/// [`storage::normalize`](crate::storage::normalize) does over one process's: the mean, then
/// the squared deviations from it, each summed per rank and then in rank order.
pub(crate) fn normalize_across(c: &dyn Collective, x: &mut [f32]) {
    let local_sum = x.iter().map(|&v| f64::from(v)).sum::<f64>();
    let ranks = gather_f64(c, &[x.len() as f64, local_sum]);
    let n: f64 = ranks.iter().map(|r| r[0]).sum();
    if n < 2.0 {
        return;
    }
    let mean = ranks.iter().map(|r| r[1]).sum::<f64>() / n;
    let local_sq = x
        .iter()
        .map(|&v| (f64::from(v) - mean).powi(2))
        .sum::<f64>();
    let var = gather_f64(c, &[local_sq]).iter().map(|r| r[0]).sum::<f64>() / (n - 1.0);
    crate::storage::standardize(x, mean, var);
}

pub mod threads {
    //! Ranks as threads of one process, exchanging through shared memory: data-parallel
    //! learners on one machine without a distributed engine (the CPU learner's update is
    //! split this way over cores), and the learner's unit tests. A rank that stops calling
    //! leaves the others waiting: end the process when one fails.

    use std::sync::{Arc, Barrier, Mutex};

    use super::Collective;

    /// One rank of a group of threads.
    pub struct ThreadRank {
        rank: usize,
        shared: Arc<(Barrier, Mutex<Vec<Vec<u8>>>)>,
    }

    /// `n` ranks; give each to its own thread.
    pub fn group(n: usize) -> Vec<ThreadRank> {
        let shared = Arc::new((Barrier::new(n), Mutex::new(vec![Vec::new(); n])));
        (0..n)
            .map(|rank| ThreadRank {
                rank,
                shared: shared.clone(),
            })
            .collect()
    }

    impl Collective for ThreadRank {
        fn rank(&self) -> usize {
            self.rank
        }
        fn world_size(&self) -> usize {
            self.shared
                .1
                .lock()
                .unwrap_or_else(|e| e.into_inner())
                .len()
        }
        fn all_gather(&self, local: &[u8], out: &mut [u8]) {
            let (barrier, slots) = &*self.shared;
            slots.lock().unwrap_or_else(|e| e.into_inner())[self.rank] = local.to_vec();
            barrier.wait();
            let all: Vec<u8> = slots.lock().unwrap_or_else(|e| e.into_inner()).concat();
            out.copy_from_slice(&all);
            // Nobody writes the next round's slot before everyone has read this one.
            barrier.wait();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::threads::group;
    use super::*;
    use crate::storage::normalize;

    /// Normalising across ranks equals normalising the ranks' values concatenated in one
    /// process (to f32 rounding), and every rank gets the same bits.
    #[test]
    fn normalizing_across_ranks_matches_one_process() {
        let data: Vec<f32> = (0..40)
            .map(|i| ((i * 7919) % 97) as f32 * 0.31 - 9.0)
            .collect();
        let mut whole = data.clone();
        normalize(&mut whole);
        let results: Vec<Vec<f32>> = std::thread::scope(|s| {
            let handles: Vec<_> = group(2)
                .into_iter()
                .map(|rank| {
                    let mut x = data[rank.rank() * 20..(rank.rank() + 1) * 20].to_vec();
                    s.spawn(move || {
                        normalize_across(&rank, &mut x);
                        assert!(any(&rank, rank.rank() == 1));
                        assert!(!any(&rank, false));
                        x
                    })
                })
                .collect();
            handles.into_iter().map(|h| h.join().unwrap()).collect()
        });
        let joined = results.concat();
        for (a, b) in joined.iter().zip(&whole) {
            assert!((a - b).abs() < 1e-6, "{a} vs {b}");
        }
    }

    /// Each rank learns which ranks hold another value than its own.
    #[test]
    fn ranks_name_those_that_differ() {
        let results: Vec<Vec<usize>> = std::thread::scope(|s| {
            let handles: Vec<_> = group(3)
                .into_iter()
                .map(|rank| {
                    s.spawn(move || {
                        let value = if rank.rank() == 2 { b"xy" } else { b"ab" };
                        ranks_differing(&rank, value)
                    })
                })
                .collect();
            handles.into_iter().map(|h| h.join().unwrap()).collect()
        });
        assert_eq!(results, vec![vec![2], vec![2], vec![0, 1]]);
    }

    /// The mean over ranks is summed in rank order: every rank gets the same value.
    #[test]
    fn mean_and_rank_0_values() {
        let results: Vec<(Vec<f32>, Vec<f32>)> = std::thread::scope(|s| {
            let handles: Vec<_> = group(3)
                .into_iter()
                .map(|rank| {
                    s.spawn(move || {
                        let local = vec![rank.rank() as f32, 1.0 + rank.rank() as f32 * 0.5];
                        (mean_f32(&rank, &local), from_rank_0(&rank, &local))
                    })
                })
                .collect();
            handles.into_iter().map(|h| h.join().unwrap()).collect()
        });
        for (mean, root) in results {
            assert_eq!(mean, vec![1.0, 1.5]);
            assert_eq!(root, vec![0.0, 1.0]);
        }
    }
}
