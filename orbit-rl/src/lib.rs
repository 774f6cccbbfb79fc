//! Learners for orbit-rs: PPO with RSL-RL's semantics on burn, its rollout storage and
//! observation normalisation, the on-policy runner with checkpoints and logs, and the
//! inference [`Policy`]. Envs reach them through [`VecEnv`] (crate `orbit-envs`).
//!
//! ```text
//! VecEnv (RlVecEnv over a ManagerBasedRlEnv, or BlackBoxEnv: one movement primitive per episode)
//!   └─ OnPolicyRunner::learn: act → env.step → process_env_step (× num_steps_per_env)
//!                             → compute_returns (GAE) → update (PPO epochs × minibatches)
//! ```

#![warn(missing_docs)]

pub mod adam;
pub mod cfg;
pub mod checkpoint;
pub mod collective;
mod error;
pub mod logger;
pub mod model;
pub mod normalizer;
pub mod plot;
pub mod policy;
pub mod ppo;
mod progress;
pub mod run_dir;
pub mod runner;
pub mod storage;
pub mod tensorboard;

pub use burn;
pub use cfg::{GpuUpdate, LearnerDevice, RunnerCfg};
pub use collective::Collective;
pub use error::RlError;
pub use orbit_envs::{VecEnv, VecEnvStep};
pub use policy::Policy;
pub use runner::{IterationLog, OnPolicyRunner};

/// Shares the GPU learner's wgpu device and queue: the fused update runs there, and rollouts
/// are collected with forward passes of their own on it (one submission per step) instead of
/// burn's.
pub fn share_wgpu_device(device: orbit_mlp_wgpu::wgpu::Device, queue: orbit_mlp_wgpu::wgpu::Queue) {
    orbit_mlp_wgpu::share_device(device, queue);
}

/// Whether `device` is the CPU learner's (burn's flex backend), with or without autodiff.
pub(crate) fn on_cpu(device: &burn::tensor::Device) -> bool {
    device.clone().inner() == burn::tensor::Device::flex()
}

/// Random streams of the learner (`EnvRng` stream ids; the env's own are 1–6 and 19, in
/// `orbit_core::rng::streams`).
pub mod streams {
    /// Network initialisation.
    pub const INIT: u32 = 16;
    /// Action noise, one stream per env.
    pub const ACTION_NOISE: u32 = 17;
    /// Minibatch shuffles, one stream per update.
    pub const SHUFFLE: u32 = 18;
}
