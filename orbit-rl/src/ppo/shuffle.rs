//! The minibatch permutation of an update: one Fisher–Yates shuffle per update, reused by
//! every epoch, drawn on a helper thread while the rollout is collected.

use orbit_core::rng::EnvRng;

use super::{MAX_ROLLOUT_ROWS, Ppo};
use crate::streams;

/// A shuffle being drawn on a helper thread: the permutation of `len` rows for update number
/// `updates`.
pub(super) struct PendingShuffle {
    updates: u32,
    len: usize,
    handle: std::thread::JoinHandle<Vec<u32>>,
}

/// The permutation of `0..len` that update number `update` uses in every epoch: a
/// Fisher–Yates shuffle drawn from the `(seed, update, SHUFFLE)` stream. Serial (each swap
/// depends on the last), so it is drawn on a helper thread while the rollout is collected.
fn shuffle(seed: u64, update: u32, len: usize) -> Vec<u32> {
    let mut perm: Vec<u32> = (0..len)
        .map(|i| u32::try_from(i).expect("the update checks the rollout's size"))
        .collect();
    let mut rng = EnvRng::new(seed, update, streams::SHUFFLE);
    for i in (1..len).rev() {
        let j = ((u64::from(rng.next_u32()) * (i as u64 + 1)) >> 32) as usize;
        perm.swap(i, j);
    }
    perm
}

impl Ppo {
    /// Rows of the permutation an update of the current storage uses (whole minibatches).
    pub(super) fn shuffle_len(&self) -> usize {
        let mb = self.cfg.num_mini_batches.max(1);
        self.storage.batch_size() / mb * mb
    }

    /// Starts drawing the next update's shuffle on a helper thread (it depends only on the
    /// seed, the update's number and the rollout's size), unless it is already being drawn.
    pub(super) fn draw_next_shuffle(&mut self) {
        let (seed, updates, len) = (self.seed, self.updates, self.shuffle_len());
        let drawn = |p: &PendingShuffle| p.updates == updates && p.len == len;
        if len > MAX_ROLLOUT_ROWS || self.next_shuffle.as_ref().is_some_and(drawn) {
            return;
        }
        // Without a thread the update draws it itself.
        self.next_shuffle = std::thread::Builder::new()
            .name("orbit-shuffle".into())
            .spawn(move || shuffle(seed, updates, len))
            .ok()
            .map(|handle| PendingShuffle {
                updates,
                len,
                handle,
            });
    }

    /// The shuffle of this update: the one drawn during the rollout, or drawn now.
    pub(super) fn take_shuffle(&mut self, len: usize) -> Vec<u32> {
        let updates = self.updates;
        match self.next_shuffle.take() {
            Some(p) if p.updates == updates && p.len == len => p
                .handle
                .join()
                .unwrap_or_else(|_| shuffle(self.seed, updates, len)),
            _ => shuffle(self.seed, updates, len),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::shuffle;
    use crate::ppo::fixtures::{ppo, rollout};

    /// The shuffle drawn on the helper thread during the rollout is a permutation of every
    /// row, the one the update would draw itself; one of another size is drawn again.
    #[test]
    fn the_shuffle_drawn_during_the_rollout_is_the_updates_own() {
        let mut p = ppo(16, 4);
        rollout(&mut p);
        assert!(
            p.next_shuffle.is_some(),
            "drawn at the rollout's first step"
        );
        let drawn = p.take_shuffle(64);
        assert_eq!(drawn, shuffle(5, 0, 64));
        let mut sorted = drawn.clone();
        sorted.sort_unstable();
        assert_eq!(sorted, (0..64).collect::<Vec<u32>>());
        assert_ne!(drawn, sorted, "shuffled");
        assert_ne!(shuffle(5, 1, 64), drawn, "each update draws its own");
        p.draw_next_shuffle();
        assert_eq!(p.take_shuffle(32), shuffle(5, 0, 32));
    }
}
