//! Collecting a rollout: actions sampled from the gradient-free copy of the policy with
//! per-env noise streams, and the tensors of each step kept on the learner's device for the
//! update.

use std::f32::consts::PI;

use burn::module::Module;
use burn::tensor::Tensor;
use orbit_core::parallel::{self, MIN_ENVS_PER_COPY_TASK, MIN_ENVS_PER_TASK, first_non_finite};
use rayon::prelude::*;

use super::{Ppo, tensor2, values};
use crate::RlError;
use crate::model::{ActorCritic, StackedActorCritic};
use crate::storage::RolloutStorage;

/// The tensors of one collected step that the update needs, already on the learner's device.
pub(super) struct StepTensors {
    /// The actor's observations, as the forward pass took them.
    pub(super) obs: Tensor<2>,
    /// The critic's, where they are not the actor's.
    pub(super) critic_obs: Option<Tensor<2>>,
    /// The action means the forward pass computed (kept on the device, never uploaded).
    pub(super) mu: Tensor<2>,
    /// The sampled actions, uploaded with the step (a few MB each time), so that the update
    /// does not start by copying the whole rollout's actions while the device waits.
    pub(super) actions: Tensor<2>,
}

/// `log N(a; μ, σ)` summed over action dimensions, for one row.
fn gaussian_log_prob(a: &[f32], mu: &[f32], sigma: &[f32]) -> f32 {
    let half_log_2pi = 0.5 * (2.0 * PI).ln();
    a.iter()
        .zip(mu)
        .zip(sigma)
        .map(|((&a, &m), &s)| -(a - m).powi(2) / (2.0 * s * s) - s.ln() - half_log_2pi)
        .sum()
}

/// The gradient-free networks that collect a rollout, made at their first use after an update
/// or a load.
pub(super) struct RolloutModel {
    /// A copy of the model.
    pub(super) model: ActorCritic,
    /// Its actor and critic stacked, where they can be (see [`StackedActorCritic`]).
    stacked: Option<StackedActorCritic>,
}

impl Ppo {
    /// The gradient-free copy of the network that collects the rollout, made at its first use
    /// after an update or a load (with the action σ it samples with).
    pub(super) fn rollout_model(&mut self) -> &RolloutModel {
        if self.rollout_model.is_none() {
            let model = self.model.valid();
            self.sigma = values(model.action_std());
            let stacked = StackedActorCritic::new(&model);
            self.load_rollout_kernel(stacked.as_ref());
            self.rollout_model = Some(RolloutModel { model, stacked });
        }
        self.rollout_model.as_ref().expect("just set")
    }

    /// Builds the collection kernels at their first use and loads the current parameters into
    /// them. Where they cannot be built the rollout is collected with burn's forward pass,
    /// which gives the same values to float rounding; the reason is logged once.
    fn load_rollout_kernel(&mut self, stacked: Option<&StackedActorCritic>) {
        use super::rollout_kernel::RolloutKernel;
        let Some(stacked) = stacked else {
            self.rollout_kernel = None;
            return;
        };
        if !self.rollout_kernel_tried {
            self.rollout_kernel_tried = true;
            let (rows, fused) = (self.storage.num_envs, self.fused.is_some());
            match RolloutKernel::for_learner(&self.device, stacked, rows, fused) {
                Ok(kernel) => self.rollout_kernel = kernel,
                Err(e) => tracing::warn!("collecting rollouts with burn's forward pass: {e}"),
            }
        }
        if let Some(kernel) = &mut self.rollout_kernel
            && let Err(e) = kernel.load(stacked)
        {
            tracing::warn!("collecting rollouts with burn's forward pass: {e}");
            self.rollout_kernel = None;
        }
    }

    /// Samples actions for the current observations (`a = μ + σ·ε`), writes them to `actions`
    /// and stores the observations, values, log-probabilities and means of this step.
    pub fn act(
        &mut self,
        obs: &[f32],
        critic_obs: &[f32],
        actions: &mut [f32],
    ) -> Result<(), RlError> {
        let s = &self.storage;
        let (n, na, t) = (s.num_envs, s.num_actions, s.step);
        let (no, nc) = (s.num_obs, s.num_critic_obs);
        assert!(
            t < s.num_steps,
            "act called more often than num_steps_per_env"
        );
        // A step that failed before (a non-finite output) is taken again from the start.
        self.step_tensors.truncate(t);
        if t == 0 {
            self.draw_next_shuffle();
        }
        let device = self.device.clone();
        // The critic's own observations, where it has them (not the same values: an env
        // without a `critic` group uploads and stores them once).
        let separate_critic = (!std::ptr::eq(obs, critic_obs)).then_some(critic_obs);
        self.rollout_model();
        let kernel_out = match self.rollout_kernel.as_mut() {
            Some(kernel) => Some(kernel.forward(obs, separate_critic)?),
            None => None,
        };
        // The step's inputs as burn tensors: burn's update keeps them on its device (the fused
        // update takes them below), and burn's forward pass reads them.
        let burn_inputs = || {
            let actor = tensor2(parallel::to_vec(obs), n, no, &device);
            let critic = separate_critic.map(|c| tensor2(parallel::to_vec(c), n, nc, &device));
            (actor, critic)
        };
        let inputs = self.fused.is_none().then(burn_inputs);
        let rollout = self.rollout_model.as_ref().expect("built above");
        // Means and values come back in one read (each read waits for the device).
        let (mean, out, stacked) = match (kernel_out, &rollout.stacked) {
            // The kernels' outputs are laid out as the stacked pass's.
            (Some(out), _) => {
                let mean = inputs
                    .is_some()
                    .then(|| tensor2(out[..n * na].to_vec(), n, na, &device));
                (mean, out, true)
            }
            (None, stacked) => {
                let (actor, critic) = inputs.clone().unwrap_or_else(burn_inputs);
                match stacked {
                    Some(stacked) => {
                        debug_assert_eq!(stacked.num_actions(), na);
                        let both = stacked.forward(actor, critic);
                        let mean = both.clone().narrow(0, 0, 1).reshape([n, na]);
                        (Some(mean), values(both), true)
                    }
                    None => {
                        let mean = rollout.model.action_mean(actor.clone());
                        let value = rollout.model.value(critic.unwrap_or(actor));
                        let both = values(Tensor::cat(vec![mean.clone(), value], 1));
                        (Some(mean), both, false)
                    }
                }
            }
        };
        let s = &mut self.storage;
        let mu = RolloutStorage::rows(&mut s.mu, t, n, na);
        let value = RolloutStorage::rows(&mut s.values, t, n, 1);
        if stacked {
            // `[2, n, na]`: the means, then the values in each row's first column.
            let (means, value_rows) = out.split_at(n * na);
            mu.copy_from_slice(means);
            value
                .par_iter_mut()
                .zip(value_rows.par_chunks(na))
                .with_min_len(MIN_ENVS_PER_COPY_TASK)
                .for_each(|(v, row)| *v = row[0]);
        } else {
            mu.par_chunks_mut(na)
                .zip(value.par_iter_mut())
                .zip(out.par_chunks(na + 1))
                .with_min_len(MIN_ENVS_PER_COPY_TASK)
                .for_each(|((m, v), row)| {
                    m.copy_from_slice(&row[..na]);
                    *v = row[na];
                });
        }
        if let Some(normalizer) = &self.value_normalizer {
            normalizer.denormalize(value);
        }
        if first_non_finite(mu).is_some() || first_non_finite(value).is_some() {
            return Err(RlError::NonFinite(
                "training diverged: the policy's output is not finite for finite observations \
                 (the weights or the observation normaliser have become non-finite); lower the \
                 learning rate or check the rewards"
                    .into(),
            ));
        }
        let sigma = &self.sigma;
        // Each env draws from its own stream, so the envs run in parallel with the same result.
        let mu = &s.mu[t * n * na..(t + 1) * n * na];
        actions
            .par_chunks_mut(na)
            .zip(mu.par_chunks(na))
            .zip(self.noise.par_iter_mut())
            .zip(s.actions_log_prob[t * n..(t + 1) * n].par_iter_mut())
            .with_min_len(MIN_ENVS_PER_TASK)
            .for_each(|(((a, m), rng), log_prob)| {
                for ((a, &m), &sd) in a.iter_mut().zip(m).zip(sigma) {
                    *a = m + sd * rng.normal();
                }
                *log_prob = gaussian_log_prob(a, m, sigma);
            });
        s.sigma.copy_from_slice(sigma);
        match (inputs, mean) {
            (Some((obs, critic_obs)), Some(mu)) => self.step_tensors.push(StepTensors {
                obs,
                critic_obs,
                mu,
                actions: tensor2(parallel::to_vec(actions), n, na, &device),
            }),
            _ => self.fused_write_step(t, obs, separate_critic, actions)?,
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use std::f32::consts::PI;

    use orbit_core::parallel::MIN_ENVS_PER_TASK;

    use super::gaussian_log_prob;
    use crate::RlError;
    use crate::ppo::fixtures::ppo;

    /// A step rejected for a non-finite policy output stores nothing that counts: taking it
    /// again with finite observations gives what a clean first attempt gives, and the update
    /// sees one step's observations, not two.
    #[test]
    fn a_rejected_step_is_taken_again_from_the_start() {
        let obs: Vec<f32> = (0..4 * 3).map(|i| (i % 5) as f32 * 0.2 - 0.4).collect();
        let mut clean = ppo(4, 1);
        let mut expected = vec![0.0; 4 * 2];
        clean.act(&obs, &obs, &mut expected).unwrap();

        let mut p = ppo(4, 1);
        let mut actions = vec![0.0; 4 * 2];
        let mut bad = obs.clone();
        bad[4] = f32::NAN;
        assert!(matches!(
            p.act(&bad, &bad, &mut actions),
            Err(RlError::NonFinite(_))
        ));
        p.act(&obs, &obs, &mut actions).unwrap();
        assert_eq!(actions, expected);
        assert_eq!(p.storage.mu, clean.storage.mu);
        assert_eq!(p.storage.values, clean.storage.values);
        assert_eq!(p.storage.actions_log_prob, clean.storage.actions_log_prob);
        assert_eq!(p.step_tensors.len(), 1);
    }

    /// Each env samples from its own stream, so the actions and their log-probabilities are
    /// the same bits on one thread and on four (with enough envs for several parallel tasks),
    /// and each log-probability is that of its own row.
    #[test]
    fn sampled_actions_do_not_depend_on_threads() {
        let n = 4 * MIN_ENVS_PER_TASK + 3;
        let sample = |threads: usize| {
            orbit_core::parallel::on_threads(threads, || {
                let mut p = ppo(n, 1);
                let obs: Vec<f32> = (0..n * 3).map(|i| (i % 11) as f32 * 0.1).collect();
                let mut actions = vec![0.0; n * 2];
                p.act(&obs, &obs, &mut actions).unwrap();
                (actions, p.storage)
            })
        };
        let (a1, s1) = sample(1);
        let (a4, s4) = sample(4);
        assert_eq!(a1, a4);
        assert_eq!(s1.actions_log_prob, s4.actions_log_prob);
        let e = n - 1;
        let row = e * 2..e * 2 + 2;
        let expected = gaussian_log_prob(&a1[row.clone()], &s1.mu[row], &s1.sigma);
        assert_eq!(s1.actions_log_prob[e], expected);
    }

    /// Stored log-probabilities are those of the sampled actions under N(μ, σ²).
    #[test]
    fn log_prob_of_a_standard_normal() {
        let lp = gaussian_log_prob(&[1.0, 0.0], &[0.0, 0.0], &[1.0, 2.0]);
        let expected = -0.5 - (2.0 * PI).ln() - 2.0f32.ln();
        assert!((lp - expected).abs() < 1e-6);
    }
}
