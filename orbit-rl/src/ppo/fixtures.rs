//! Test fixtures shared by the learner's unit tests: a small learner and synthetic rollouts.

use burn::tensor::Device;
use orbit_core::rng::EnvRng;

use super::Ppo;
use super::minibatch::Minibatch;
use super::tensor::index_tensor;
use crate::cfg::{Activation, GradClip, NoiseStdType, PolicyCfg, PpoCfg, Schedule};
use crate::model::ActorCritic;

/// A small learner (3 observations, 2 actions, σ 0.7, 2 epochs × 2 minibatches, seed 5) on
/// the CPU.
pub(super) fn ppo(num_envs: usize, num_steps: usize) -> Ppo {
    let policy = PolicyCfg {
        init_noise_std: 0.7,
        actor_hidden_dims: vec![8, 8],
        critic_hidden_dims: vec![8],
        activation: Activation::Elu,
        noise_std_type: NoiseStdType::Scalar,
    };
    let cfg = PpoCfg {
        value_loss_coef: 1.0,
        use_clipped_value_loss: true,
        clip_param: 0.2,
        entropy_coef: 0.01,
        num_learning_epochs: 2,
        num_mini_batches: 2,
        learning_rate: 1e-3,
        schedule: Schedule::Adaptive,
        gamma: 0.99,
        lam: 0.95,
        desired_kl: 0.01,
        max_grad_norm: 1.0,
        normalize_advantage_per_mini_batch: false,
        grad_clip: GradClip::Global,
        normalize_value: false,
    };
    let device = Device::flex().autodiff();
    let model = ActorCritic::new(&policy, 3, 3, 2, 5, &device);
    Ppo::new(cfg, model, num_envs, num_steps, (3, 3, 2), 5, device)
}

/// The whole rollout as one minibatch.
pub(super) fn whole_rollout(p: &Ppo) -> Minibatch {
    let all: Vec<u32> = (0..p.storage.batch_size() as u32).collect();
    Minibatch::upload(
        &p.storage,
        &p.step_tensors,
        &all,
        all.len(),
        false,
        &p.device,
    )
    .select(&index_tensor(&all, &p.device))
}

/// Fills the storage with a rollout on synthetic observations and rewards; returns the
/// observations and the sampled actions, step after step.
pub(super) fn rollout(p: &mut Ppo) -> (Vec<f32>, Vec<f32>) {
    let (n, t) = (p.storage.num_envs, p.storage.num_steps);
    let mut rng = EnvRng::new(1, 0, 99);
    let mut actions = vec![0.0; n * 2];
    let (mut all_obs, mut all_actions) = (Vec::new(), Vec::new());
    for _ in 0..t {
        let obs: Vec<f32> = (0..n * 3).map(|_| rng.uniform_range(-1.0, 1.0)).collect();
        p.act(&obs, &obs, &mut actions).unwrap();
        all_obs.extend_from_slice(&obs);
        all_actions.extend_from_slice(&actions);
        let rewards: Vec<f32> = actions.chunks(2).map(|a| -a[0] * a[0]).collect();
        p.process_env_step(&rewards, &vec![false; n], &vec![false; n]);
    }
    let last: Vec<f32> = (0..n * 3).map(|_| rng.uniform_range(-1.0, 1.0)).collect();
    p.compute_returns(&last);
    (all_obs, all_actions)
}
