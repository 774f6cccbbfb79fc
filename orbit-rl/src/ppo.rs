//! Proximal policy optimisation with RSL-RL's exact semantics (its `algorithms/ppo.py`): time-out
//! bootstrapping, GAE, whole-rollout advantage normalisation, one shuffle reused across epochs,
//! the KL-adaptive learning rate applied per minibatch before its gradient step, clipped
//! surrogate and value losses, an entropy bonus and a gradient-norm clip (global, or per
//! network as in RSL-RL 5). Optionally the critic learns normalised returns (rl_games'
//! `normalize_value`).

use std::f32::consts::PI;
use std::path::Path;

use burn::module::{Module, ModuleVisitor, Param};
use burn::optim::GradientsParams;
use burn::tensor::{Device, Int, Tensor, TensorData};
use orbit_core::parallel::{self, MIN_ENVS_PER_COPY_TASK, MIN_ENVS_PER_TASK, first_non_finite};
use orbit_core::rng::EnvRng;
use rayon::prelude::*;

use crate::adam::Adam;
use crate::cfg::{GradClip, PpoCfg, Schedule};
use crate::model::ActorCritic;
use crate::normalizer::EmpiricalNormalizer;
use crate::storage::{self, RolloutStorage};
use crate::{RlError, streams};

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
    rollout_model: Option<ActorCritic>,
    /// The device tensors of each stored step (the update concatenates them instead of
    /// uploading the whole rollout at once).
    step_tensors: Vec<StepTensors>,
    /// The action standard deviation during the current rollout.
    sigma: Vec<f32>,
    updates: u32,
    /// The next update's shuffle, drawn on a helper thread while the rollout is collected.
    next_shuffle: Option<PendingShuffle>,
}

/// The tensors of one collected step that the update needs, already on the learner's device.
struct StepTensors {
    /// The actor's observations, as the forward pass took them.
    obs: Tensor<2>,
    /// The critic's, where they are not the actor's.
    critic_obs: Option<Tensor<2>>,
    /// The action means the forward pass computed (kept on the device, never uploaded).
    mu: Tensor<2>,
    /// The sampled actions, uploaded with the step (a few MB each time), so that the update
    /// does not start by copying the whole rollout's actions while the device waits.
    actions: Tensor<2>,
}

/// A shuffle being drawn on a helper thread: the permutation of `len` rows for update number
/// `updates`.
struct PendingShuffle {
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

/// The largest rollout (envs × steps) an update takes: its rows are indexed by `i32` on the
/// device.
const MAX_ROLLOUT_ROWS: usize = i32::MAX as usize;

/// A `[rows, cols]` tensor from row-major values.
pub(crate) fn tensor2(values: Vec<f32>, rows: usize, cols: usize, device: &Device) -> Tensor<2> {
    Tensor::from_data(TensorData::new(values, [rows, cols]), device)
}

/// A `[n]` tensor.
pub(crate) fn tensor1(values: Vec<f32>, device: &Device) -> Tensor<1> {
    let n = values.len();
    Tensor::from_data(TensorData::new(values, [n]), device)
}

/// Row indices (below [`MAX_ROLLOUT_ROWS`]) as an `i32` tensor, for `select`.
fn index_tensor(idx: &[u32], device: &Device) -> Tensor<1, Int> {
    let idx: Vec<i32> = idx
        .iter()
        .map(|&i| i32::try_from(i).expect("rows are indexed below i32::MAX"))
        .collect();
    let n = idx.len();
    Tensor::from_data(TensorData::new(idx, [n]), device)
}

/// The sum of all of `x`'s values as a `[1]` tensor, reduced along one dimension. burn's
/// whole-tensor `sum` (and `mean`) lets cubecl's autotune choose a kernel whose workgroups add
/// their partial sums atomically (`sum_one_shot`), in an order that changes from run to run;
/// it does choose it for the gradient norms' sums on an H100. A reduction along a dimension
/// gives each output to one workgroup, so the same inputs give the same bits.
fn sum_all<const D: usize>(x: Tensor<D>) -> Tensor<1> {
    let n = x.shape().num_elements();
    x.reshape([n]).sum_dim(0)
}

/// The mean of `x`'s values as a `[1]` tensor, reduced as in [`sum_all`].
fn mean_all(x: Tensor<1>) -> Tensor<1> {
    x.mean_dim(0)
}

/// A tensor's values, row-major.
pub(crate) fn values<const D: usize>(t: Tensor<D>) -> Vec<f32> {
    t.into_data()
        .try_into_vec::<f32>()
        .expect("float tensors hold f32 values")
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
            step_tensors: Vec::with_capacity(num_steps),
            sigma: Vec::new(),
            updates: 0,
            next_shuffle: None,
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
    }

    fn rollout_model(&mut self) -> &ActorCritic {
        if self.rollout_model.is_none() {
            let m = self.model.valid();
            self.sigma = values(m.action_std());
            self.rollout_model = Some(m);
        }
        self.rollout_model.as_ref().expect("just set")
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
        let actor_input = tensor2(parallel::to_vec(obs), n, no, &device);
        // The same values (an env without a `critic` group): uploaded, and later
        // concatenated, once.
        let critic_input = (!std::ptr::eq(obs, critic_obs))
            .then(|| tensor2(parallel::to_vec(critic_obs), n, nc, &device));
        let critic_view = critic_input.clone().unwrap_or_else(|| actor_input.clone());
        let model = self.rollout_model();
        let mean = model.action_mean(actor_input.clone());
        // Means and values come back in one read (each read waits for the device).
        let out = values(Tensor::cat(vec![mean.clone(), model.value(critic_view)], 1));
        let s = &mut self.storage;
        let mu = RolloutStorage::rows(&mut s.mu, t, n, na);
        let value = RolloutStorage::rows(&mut s.values, t, n, 1);
        mu.par_chunks_mut(na)
            .zip(value.par_iter_mut())
            .zip(out.par_chunks(na + 1))
            .with_min_len(MIN_ENVS_PER_COPY_TASK)
            .for_each(|((m, v), row)| {
                m.copy_from_slice(&row[..na]);
                *v = row[na];
            });
        if let Some(normalizer) = &self.value_normalizer {
            normalizer.denormalize(value);
        }
        if first_non_finite(mu).is_some() || first_non_finite(value).is_some() {
            return Err(RlError::NonFinite("the policy's output".into()));
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
        self.step_tensors.push(StepTensors {
            obs: actor_input,
            critic_obs: critic_input,
            mu: mean,
            actions: tensor2(parallel::to_vec(actions), n, na, &device),
        });
        Ok(())
    }

    /// Rows of the permutation an update of the current storage uses (whole minibatches).
    fn shuffle_len(&self) -> usize {
        let mb = self.cfg.num_mini_batches.max(1);
        self.storage.batch_size() / mb * mb
    }

    /// Starts drawing the next update's shuffle on a helper thread (it depends only on the
    /// seed, the update's number and the rollout's size), unless it is already being drawn.
    fn draw_next_shuffle(&mut self) {
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
    fn take_shuffle(&mut self, len: usize) -> Vec<u32> {
        let updates = self.updates;
        match self.next_shuffle.take() {
            Some(p) if p.updates == updates && p.len == len => p
                .handle
                .join()
                .unwrap_or_else(|_| shuffle(self.seed, updates, len)),
            _ => shuffle(self.seed, updates, len),
        }
    }

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

    /// Computes returns and advantages with the values of the states after the last step.
    pub fn compute_returns(&mut self, last_critic_obs: &[f32]) {
        let (n, nc) = (self.storage.num_envs, self.storage.num_critic_obs);
        let device = self.device.clone();
        let mut last =
            values(
                self.rollout_model()
                    .value(tensor2(last_critic_obs.to_vec(), n, nc, &device)),
            );
        if let Some(normalizer) = &self.value_normalizer {
            normalizer.denormalize(&mut last);
        }
        let (gamma, lam) = (self.cfg.gamma, self.cfg.lam);
        let per_mb = self.cfg.normalize_advantage_per_mini_batch;
        self.storage.compute_returns(&last, gamma, lam, per_mb);
        // The critic trains on normalised targets: fold this rollout's returns into the
        // statistics, then express the returns and the old values (for value clipping) in
        // them.
        if let Some(normalizer) = &mut self.value_normalizer {
            normalizer.update(&self.storage.returns);
            normalizer.normalize(&mut self.storage.returns);
            normalizer.normalize(&mut self.storage.values);
        }
    }

    /// The PPO update over the stored rollout; clears the storage. An update that fails leaves
    /// the network, the optimiser, the learning rate and the rollout as they were.
    pub fn update(&mut self) -> Result<LossStats, RlError> {
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
                "the PPO loss (mean value loss {}, surrogate {} over the update; learning rate \
                 {:.2e} at its end; rollout {})",
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
    fn minibatch_losses(&self, mb: Minibatch) -> MinibatchLosses {
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
        let log_prob = (actions - mu.clone())
            .powi_scalar(2)
            .div(sigma.clone().powi_scalar(2).mul_scalar(2.0))
            .sum_dim(1)
            .reshape([rows])
            .neg()
            .sub(log_sigma_sum.clone())
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
        if cfg.schedule == Schedule::Adaptive {
            // A NaN KL leaves the rate as it is; the update then fails on its losses.
            self.optimizer.adapt(l.kl, cfg.desired_kl);
        }
        clip_gradients(&self.model, &mut grads, cfg.grad_clip, cfg.max_grad_norm);
        let model = self.model.clone();
        self.model = self.optimizer.step(model, grads);
        losses
    }

    /// Saves the network and the optimiser state as burnpack files `<base>.bpk` and
    /// `<base>.adam.bpk`.
    pub fn save(&self, base: &Path) -> Result<(), RlError> {
        let model_path = base.with_extension("bpk");
        self.model
            .clone()
            .save_file(&model_path)
            .map_err(|e| RlError::checkpoint(model_path, e))?;
        self.optimizer
            .save(&self.model, &base.with_extension("adam.bpk"))
    }

    /// Loads the network (and, if `with_optimizer`, the optimiser state) saved by [`Ppo::save`].
    /// A checkpoint whose optimiser state is in burn's format (`<base>.optim.bpk`, written
    /// before Adam kept its learning rate on the device) resumes with fresh Adam moments and a
    /// warning. A load that fails changes nothing.
    pub fn load(&mut self, base: &Path, with_optimizer: bool) -> Result<(), RlError> {
        let model = load_model(self.model.clone(), base)?;
        if with_optimizer {
            let path = base.with_extension("adam.bpk");
            let legacy = base.with_extension("optim.bpk");
            let mut optimizer = self.optimizer.clone();
            if !path.exists() && legacy.exists() {
                tracing::warn!(
                    "{} holds burn's Adam state, which this version does not read: resuming \
                     with fresh Adam moments (the weights, normalisers and learning rate are \
                     restored)",
                    legacy.display()
                );
                optimizer = Adam::new(self.learning_rate, &self.device);
            } else {
                optimizer.load(&model, &path)?;
            }
            self.optimizer = optimizer;
        }
        self.model = model;
        self.rollout_model = None;
        Ok(())
    }
}

/// Loads network weights saved by [`Ppo::save`] into `model` (which fixes the architecture).
pub fn load_model(model: ActorCritic, base: &Path) -> Result<ActorCritic, RlError> {
    let path = base.with_extension("bpk");
    model
        .try_load_file(&path)
        .map_err(|e| RlError::checkpoint(path, e))
}

/// The squared norm of the gradients of `module`'s parameters, `Σ‖g‖²` (shape `[1]`).
fn grad_norm_squared<M: Module>(module: &M, grads: &GradientsParams) -> Tensor<1> {
    struct SquaredNorm<'a> {
        grads: &'a GradientsParams,
        total: Option<Tensor<1>>,
    }
    impl ModuleVisitor for SquaredNorm<'_> {
        fn visit_float<const D: usize>(&mut self, param: &Param<Tensor<D>>) {
            if let Some(g) = self.grads.get::<D>(param.id) {
                let s = sum_all(g.powi_scalar(2));
                self.total = Some(match self.total.take() {
                    Some(t) => t + s,
                    None => s,
                });
            }
        }
    }
    let mut norm = SquaredNorm { grads, total: None };
    module.visit(&mut norm);
    norm.total.expect("the module has parameters")
}

/// The squared norm of the actor's gradients, the noise parameter included.
fn actor_grad_norm_squared(model: &ActorCritic, grads: &GradientsParams) -> Tensor<1> {
    grad_norm_squared(&model.actor, grads) + grad_norm_squared(&model.std, grads)
}

/// Clips the gradients to `max_norm`: all together, or the actor's (with the noise parameter)
/// and the critic's each (RSL-RL 5), on the device.
fn clip_gradients(model: &ActorCritic, grads: &mut GradientsParams, mode: GradClip, max_norm: f32) {
    let actor_sq = actor_grad_norm_squared(model, grads);
    let critic_sq = grad_norm_squared(&model.critic, grads);
    match mode {
        GradClip::Global => {
            let factor = clip_factor(actor_sq + critic_sq, max_norm);
            scale_grads(model, grads, &factor);
        }
        GradClip::PerNetwork => {
            let actor = clip_factor(actor_sq, max_norm);
            scale_grads(&model.actor, grads, &actor);
            scale_grads(&model.std, grads, &actor);
            scale_grads(&model.critic, grads, &clip_factor(critic_sq, max_norm));
        }
    }
}

/// The factor `min(1, max_norm / (‖g‖ + 1e-6))` that clips gradients of squared norm
/// `norm_squared` to `max_norm` (`torch.nn.utils.clip_grad_norm_`), as a `[1]` tensor.
fn clip_factor(norm_squared: Tensor<1>, max_norm: f32) -> Tensor<1> {
    norm_squared
        .sqrt()
        .add_scalar(1e-6)
        .recip()
        .mul_scalar(max_norm)
        .clamp_max(1.0)
}

/// Multiplies the gradients of `module`'s parameters by `factor` (a `[1]` tensor).
fn scale_grads<M: Module>(module: &M, grads: &mut GradientsParams, factor: &Tensor<1>) {
    struct Scale<'a> {
        grads: &'a mut GradientsParams,
        factor: &'a Tensor<1>,
    }
    impl ModuleVisitor for Scale<'_> {
        fn visit_float<const D: usize>(&mut self, param: &Param<Tensor<D>>) {
            if let Some(g) = self.grads.remove::<D>(param.id) {
                let factor = self.factor.clone().reshape([1; D]);
                self.grads.register(param.id, g.mul(factor));
            }
        }
    }
    module.visit(&mut Scale { grads, factor });
}

/// The loss terms of one minibatch.
struct MinibatchLosses {
    /// Mean KL divergence from the sampling policy (shape `[1]`, no gradient).
    kl: Tensor<1>,
    /// Clipped surrogate loss.
    surrogate: Tensor<1>,
    /// (Clipped) value loss.
    value: Tensor<1>,
    /// Policy entropy.
    entropy: Tensor<1>,
}

/// Rollout rows on the learner's device: the whole rollout of an update (uploaded once, then
/// every minibatch of every epoch is selected from it there: a GPU learner would otherwise
/// gather and upload each minibatch on the host), or one minibatch of it.
struct Minibatch {
    obs: Tensor<2>,
    /// `None`: the critic observes `obs`.
    critic_obs: Option<Tensor<2>>,
    actions: Tensor<2>,
    mu: Tensor<2>,
    log_prob: Tensor<1>,
    advantages: Tensor<1>,
    returns: Tensor<1>,
    values: Tensor<1>,
}

impl Minibatch {
    /// The whole rollout: the tensors of its steps concatenated, the rest of the storage
    /// uploaded. With `per_minibatch` the advantages are normalised within each minibatch of
    /// `perm` (chunks of `m`): the permutation is the same in every epoch, so this is done
    /// once, here.
    fn upload(
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
        let mut advantages = s.advantages.clone();
        if per_minibatch {
            for chunk in perm.chunks_exact(m) {
                let mut a: Vec<f32> = chunk.iter().map(|&i| s.advantages[i as usize]).collect();
                storage::normalize(&mut a);
                for (&i, v) in chunk.iter().zip(a) {
                    advantages[i as usize] = v;
                }
            }
        }
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

    /// The rows `idx` (an [`index_tensor`]), in that order.
    fn select(&self, idx: &Tensor<1, Int>) -> Self {
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
    fn rows(&self) -> usize {
        self.advantages.dims()[0]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cfg::{Activation, NoiseStdType, PolicyCfg};

    fn ppo(num_envs: usize, num_steps: usize) -> Ppo {
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
    fn whole_rollout(p: &Ppo) -> Minibatch {
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
    fn rollout(p: &mut Ppo) -> (Vec<f32>, Vec<f32>) {
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

    /// Stored log-probabilities are those of the sampled actions under N(μ, σ²).
    #[test]
    fn log_prob_of_a_standard_normal() {
        let lp = gaussian_log_prob(&[1.0, 0.0], &[0.0, 0.0], &[1.0, 2.0]);
        let expected = -0.5 - (2.0 * PI).ln() - 2.0f32.ln();
        assert!((lp - expected).abs() < 1e-6);
    }

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

    /// With per-network clipping, the actor's gradient (with the noise parameter) and the
    /// critic's each end at the limit when both exceed it.
    #[test]
    fn gradient_norm_is_clipped_per_network() {
        let mut p = ppo(16, 4);
        rollout(&mut p);
        let l = p.minibatch_losses(whole_rollout(&p));
        let loss = l.surrogate.mul_scalar(100.0) + l.value.mul_scalar(100.0);
        let mut grads = GradientsParams::from_grads(loss.backward(), &p.model);
        let norm = |grads: &GradientsParams, m: &dyn Fn(&GradientsParams) -> Tensor<1>| {
            m(grads).into_scalar::<f32>().sqrt()
        };
        let actor = |g: &GradientsParams| actor_grad_norm_squared(&p.model, g);
        let critic = |g: &GradientsParams| grad_norm_squared(&p.model.critic, g);
        let (a, c) = (norm(&grads, &actor), norm(&grads, &critic));
        assert!(a > 1e-2 && c > 1e-2, "norms {a} {c}");
        clip_gradients(&p.model, &mut grads, GradClip::PerNetwork, 1e-2);
        assert!((norm(&grads, &actor) - 1e-2).abs() < 1e-6);
        assert!((norm(&grads, &critic) - 1e-2).abs() < 1e-6);
        // Under the limit, nothing changes.
        clip_gradients(&p.model, &mut grads, GradClip::PerNetwork, 1.0);
        assert!((norm(&grads, &actor) - 1e-2).abs() < 1e-6);
    }

    /// After clipping, the global gradient norm equals the limit.
    #[test]
    fn gradient_norm_is_clipped_globally() {
        let mut p = ppo(16, 4);
        rollout(&mut p);
        let l = p.minibatch_losses(whole_rollout(&p));
        let loss = l.surrogate + l.value.mul_scalar(100.0);
        let mut grads = GradientsParams::from_grads(loss.backward(), &p.model);
        let norm = grad_norm_squared(&p.model, &grads)
            .into_scalar::<f32>()
            .sqrt();
        assert!(norm > 1e-3, "norm {norm}");
        clip_gradients(&p.model, &mut grads, GradClip::Global, 1e-3);
        struct Norm<'a>(&'a GradientsParams, f32);
        impl ModuleVisitor for Norm<'_> {
            fn visit_float<const D: usize>(&mut self, param: &Param<Tensor<D>>) {
                if let Some(g) = self.0.get::<D>(param.id) {
                    self.1 += g.powi_scalar(2).sum().into_scalar::<f32>();
                }
            }
        }
        let mut n = Norm(&grads, 0.0);
        p.model.visit(&mut n);
        assert!((n.1.sqrt() - 1e-3).abs() < 1e-6, "norm {}", n.1.sqrt());
    }

    /// A checkpoint restores Adam's state; one whose Adam file is missing is refused without
    /// touching the network, and one with only burn's older optimiser file resumes with fresh
    /// moments.
    #[test]
    fn checkpoints_restore_adam_or_refuse_cleanly() {
        let mut p = ppo(16, 4);
        rollout(&mut p);
        p.update().unwrap();
        let dir = std::env::temp_dir().join(format!("orbit-ppo-ckpt-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let base = dir.join("model_0");
        p.save(&base).unwrap();
        let steps = p.optimizer.steps();
        assert_eq!(steps, 4, "2 epochs × 2 minibatches");

        let mut q = ppo(16, 4);
        q.load(&base, true).unwrap();
        assert_eq!(q.optimizer.steps(), steps);
        assert_eq!(values(q.model.action_std()), values(p.model.action_std()));

        let adam = base.with_extension("adam.bpk");
        std::fs::rename(&adam, base.with_extension("elsewhere")).unwrap();
        let mut r = ppo(16, 4);
        let fresh = values(r.model.action_std());
        assert_ne!(fresh, values(p.model.action_std()), "the update moved σ");
        assert!(matches!(
            r.load(&base, true),
            Err(RlError::Checkpoint { .. })
        ));
        assert_eq!(
            values(r.model.action_std()),
            fresh,
            "the network is untouched"
        );

        std::fs::rename(
            base.with_extension("elsewhere"),
            base.with_extension("optim.bpk"),
        )
        .unwrap();
        r.load(&base, true).unwrap();
        assert_eq!(r.optimizer.steps(), 0);
        assert_eq!(values(r.model.action_std()), values(p.model.action_std()));
        std::fs::remove_dir_all(&dir).unwrap();
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
