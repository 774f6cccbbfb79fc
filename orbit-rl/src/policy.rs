//! A trained policy for inference (RSL-RL's `get_inference_policy`): a checkpoint's
//! observation normaliser and actor, giving mean actions.

use std::path::Path;

use burn::tensor::Device;

use crate::RlError;
use crate::checkpoint::read_state;
use crate::model::ActorCritic;
use crate::normalizer::EmpiricalNormalizer;
use crate::ppo::{tensor2, values};

/// A trained policy for inference: observation normaliser + actor, mean actions.
pub struct Policy {
    model: ActorCritic,
    normalizer: Option<EmpiricalNormalizer>,
    device: Device,
    num_obs: usize,
    num_actions: usize,
}

impl Policy {
    /// The policy of `model` (its actor) behind `normalizer`, for `num_obs` observations and
    /// `num_actions` actions.
    pub(crate) fn new(
        model: ActorCritic,
        normalizer: Option<EmpiricalNormalizer>,
        device: Device,
        num_obs: usize,
        num_actions: usize,
    ) -> Self {
        Self {
            num_obs,
            model,
            normalizer,
            device,
            num_actions,
        }
    }

    /// Loads a checkpoint (`base` without extension) onto `device`.
    pub fn load(base: &Path, device: Device) -> Result<Self, RlError> {
        let state = read_state(base)?;
        let model = ActorCritic::new(
            &state.policy,
            state.num_obs,
            state.num_critic_obs,
            state.num_actions,
            0,
            &device,
        );
        let model = crate::ppo::load_model(model, base)?;
        let policy = Self::new(
            model,
            state.obs_normalizer,
            device,
            state.num_obs,
            state.num_actions,
        );
        policy.check_finite(base)?;
        Ok(policy)
    }

    /// Fails, naming the checkpoint `base` and the part, when the policy holds non-finite
    /// numbers: its normaliser's statistics, or weights that give a non-finite action for an
    /// observation of zeros (a checkpoint saved from a diverged run, or damaged).
    pub(crate) fn check_finite(&self, base: &Path) -> Result<(), RlError> {
        if let Some(part) = self.normalizer.as_ref().and_then(|n| n.first_non_finite()) {
            return Err(RlError::NonFinite(format!(
                "{}: the observation normaliser's {part} is not finite: the checkpoint was \
                 saved from a diverged run or is damaged; load an earlier checkpoint",
                base.with_extension("json").display()
            )));
        }
        let probe = self.act(&vec![0.0; self.num_obs]);
        if let Some(i) = orbit_core::parallel::first_non_finite(&probe) {
            return Err(RlError::NonFinite(format!(
                "{}: the actor's weights are not finite (its action {i} for zero observations is \
                 {}): the checkpoint was saved from a diverged run or is damaged; load an \
                 earlier checkpoint",
                base.with_extension("bpk").display(),
                probe[i]
            )));
        }
        Ok(())
    }

    /// Observation width the policy expects.
    pub fn num_obs(&self) -> usize {
        self.num_obs
    }

    /// Mean actions for a batch of raw observations (`[rows, num_obs]`).
    pub fn act(&self, obs: &[f32]) -> Vec<f32> {
        let mut x = obs.to_vec();
        if let Some(n) = &self.normalizer {
            n.normalize(&mut x);
        }
        let rows = x.len() / self.num_obs;
        let t = tensor2(x, rows, self.num_obs, &self.device);
        let a = values(self.model.action_mean(t));
        debug_assert_eq!(a.len(), rows * self.num_actions);
        a
    }
}
