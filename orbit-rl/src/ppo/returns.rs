//! Rewards and returns: the time-out bootstrap of each step, GAE over the rollout (in
//! [`RolloutStorage::compute_returns`](crate::storage::RolloutStorage::compute_returns)) and,
//! with `normalize_value`, the critic's targets in the returns' running statistics.

use super::{Ppo, tensor2, values};

impl Ppo {
    /// Stores the step's rewards and dones; a time-out adds `γ·V(s_t)` to the reward, since
    /// the true terminal observation is gone (RSL-RL's bootstrap).
    pub fn process_env_step(&mut self, rewards: &[f32], dones: &[bool], time_outs: &[bool]) {
        let gamma = self.cfg.gamma;
        let s = &mut self.storage;
        let (n, t) = (s.num_envs, s.step);
        for e in 0..n {
            let i = t * n + e;
            let bootstrap = if time_outs[e] {
                gamma * s.values[i]
            } else {
                0.0
            };
            s.rewards[i] = rewards[e] + bootstrap;
            s.dones[i] = f32::from(u8::from(dones[e]));
        }
        s.step += 1;
    }

    /// The critic's values for `critic_obs` from the collection kernels, where they run (they
    /// stack the networks, so the actor's inputs are as wide as the critic's).
    fn last_values_by_kernel(&mut self, critic_obs: &[f32]) -> Option<Vec<f32>> {
        self.rollout_model();
        let (n, na) = (self.storage.num_envs, self.storage.num_actions);
        let out = self
            .rollout_kernel
            .as_mut()?
            .forward(critic_obs, None)
            .ok()?;
        Some(out[n * na..].chunks(na).map(|row| row[0]).collect())
    }

    /// Computes returns and advantages with the values of the states after the last step.
    pub fn compute_returns(&mut self, last_critic_obs: &[f32]) {
        let mut last = match self.last_values_by_kernel(last_critic_obs) {
            Some(values) => values,
            None => {
                let (n, nc) = (self.storage.num_envs, self.storage.num_critic_obs);
                let obs = tensor2(last_critic_obs.to_vec(), n, nc, &self.device);
                values(self.rollout_model().model.value(obs))
            }
        };
        if let Some(normalizer) = &self.value_normalizer {
            normalizer.denormalize(&mut last);
        }
        let (gamma, lam) = (self.cfg.gamma, self.cfg.lam);
        let per_mb = self.cfg.normalize_advantage_per_mini_batch;
        let collective = self.collective.as_deref();
        // Replicas normalise the advantages over every rank's rollout.
        self.storage
            .compute_returns(&last, gamma, lam, per_mb || collective.is_some());
        if let (Some(c), false) = (collective, per_mb) {
            crate::collective::normalize_across(c, &mut self.storage.advantages);
        }
        // The critic trains on normalised targets: fold this rollout's returns into the
        // statistics, then express the returns and the old values (for value clipping) in
        // them.
        if let Some(normalizer) = &mut self.value_normalizer {
            normalizer.update_across(collective, &self.storage.returns);
            normalizer.normalize(&mut self.storage.returns);
            normalizer.normalize(&mut self.storage.values);
        }
    }
}

#[cfg(test)]
mod tests {
    use orbit_core::rng::EnvRng;

    use crate::normalizer::EmpiricalNormalizer;
    use crate::ppo::Ppo;
    use crate::ppo::fixtures::ppo;

    /// Fills the storage with one-step episodes whose rewards are `offset − a₀²`, on random
    /// observations, and returns the values the critic predicted for them.
    fn episodic_rollout(p: &mut Ppo, offset: f32, seed: u64) -> Vec<f32> {
        let (n, t) = (p.storage.num_envs, p.storage.num_steps);
        let mut rng = EnvRng::new(seed, 0, 99);
        let mut actions = vec![0.0; n * 2];
        for _ in 0..t {
            let obs: Vec<f32> = (0..n * 3).map(|_| rng.uniform_range(-1.0, 1.0)).collect();
            p.act(&obs, &obs, &mut actions).unwrap();
            let rewards: Vec<f32> = actions.chunks(2).map(|a| offset - a[0] * a[0]).collect();
            p.process_env_step(&rewards, &vec![true; n], &vec![false; n]);
        }
        let predicted = p.storage.values.clone();
        p.compute_returns(&vec![0.0; n * 3]);
        predicted
    }

    /// The mean |V − R| of a second rollout after one update on returns near −260, with and
    /// without value normalisation (the returns of the second rollout are `offset − a₀²`).
    fn value_error_after_one_update(normalize_value: bool) -> f32 {
        let mut p = ppo(64, 2);
        p.cfg.normalize_value = normalize_value;
        p.value_normalizer = normalize_value.then(|| EmpiricalNormalizer::new(1, u64::MAX));
        episodic_rollout(&mut p, -260.0, 1);
        p.update().unwrap();
        let predicted = episodic_rollout(&mut p, -260.0, 2);
        let returns = &p.storage.rewards;
        let error: f32 = predicted
            .iter()
            .zip(returns)
            .map(|(v, r)| (v - r).abs())
            .sum();
        error / predicted.len() as f32
    }

    /// With value normalisation the untrained critic already predicts the running mean of the
    /// returns (its output is scaled by their spread, about 1 here): the error is a few units
    /// against returns of −260. Without it, four Adam steps of 1e-3 leave the critic near its
    /// initial output, almost 260 away.
    #[test]
    fn value_normalisation_puts_the_critic_in_the_returns_units() {
        let normalised = value_error_after_one_update(true);
        let raw = value_error_after_one_update(false);
        assert!(normalised < 0.05 * 260.0, "normalised error {normalised}");
        assert!(raw > 0.9 * 260.0, "raw error {raw}");
    }

    /// After `compute_returns` with value normalisation, the first rollout's returns are in
    /// normalised units: mean 0 and standard deviation `σ/(σ + 0.01)`.
    #[test]
    fn normalised_returns_have_zero_mean() {
        let mut p = ppo(64, 2);
        p.value_normalizer = Some(EmpiricalNormalizer::new(1, u64::MAX));
        episodic_rollout(&mut p, -260.0, 3);
        let r = &p.storage.returns;
        let mean = r.iter().sum::<f32>() / r.len() as f32;
        let var = r.iter().map(|x| (x - mean).powi(2)).sum::<f32>() / r.len() as f32;
        let sigma = p.value_normalizer.as_ref().unwrap().var[0].sqrt();
        assert!(mean.abs() < 1e-4, "mean {mean}");
        assert!(
            (var.sqrt() - sigma / (sigma + 0.01)).abs() < 1e-4,
            "std {}",
            var.sqrt()
        );
    }
}
