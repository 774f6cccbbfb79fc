//! Rollout storage (`[T, N, ·]` buffers) and generalised advantage estimation.

/// One iteration's transitions: `T` steps of `N` envs, stored step-major (`[t][env][dim]`).
#[derive(Clone, Debug)]
pub struct RolloutStorage {
    /// Steps per env (`T`).
    pub num_steps: usize,
    /// Envs (`N`).
    pub num_envs: usize,
    /// Actor observation width.
    pub num_obs: usize,
    /// Critic observation width.
    pub num_critic_obs: usize,
    /// Action width.
    pub num_actions: usize,
    /// Rewards (with the time-out bootstrap added).
    pub rewards: Vec<f32>,
    /// 1 where the episode ended (terminated or timed out) after the step.
    pub dones: Vec<f32>,
    /// Critic values of the states.
    pub values: Vec<f32>,
    /// Log-probabilities of the actions under the sampling policy.
    pub actions_log_prob: Vec<f32>,
    /// Action means of the sampling policy.
    pub mu: Vec<f32>,
    /// Action standard deviations of the sampling policy (state-independent: one row).
    pub sigma: Vec<f32>,
    /// GAE returns (`advantages + values`).
    pub returns: Vec<f32>,
    /// Advantages (normalised over the rollout unless PPO normalises per minibatch).
    pub advantages: Vec<f32>,
    /// Steps stored so far.
    pub step: usize,
}

impl RolloutStorage {
    /// The largest magnitudes in the rollout (rewards, returns, action means; the observations
    /// live on the learner's device and are not included)
    /// and the smallest noise std, for diagnosing a diverged update.
    pub fn extremes(&self) -> String {
        // NaN wins (f32::max would drop it).
        let max_abs = |v: &[f32]| {
            v.iter().fold(0.0f32, |m, x| {
                if m.is_nan() || x.is_nan() {
                    f32::NAN
                } else {
                    m.max(x.abs())
                }
            })
        };
        let min_sigma = self.sigma.iter().fold(f32::INFINITY, |m, &x| m.min(x));
        format!(
            "max |reward| {:.3e}, max |return| {:.3e}, max |mean action| {:.3e}, min σ \
             {min_sigma:.3e}",
            max_abs(&self.rewards),
            max_abs(&self.returns),
            max_abs(&self.mu)
        )
    }

    /// The advantages as an update sees them: as stored, or with `per_minibatch` normalised
    /// within each minibatch of `perm` (chunks of `m`; every epoch takes the same ones).
    pub(crate) fn update_advantages(
        &self,
        perm: &[u32],
        m: usize,
        per_minibatch: bool,
    ) -> Vec<f32> {
        let mut advantages = self.advantages.clone();
        if per_minibatch {
            for chunk in perm.chunks_exact(m) {
                let mut a: Vec<f32> = chunk.iter().map(|&i| self.advantages[i as usize]).collect();
                normalize(&mut a);
                for (&i, v) in chunk.iter().zip(a) {
                    advantages[i as usize] = v;
                }
            }
        }
        advantages
    }

    /// Zeroed storage for `num_steps × num_envs` transitions.
    pub fn new(
        num_steps: usize,
        num_envs: usize,
        num_obs: usize,
        num_critic_obs: usize,
        num_actions: usize,
    ) -> Self {
        let b = num_steps * num_envs;
        Self {
            num_steps,
            num_envs,
            num_obs,
            num_critic_obs,
            num_actions,
            rewards: vec![0.0; b],
            dones: vec![0.0; b],
            values: vec![0.0; b],
            actions_log_prob: vec![0.0; b],
            mu: vec![0.0; b * num_actions],
            sigma: vec![0.0; num_actions],
            returns: vec![0.0; b],
            advantages: vec![0.0; b],
            step: 0,
        }
    }

    /// Transitions per iteration (`T·N`).
    pub fn batch_size(&self) -> usize {
        self.num_steps * self.num_envs
    }

    /// Mutable rows of step `t` of a `[T, N, dim]` buffer.
    pub fn rows(buffer: &mut [f32], t: usize, num_envs: usize, dim: usize) -> &mut [f32] {
        &mut buffer[t * num_envs * dim..(t + 1) * num_envs * dim]
    }

    /// Computes GAE returns and advantages from the stored rewards, dones and values and the
    /// values of the states after the last step (RSL-RL's `compute_returns`), then normalises the
    /// advantages over the whole rollout unless `per_mini_batch`.
    pub fn compute_returns(
        &mut self,
        last_values: &[f32],
        gamma: f32,
        lam: f32,
        per_mini_batch: bool,
    ) {
        gae(
            &self.rewards,
            &self.dones,
            &self.values,
            last_values,
            gamma,
            lam,
            &mut self.returns,
            &mut self.advantages,
        );
        if !per_mini_batch {
            normalize(&mut self.advantages);
        }
    }
}

/// Generalised advantage estimation over `[T, N]` buffers:
/// `δ = r_t + (1 − d_t)·γ·V_{t+1} − V_t`, `A_t = δ + (1 − d_t)·γ·λ·A_{t+1}`, `R_t = A_t + V_t`,
/// with `V_T = last_values`. Writes `returns` and the unnormalised `advantages`.
#[allow(clippy::too_many_arguments)]
pub fn gae(
    rewards: &[f32],
    dones: &[f32],
    values: &[f32],
    last_values: &[f32],
    gamma: f32,
    lam: f32,
    returns: &mut [f32],
    advantages: &mut [f32],
) {
    let n = last_values.len();
    let t_max = rewards.len() / n;
    // Backwards over whole steps (contiguous rows, so the inner loop vectorises); `trace`
    // carries each env's advantage to the step before, with the arithmetic of an env-by-env
    // loop.
    let mut trace = vec![0.0f32; n];
    for t in (0..t_max).rev() {
        let row = t * n..(t + 1) * n;
        let next_values = if t == t_max - 1 {
            last_values
        } else {
            &values[(t + 1) * n..(t + 2) * n]
        };
        let inputs = rewards[row.clone()]
            .iter()
            .zip(&dones[row.clone()])
            .zip(&values[row.clone()])
            .zip(next_values);
        let outputs = returns[row.clone()]
            .iter_mut()
            .zip(&mut advantages[row])
            .zip(&mut trace);
        for ((((&reward, &done), &value), &next_value), ((ret, adv), trace)) in inputs.zip(outputs)
        {
            let not_done = 1.0 - done;
            let delta = reward + not_done * gamma * next_value - value;
            *trace = delta + not_done * gamma * lam * *trace;
            *ret = *trace + value;
            *adv = *trace;
        }
    }
}

/// Normalises values to zero mean and unit standard deviation (`(x − μ)/(σ + 1e-8)` with the
/// unbiased `σ`, as `torch.std`). Sums run in `f64` in index order.
pub fn normalize(x: &mut [f32]) {
    let n = x.len();
    if n < 2 {
        return;
    }
    let mean = x.iter().map(|&v| f64::from(v)).sum::<f64>() / n as f64;
    let var = x
        .iter()
        .map(|&v| (f64::from(v) - mean).powi(2))
        .sum::<f64>()
        / (n - 1) as f64;
    standardize(x, mean, var);
}

/// `(x − mean) / (√var + 1e-8)` in place, the last step of [`normalize`].
pub(crate) fn standardize(x: &mut [f32], mean: f64, var: f64) {
    let scale = 1.0 / (var.sqrt() + 1e-8);
    for v in x {
        *v = ((f64::from(*v) - mean) * scale) as f32;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// One env, three steps, hand-computed: γ = 0.5, λ = 0.5, the episode ends after step 1.
    #[test]
    fn gae_matches_hand_values() {
        let rewards = [1.0, 2.0, 3.0];
        let dones = [0.0, 1.0, 0.0];
        let values = [0.5, 1.0, 2.0];
        let (mut ret, mut adv) = ([0.0; 3], [0.0; 3]);
        gae(
            &rewards,
            &dones,
            &values,
            &[4.0],
            0.5,
            0.5,
            &mut ret,
            &mut adv,
        );
        // t=2: δ = 3 + 0.5·4 − 2 = 3, A = 3.
        // t=1: done, δ = 2 − 1 = 1, A = 1 (the trace is cut).
        // t=0: δ = 1 + 0.5·1 − 0.5 = 1, A = 1 + 0.25·1 = 1.25.
        assert_eq!(adv, [1.25, 1.0, 3.0]);
        assert_eq!(ret, [1.75, 2.0, 5.0]);
    }

    /// Two envs interleave step-major and do not mix.
    #[test]
    fn gae_keeps_envs_apart() {
        let rewards = [1.0, 10.0, 1.0, 10.0];
        let (mut ret, mut adv) = ([0.0; 4], [0.0; 4]);
        gae(
            &rewards,
            &[0.0; 4],
            &[0.0; 4],
            &[0.0, 0.0],
            1.0,
            1.0,
            &mut ret,
            &mut adv,
        );
        assert_eq!(ret, [2.0, 20.0, 1.0, 10.0]);
    }

    /// Normalised values have mean 0 and unbiased standard deviation 1.
    #[test]
    fn normalize_uses_unbiased_std() {
        let mut x = [1.0f32, 2.0, 3.0, 4.0];
        normalize(&mut x);
        // mean 2.5, unbiased std sqrt(5/3).
        let s = (5.0f32 / 3.0).sqrt();
        assert!((x[0] + 1.5 / s).abs() < 1e-6 && (x[3] - 1.5 / s).abs() < 1e-6);
    }
}
