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

use std::collections::BTreeMap;

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

/// Every rank's `local` bytes, which may differ in length between ranks, one `Vec` per rank in
/// rank order.
fn gather_var_bytes(c: &dyn Collective, local: &[u8]) -> Vec<Vec<u8>> {
    let lens: Vec<usize> = gather(
        c,
        &[local.len() as u64],
        u64::to_le_bytes,
        u64::from_le_bytes,
    )
    .iter()
    .map(|l| l[0] as usize)
    .collect();
    let mut padded = local.to_vec();
    padded.resize(lens.iter().copied().max().unwrap_or(0), 0);
    let mut ranks = gather_bytes(c, &padded);
    for (bytes, len) in ranks.iter_mut().zip(lens) {
        bytes.truncate(len);
    }
    ranks
}

/// Named sums and their counts added up over every rank, in rank order (a name missing on a
/// rank counts nothing there).
pub(crate) fn sum_named(
    c: &dyn Collective,
    local: &BTreeMap<String, (f64, usize)>,
) -> BTreeMap<String, (f64, usize)> {
    let mut bytes = Vec::new();
    for (name, &(sum, count)) in local {
        bytes.extend((name.len() as u64).to_le_bytes());
        bytes.extend(name.as_bytes());
        bytes.extend(sum.to_le_bytes());
        bytes.extend((count as u64).to_le_bytes());
    }
    let word = |b: &[u8], at: usize| -> [u8; 8] { b[at..at + 8].try_into().expect("8 bytes") };
    let mut all: BTreeMap<String, (f64, usize)> = BTreeMap::new();
    for rank in gather_var_bytes(c, &bytes) {
        let mut at = 0;
        while at < rank.len() {
            let len = u64::from_le_bytes(word(&rank, at)) as usize;
            let name = String::from_utf8_lossy(&rank[at + 8..at + 8 + len]).into_owned();
            at += 8 + len;
            let entry = all.entry(name).or_default();
            entry.0 += f64::from_le_bytes(word(&rank, at));
            entry.1 += u64::from_le_bytes(word(&rank, at + 8)) as usize;
            at += 16;
        }
    }
    all
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
    //! split this way over cores), and the learner's unit tests. A rank that fails calls
    //! [`ThreadRank::abort`]: the others then unwind out of their next exchange with
    //! [`GroupAborted`] instead of waiting for it.

    use std::sync::{Arc, Condvar, Mutex, MutexGuard};

    use super::Collective;

    /// The panic payload with which a rank leaves an exchange of a group that another rank
    /// aborted (raised with `resume_unwind`, so no panic message is printed).
    #[derive(Debug)]
    pub struct GroupAborted {
        /// The rank that aborted.
        pub by: usize,
    }

    /// What the ranks of a group share.
    struct Group {
        size: usize,
        state: Mutex<Round>,
        done: Condvar,
    }

    /// The exchange under way.
    struct Round {
        /// Each rank's bytes for this round.
        slots: Vec<Vec<u8>>,
        /// Ranks that have put theirs.
        arrived: usize,
        /// Rounds completed.
        completed: u64,
        /// The last completed round's bytes, in rank order.
        gathered: Arc<Vec<u8>>,
        /// The rank that aborted the group.
        aborted_by: Option<usize>,
    }

    /// One rank of a group of threads.
    pub struct ThreadRank {
        rank: usize,
        group: Arc<Group>,
    }

    /// `n` ranks; give each to its own thread.
    pub fn group(n: usize) -> Vec<ThreadRank> {
        let group = Arc::new(Group {
            size: n,
            state: Mutex::new(Round {
                slots: vec![Vec::new(); n],
                arrived: 0,
                completed: 0,
                gathered: Arc::new(Vec::new()),
                aborted_by: None,
            }),
            done: Condvar::new(),
        });
        (0..n)
            .map(|rank| ThreadRank {
                rank,
                group: group.clone(),
            })
            .collect()
    }

    impl ThreadRank {
        /// Ends the group's exchanges: every rank waiting in one, or entering one later,
        /// unwinds with [`GroupAborted`].
        pub fn abort(&self) {
            let mut round = self.lock();
            round.aborted_by.get_or_insert(self.rank);
            self.group.done.notify_all();
        }

        fn lock(&self) -> MutexGuard<'_, Round> {
            self.group.state.lock().unwrap_or_else(|e| e.into_inner())
        }
    }

    /// Leaves the exchange of an aborted group.
    fn unwind(by: usize) -> ! {
        std::panic::resume_unwind(Box::new(GroupAborted { by }))
    }

    impl Collective for ThreadRank {
        fn rank(&self) -> usize {
            self.rank
        }
        fn world_size(&self) -> usize {
            self.group.size
        }
        fn all_gather(&self, local: &[u8], out: &mut [u8]) {
            let mut round = self.lock();
            if let Some(by) = round.aborted_by {
                drop(round);
                unwind(by);
            }
            round.slots[self.rank] = local.to_vec();
            round.arrived += 1;
            let this_round = round.completed;
            if round.arrived == self.group.size {
                // The last to arrive completes the round; a rank's next round's bytes go to
                // the slots only after it has left this one.
                round.gathered = Arc::new(round.slots.concat());
                round.arrived = 0;
                round.completed += 1;
                self.group.done.notify_all();
            }
            while round.completed == this_round {
                if let Some(by) = round.aborted_by {
                    drop(round);
                    unwind(by);
                }
                round = self
                    .group
                    .done
                    .wait(round)
                    .unwrap_or_else(|e| e.into_inner());
            }
            let gathered = round.gathered.clone();
            drop(round);
            out.copy_from_slice(&gathered);
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

    /// Named sums add up over ranks that logged different names, and every rank gets the same
    /// totals.
    #[test]
    fn named_sums_add_up_over_ranks_with_different_names() {
        let results: Vec<BTreeMap<String, (f64, usize)>> = std::thread::scope(|s| {
            let handles: Vec<_> = group(3)
                .into_iter()
                .map(|rank| {
                    s.spawn(move || {
                        let r = rank.rank();
                        let mut local = BTreeMap::from([("success".to_string(), (r as f64, 2))]);
                        if r == 1 {
                            local.insert("Episode_Reward/a_longer_name".into(), (2.5, 1));
                        }
                        sum_named(&rank, &local)
                    })
                })
                .collect();
            handles.into_iter().map(|h| h.join().unwrap()).collect()
        });
        let expected = BTreeMap::from([
            ("Episode_Reward/a_longer_name".to_string(), (2.5, 1)),
            ("success".to_string(), (3.0, 6)),
        ]);
        for r in results {
            assert_eq!(r, expected);
        }
    }

    /// A rank's abort wakes the ranks waiting in an exchange, and each leaves it with
    /// `GroupAborted` naming the rank that aborted.
    #[test]
    fn an_abort_releases_the_waiting_ranks() {
        let mut ranks = group(3).into_iter();
        let aborting = ranks.next().unwrap();
        let outcomes: Vec<Option<usize>> = std::thread::scope(|s| {
            let waiting: Vec<_> = ranks
                .map(|rank| {
                    s.spawn(move || {
                        let r = std::panic::catch_unwind(|| any(&rank, true));
                        r.err()
                            .and_then(|p| p.downcast::<threads::GroupAborted>().ok())
                            .map(|a| a.by)
                    })
                })
                .collect();
            std::thread::sleep(std::time::Duration::from_millis(50));
            aborting.abort();
            waiting.into_iter().map(|h| h.join().unwrap()).collect()
        });
        assert_eq!(outcomes, vec![Some(0), Some(0)]);
    }
}
