//! The rollout on the learner's device for an update, and the minibatches selected from it.

use burn::tensor::{Device, Int, Tensor};

use super::StepTensors;
use super::tensor1;
use crate::storage::RolloutStorage;

/// Rollout rows on the learner's device: the whole rollout of an update (uploaded once, then
/// every minibatch of every epoch is selected from it there: a GPU learner would otherwise
/// gather and upload each minibatch on the host), or one minibatch of it.
pub(super) struct Minibatch {
    pub(super) obs: Tensor<2>,
    /// `None`: the critic observes `obs`.
    pub(super) critic_obs: Option<Tensor<2>>,
    pub(super) actions: Tensor<2>,
    pub(super) mu: Tensor<2>,
    pub(super) log_prob: Tensor<1>,
    pub(super) advantages: Tensor<1>,
    pub(super) returns: Tensor<1>,
    pub(super) values: Tensor<1>,
}

impl Minibatch {
    /// The whole rollout: the tensors of its steps concatenated, the rest of the storage
    /// uploaded. With `per_minibatch` the advantages are normalised within each minibatch of
    /// `perm` (chunks of `m`): the permutation is the same in every epoch, so this is done
    /// once, here.
    pub(super) fn upload(
        s: &RolloutStorage,
        steps: &[StepTensors],
        perm: &[u32],
        m: usize,
        per_minibatch: bool,
        device: &Device,
    ) -> Self {
        assert_eq!(
            steps.len(),
            s.num_steps,
            "the update needs the tensors of every step"
        );
        let cat =
            |f: &dyn Fn(&StepTensors) -> Tensor<2>| Tensor::cat(steps.iter().map(f).collect(), 0);
        let critic_obs = steps
            .iter()
            .any(|st| st.critic_obs.is_some())
            .then(|| cat(&|st| st.critic_obs.clone().unwrap_or_else(|| st.obs.clone())));
        let advantages = s.update_advantages(perm, m, per_minibatch);
        Self {
            obs: cat(&|st| st.obs.clone()),
            critic_obs,
            actions: cat(&|st| st.actions.clone()),
            mu: cat(&|st| st.mu.clone()),
            log_prob: tensor1(s.actions_log_prob.clone(), device),
            advantages: tensor1(advantages, device),
            returns: tensor1(s.returns.clone(), device),
            values: tensor1(s.values.clone(), device),
        }
    }

    /// The rows `idx` (an [`index_tensor`](super::tensor::index_tensor)), in that order.
    pub(super) fn select(&self, idx: &Tensor<1, Int>) -> Self {
        let pick1 = |t: &Tensor<1>| t.clone().select(0, idx.clone());
        let pick2 = |t: &Tensor<2>| t.clone().select(0, idx.clone());
        Self {
            obs: pick2(&self.obs),
            critic_obs: self.critic_obs.as_ref().map(pick2),
            actions: pick2(&self.actions),
            mu: pick2(&self.mu),
            log_prob: pick1(&self.log_prob),
            advantages: pick1(&self.advantages),
            returns: pick1(&self.returns),
            values: pick1(&self.values),
        }
    }

    /// Number of rows.
    pub(super) fn rows(&self) -> usize {
        self.advantages.dims()[0]
    }
}

#[cfg(test)]
mod tests {
    use super::Minibatch;
    use crate::ppo::fixtures::{ppo, rollout};
    use crate::ppo::tensor::index_tensor;
    use crate::ppo::values;

    /// A minibatch holds the storage's rows in the permutation's order, and with per-minibatch
    /// normalisation its advantages have mean 0 and (unbiased) standard deviation 1.
    #[test]
    fn minibatches_select_their_rows_and_normalise_their_advantages() {
        let mut p = ppo(16, 4);
        let (all_obs, all_actions) = rollout(&mut p);
        let perm: Vec<u32> = (0..64).map(|i| (i * 37) % 64).collect();
        let r = Minibatch::upload(&p.storage, &p.step_tensors, &perm, 16, true, &p.device);
        for chunk in perm.chunks_exact(16) {
            let mb = r.select(&index_tensor(chunk, &p.device));
            let (obs, actions, mu) = (values(mb.obs), values(mb.actions), values(mb.mu));
            let s = &p.storage;
            for (row, &i) in chunk.iter().enumerate() {
                let i = i as usize;
                assert_eq!(obs[row * 3..row * 3 + 3], all_obs[i * 3..i * 3 + 3]);
                assert_eq!(actions[row * 2..row * 2 + 2], all_actions[i * 2..i * 2 + 2]);
                assert_eq!(mu[row * 2..row * 2 + 2], s.mu[i * 2..i * 2 + 2]);
            }
            let a = values(mb.advantages);
            let mean = a.iter().sum::<f32>() / 16.0;
            let var = a.iter().map(|v| (v - mean).powi(2)).sum::<f32>() / 15.0;
            assert!(
                mean.abs() < 1e-6 && (var - 1.0).abs() < 1e-5,
                "{mean} {var}"
            );
        }
    }
}
