//! The PPO update: epochs over the minibatches of one permutation, the clipped surrogate and
//! value losses with the entropy bonus, the KL-adaptive learning rate applied per minibatch
//! before its gradient step, and the all-or-nothing commit of an update.

use std::f32::consts::PI;

use burn::optim::GradientsParams;
use burn::tensor::{Int, Tensor};

use super::grad_clip::clip_gradients;
use super::minibatch::Minibatch;
use super::tensor::{index_tensor, mean_all, spread_rows, sum_all};
use super::{MAX_ROLLOUT_ROWS, Ppo, tensor1, values};
use crate::RlError;
use crate::cfg::Schedule;

/// Mean losses of one update (over epochs and minibatches).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct LossStats {
    /// Value-function loss.
    pub value: f32,
    /// Clipped surrogate loss.
    pub surrogate: f32,
    /// Mean policy entropy.
    pub entropy: f32,
}

/// The loss terms of one minibatch.
pub(super) struct MinibatchLosses {
    /// Mean KL divergence from the sampling policy (shape `[1]`, no gradient).
    pub(super) kl: Tensor<1>,
    /// Clipped surrogate loss.
    pub(super) surrogate: Tensor<1>,
    /// (Clipped) value loss.
    pub(super) value: Tensor<1>,
    /// Policy entropy.
    pub(super) entropy: Tensor<1>,
}

impl Ppo {
    /// The PPO update over the stored rollout; clears the storage. An update that fails leaves
    /// the network, the optimiser, the learning rate and the rollout as they were.
    pub fn update(&mut self) -> Result<LossStats, RlError> {
        if self.fused.is_some() {
            return self.fused_update();
        }
        self.rollout_model = None;
        let cfg = self.cfg.clone();
        let b = self.storage.batch_size();
        let m = b / cfg.num_mini_batches;
        if m == 0 {
            return Err(RlError::EnvMismatch(format!(
                "{b} transitions cannot fill {} minibatches",
                cfg.num_mini_batches
            )));
        }
        if b > MAX_ROLLOUT_ROWS {
            return Err(RlError::EnvMismatch(format!(
                "a rollout of {b} transitions is more than an update takes ({MAX_ROLLOUT_ROWS}); \
                 use fewer envs or steps per env"
            )));
        }
        // One permutation per update, reused by every epoch (RSL-RL's generator).
        let perm = self.take_shuffle(self.shuffle_len());
        // A failed update leaves the network, the optimiser and the learning rate as they
        // were (tensors are shared, so this copies no weights).
        let before = (
            self.model.clone(),
            self.optimizer.clone(),
            self.learning_rate,
        );
        let mut totals: Option<Tensor<1>> = None;
        let rollout = Minibatch::upload(
            &self.storage,
            &self.step_tensors,
            &perm,
            m,
            cfg.normalize_advantage_per_mini_batch,
            &self.device,
        );
        // Each minibatch's rows, uploaded once for all epochs.
        let rows: Vec<Tensor<1, Int>> = perm
            .chunks_exact(m)
            .map(|chunk| index_tensor(chunk, &self.device))
            .collect();
        for _ in 0..cfg.num_learning_epochs {
            for rows in &rows {
                let batch = rollout.select(rows);
                let losses = self.step_minibatch(batch);
                totals = Some(match totals {
                    Some(t) => t + losses,
                    None => losses,
                });
            }
        }
        let steps = (cfg.num_learning_epochs * cfg.num_mini_batches) as f32;
        // One read for the whole update, the learning rate with the losses: a NaN in any
        // minibatch's losses makes its sum NaN.
        let totals = totals.expect("an update has at least one minibatch");
        let read = values(Tensor::cat(vec![totals, self.optimizer.learning_rate()], 0));
        let [value, surrogate, entropy, learning_rate] = read[..] else {
            unreachable!("three losses per minibatch and the learning rate")
        };
        if !(value.is_finite() && surrogate.is_finite()) {
            let e = RlError::NonFinite(format!(
                "training diverged: the PPO loss is not finite (mean value loss {}, surrogate {} \
                 over the update; learning rate {:.2e} at its end; rollout {}); lower the \
                 learning rate or check the rewards",
                value / steps,
                surrogate / steps,
                learning_rate,
                self.storage.extremes()
            ));
            (self.model, self.optimizer, self.learning_rate) = before;
            return Err(e);
        }
        self.learning_rate = f64::from(learning_rate);
        // Only now: an update that failed can be run again on the same rollout, with the same
        // permutation.
        self.updates += 1;
        self.storage.step = 0;
        self.step_tensors.clear();
        Ok(LossStats {
            value: value / steps,
            surrogate: surrogate / steps,
            entropy: entropy / steps,
        })
    }

    /// The losses of a minibatch under the current network, and the KL divergence from the
    /// sampling policy (a plain number; it steers the adaptive learning rate).
    pub(super) fn minibatch_losses(&self, mb: Minibatch) -> MinibatchLosses {
        let cfg = &self.cfg;
        let s = &self.storage;
        let (rows, na) = (mb.rows(), s.num_actions);
        let Minibatch {
            obs,
            critic_obs,
            actions,
            mu: old_mu,
            log_prob: old_log_prob,
            advantages,
            returns,
            values: old_values,
        } = mb;
        let old_sigma = tensor1(s.sigma.clone(), &self.device).reshape([1, na]);

        let critic_obs = critic_obs.unwrap_or_else(|| obs.clone());
        let mu = self.model.action_mean(obs);
        let sigma = self.model.action_std().reshape([1, na]);
        let log_sigma_sum = sum_all(sigma.clone().log());
        // log N(a; μ, σ) summed over actions: −Σ (a−μ)²/(2σ²) − Σ ln σ − A/2·ln 2π.
        // σ and Σ ln σ reach every row through `spread_rows`: their gradients are sums over
        // the rows.
        let log_prob = (actions - mu.clone())
            .powi_scalar(2)
            .div(spread_rows(
                sigma.clone().powi_scalar(2).mul_scalar(2.0),
                rows,
            ))
            .sum_dim(1)
            .reshape([rows])
            .neg()
            .sub(spread_rows(log_sigma_sum.clone().reshape([1, 1]), rows).reshape([rows]))
            .sub_scalar(na as f32 * 0.5 * (2.0 * PI).ln());
        // The entropy of a state-independent Gaussian is the same for every row.
        let entropy = log_sigma_sum.add_scalar(na as f32 * (0.5 + 0.5 * (2.0 * PI).ln()));

        let (mu_d, sigma_d) = (mu.detach(), sigma.detach());
        let kl = (sigma_d
            .clone()
            .div(old_sigma.clone())
            .add_scalar(1e-5)
            .log()
            + (old_sigma.powi_scalar(2) + (old_mu - mu_d).powi_scalar(2))
                .div(sigma_d.powi_scalar(2).mul_scalar(2.0)))
        .sub_scalar(0.5)
        .sum_dim(1)
        .reshape([rows]);
        let kl = mean_all(kl);

        let ratio = (log_prob - old_log_prob).exp();
        let eps = cfg.clip_param;
        let surrogate = advantages.clone().neg().mul(ratio.clone());
        let surrogate_clipped = advantages.neg().mul(ratio.clamp(1.0 - eps, 1.0 + eps));
        let surrogate = mean_all(surrogate.max_pair(surrogate_clipped));

        let value = self.model.value(critic_obs).reshape([rows]);
        let value = if cfg.use_clipped_value_loss {
            let clipped = old_values.clone() + (value.clone() - old_values).clamp(-eps, eps);
            let a = (value - returns.clone()).powi_scalar(2);
            let b = (clipped - returns).powi_scalar(2);
            mean_all(a.max_pair(b))
        } else {
            mean_all((returns - value).powi_scalar(2))
        };
        MinibatchLosses {
            kl,
            surrogate,
            value,
            entropy,
        }
    }

    /// One gradient step on a minibatch. Returns its value, surrogate and entropy losses as a
    /// `[3]` tensor, left on the device (the update checks their sum). The step never waits
    /// for the device: the adaptive learning rate, the gradient clipping and Adam all run
    /// there.
    fn step_minibatch(&mut self, mb: Minibatch) -> Tensor<1> {
        let l = self.minibatch_losses(mb);
        let cfg = &self.cfg;
        let loss = l.surrogate.clone() + l.value.clone().mul_scalar(cfg.value_loss_coef)
            - l.entropy.clone().mul_scalar(cfg.entropy_coef);
        let mut grads = GradientsParams::from_grads(loss.backward(), &self.model);
        let losses = Tensor::cat(
            vec![l.value.detach(), l.surrogate.detach(), l.entropy.detach()],
            0,
        );
        let kl = match self.collective.as_deref() {
            Some(c) => super::distributed::average_gradients(c, &self.model, &mut grads, l.kl),
            None => l.kl,
        };
        if cfg.schedule == Schedule::Adaptive {
            // A NaN KL leaves the rate as it is; the update then fails on its losses.
            self.optimizer.adapt(kl, cfg.desired_kl);
        }
        clip_gradients(&self.model, &mut grads, cfg.grad_clip, cfg.max_grad_norm);
        let model = self.model.clone();
        self.model = self.optimizer.step(model, grads);
        losses
    }
}

#[cfg(test)]
mod tests {
    use std::f32::consts::PI;

    use burn::module::Module;

    use crate::RlError;
    use crate::cfg::Schedule;
    use crate::ppo::fixtures::{ppo, rollout, whole_rollout};
    use crate::ppo::{Ppo, tensor2, values};

    /// Before any update the network is the sampling policy: the ratio is 1, so the surrogate
    /// loss is −mean(advantage) (0 over a whole normalised rollout), and the KL is RSL-RL's
    /// floor `A·ln(1 + 1e-5)` (its formula adds 1e-5 inside the log).
    #[test]
    fn first_minibatch_sees_the_sampling_policy() {
        let mut p = ppo(16, 4);
        rollout(&mut p);
        let l = p.minibatch_losses(whole_rollout(&p));
        let floor = 2.0 * (1.0f32 + 1e-5).ln();
        let kl = l.kl.into_scalar::<f32>();
        assert!((kl - floor).abs() < 1e-6, "kl {kl}");
        let surrogate = l.surrogate.into_scalar::<f32>();
        assert!(surrogate.abs() < 1e-5, "surrogate {surrogate}");
        // Entropy of N(·, 0.7²) in 2 dimensions: 2·(0.5 + 0.5 ln 2π + ln 0.7).
        let expected = 2.0 * (0.5 + 0.5 * (2.0 * PI).ln() + 0.7f32.ln());
        assert!((l.entropy.into_scalar::<f32>() - expected).abs() < 1e-5);
    }

    /// An update whose losses turn non-finite (NaN returns) fails without touching the
    /// network, the learning rate (on the host and on the device), Adam's step count or the
    /// shuffle, under either schedule; the rollout stays for another attempt.
    #[test]
    fn a_failed_update_leaves_the_policy_as_it_was() {
        for schedule in [Schedule::Adaptive, Schedule::Fixed] {
            let mut p = ppo(16, 4);
            p.cfg.schedule = schedule;
            rollout(&mut p);
            p.storage.returns.fill(f32::NAN);
            let probe = tensor2(vec![0.3, -0.2, 0.5], 1, 3, &p.device);
            let outputs = |p: &Ppo| {
                let m = p.model.valid();
                (
                    values(m.action_mean(probe.clone())),
                    values(m.value(probe.clone())),
                    values(m.action_std()),
                )
            };
            let state = |p: &Ppo| {
                let rate = values(p.optimizer.learning_rate());
                (p.learning_rate(), rate, p.optimizer.steps(), p.updates)
            };
            let before = (outputs(&p), state(&p));
            assert!(matches!(p.update(), Err(RlError::NonFinite(_))));
            assert_eq!((outputs(&p), state(&p)), before, "{schedule:?}");
            assert_eq!(p.storage.step, 4, "the rollout is kept");
        }
    }
}
