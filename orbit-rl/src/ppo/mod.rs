//! Proximal policy optimisation with RSL-RL's exact semantics (its `algorithms/ppo.py`): time-out
//! bootstrapping, GAE, whole-rollout advantage normalisation, one shuffle reused across epochs,
//! the KL-adaptive learning rate applied per minibatch before its gradient step, clipped
//! surrogate and value losses, an entropy bonus and a gradient-norm clip (global, or per
//! network as in RSL-RL 5). Optionally the critic learns normalised returns (rl_games'
//! `normalize_value`).
//!
//! The learner is one type, [`Ppo`], whose methods are split by concept: collecting a rollout
//! (`rollout`: sampling actions, the step tensors kept on the device), the time-out bootstrap
//! and returns (`returns`), the minibatch permutation drawn on a helper thread (`shuffle`),
//! the rollout on the device and its minibatches (`minibatch`), the update with its losses and
//! KL-adaptive learning rate (`update`), gradient-norm clipping (`grad_clip`), the same update
//! on fused kernels of `orbit-mlp-wgpu` (`fused`), the collection pass on such kernels
//! (`rollout_kernel`), checkpoints (`checkpoint`), the replica of a data-parallel run
//! (`distributed`) and the tensor helpers they share (`tensor`).

mod checkpoint;
mod distributed;
#[cfg(test)]
mod fixtures;
mod fused;
mod grad_clip;
mod minibatch;
mod returns;
mod rollout;
mod rollout_kernel;
mod shuffle;
mod tensor;
mod update;

use std::sync::Arc;

use burn::tensor::Device;
use orbit_core::rng::EnvRng;

use crate::adam::Adam;
use crate::cfg::PpoCfg;
use crate::collective::Collective;
use crate::model::ActorCritic;
use crate::normalizer::EmpiricalNormalizer;
use crate::storage::RolloutStorage;
use crate::streams;

pub use checkpoint::load_model;
use rollout::StepTensors;
use shuffle::PendingShuffle;
pub(crate) use tensor::{tensor1, tensor2, values};
pub use update::LossStats;

/// The PPO learner: the network, its Adam optimiser and the rollout storage.
pub struct Ppo {
    /// Algorithm settings.
    pub cfg: PpoCfg,
    /// The actor-critic being trained.
    pub model: ActorCritic,
    /// The learning rate as of the last update (the adaptive schedule changes it on the
    /// device; it persists across iterations).
    learning_rate: f64,
    /// This iteration's transitions.
    pub storage: RolloutStorage,
    /// Running statistics of the returns when `normalize_value` is set: the critic's output
    /// is a normalised value, denormalised by these statistics.
    pub value_normalizer: Option<EmpiricalNormalizer>,
    optimizer: Adam,
    device: Device,
    seed: u64,
    /// Per-env action-noise streams: each env's samples depend only on the seed, the env and
    /// how many actions it has taken.
    noise: Vec<EnvRng>,
    /// A gradient-free copy of the model used while collecting a rollout.
    rollout_model: Option<rollout::RolloutModel>,
    /// The collection pass as kernels of its own on a GPU learner's device (built at the first
    /// rollout; `None` on the CPU or where the networks do not stack).
    rollout_kernel: Option<rollout_kernel::RolloutKernel>,
    /// Whether building `rollout_kernel` was tried (a failure is reported once).
    rollout_kernel_tried: bool,
    /// The update on fused kernels, where it runs there (see [`Ppo::use_fused_update`]).
    fused: Option<fused::FusedUpdate>,
    /// The device tensors of each stored step (the update concatenates them instead of
    /// uploading the whole rollout at once).
    step_tensors: Vec<StepTensors>,
    /// The action standard deviation during the current rollout.
    sigma: Vec<f32>,
    updates: u32,
    /// The next update's shuffle, drawn on a helper thread while the rollout is collected.
    next_shuffle: Option<PendingShuffle>,
    /// The other replicas of a data-parallel run (see [`Ppo::distribute`]).
    collective: Option<Arc<dyn Collective>>,
}

/// The largest rollout (envs × steps) an update takes: its rows are indexed by `i32` on the
/// device.
const MAX_ROLLOUT_ROWS: usize = i32::MAX as usize;

impl Ppo {
    /// A learner for `num_envs` envs collecting `num_steps` steps per iteration.
    pub fn new(
        cfg: PpoCfg,
        model: ActorCritic,
        num_envs: usize,
        num_steps: usize,
        dims: (usize, usize, usize),
        seed: u64,
        device: Device,
    ) -> Self {
        let (num_obs, num_critic_obs, num_actions) = dims;
        let optimizer = Adam::new(cfg.learning_rate, &device);
        let noise = (0..num_envs)
            .map(|e| EnvRng::new(seed, e as u32, streams::ACTION_NOISE))
            .collect();
        Self {
            learning_rate: cfg.learning_rate,
            value_normalizer: cfg
                .normalize_value
                .then(|| EmpiricalNormalizer::new(1, u64::MAX)),
            cfg,
            model,
            storage: RolloutStorage::new(num_steps, num_envs, num_obs, num_critic_obs, num_actions),
            optimizer,
            device,
            seed,
            noise,
            rollout_model: None,
            rollout_kernel: None,
            rollout_kernel_tried: false,
            fused: None,
            step_tensors: Vec::with_capacity(num_steps),
            sigma: Vec::new(),
            updates: 0,
            next_shuffle: None,
            collective: None,
        }
    }

    /// The device the network lives on.
    pub fn device(&self) -> &Device {
        &self.device
    }

    /// The learning rate as of the last update.
    pub fn learning_rate(&self) -> f64 {
        self.learning_rate
    }

    /// Sets the learning rate (resuming a run restores the rate it had reached).
    pub fn set_learning_rate(&mut self, learning_rate: f64) {
        self.learning_rate = learning_rate;
        self.optimizer.set_learning_rate(learning_rate);
        self.fused_set_learning_rate(learning_rate);
    }
}
