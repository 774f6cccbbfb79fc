//! The update on [`orbit_mlp_wgpu::PpoTrainer`]'s kernels (`gpu_update: Fused`): the rollout's
//! observations and actions go to the device as they are collected, the rest at the update,
//! and a whole update is one submission with one read of its results. The network and Adam
//! live on the device between updates; the host's model takes the parameters after each
//! update (for the rollout, checkpoints and inference) and Adam's moments when a checkpoint
//! is written.

use orbit_mlp_wgpu::{PpoSettings, PpoShape, PpoTrainer, UpdateInputs};

use super::{LossStats, MAX_ROLLOUT_ROWS, Ppo};
use crate::RlError;
use crate::adam::Adam;
use crate::cfg::{GradClip, NoiseStdType, Schedule};
use crate::model::kernel_activation;
use crate::storage::RolloutStorage;

/// The device side of the fused update.
pub(super) struct FusedUpdate {
    device: orbit_mlp_wgpu::wgpu::Device,
    queue: orbit_mlp_wgpu::wgpu::Queue,
    /// Built at the first collected step, when it is known whether the critic has
    /// observations of its own.
    trainer: Option<PpoTrainer>,
    /// The trainer's parameters, moments and learning rate are behind the host's (a new
    /// trainer, a loaded checkpoint): they are uploaded before the next update.
    stale: bool,
    /// The host's Adam moments are behind the device's (set by every update).
    host_moments_stale: bool,
    /// Adam steps taken on the device.
    steps: u32,
}

impl Ppo {
    /// Runs this learner's updates on the fused kernels, on the wgpu device shared with
    /// [`crate::share_wgpu_device`]. Data-parallel replicas average their gradients on the
    /// host after every minibatch, which these kernels do not: their updates fail with an
    /// error that says to keep burn's update.
    pub fn use_fused_update(&mut self) -> Result<(), RlError> {
        let Some((device, queue)) = orbit_mlp_wgpu::shared_device() else {
            return Err(RlError::Device(
                "the fused GPU update runs on the wgpu device the process shares with \
                 `orbit_rl::share_wgpu_device`, and none was shared"
                    .into(),
            ));
        };
        self.fused = Some(FusedUpdate {
            device,
            queue,
            trainer: None,
            stale: true,
            host_moments_stale: false,
            steps: 0,
        });
        Ok(())
    }

    /// Whether updates run on the fused kernels.
    pub fn uses_fused_update(&self) -> bool {
        self.fused.is_some()
    }

    /// Sends step `t`'s observations and actions to the device (building the trainer at the
    /// first step, or again at a rollout's first step where the critic's inputs changed; a
    /// change within a rollout is an error).
    pub(super) fn fused_write_step(
        &mut self,
        t: usize,
        obs: &[f32],
        critic_obs: Option<&[f32]>,
        actions: &[f32],
    ) -> Result<(), RlError> {
        let separate = critic_obs.is_some();
        let rebuild = self.fused.as_ref().is_some_and(|f| {
            f.trainer
                .as_ref()
                .is_none_or(|_| f.separate_critic() != Some(separate))
        });
        if rebuild && t > 0 {
            return Err(RlError::EnvMismatch(format!(
                "the fused update's rollout cannot start at step {t}: the critic's observations \
                 changed within the rollout (an env keeps its observation groups for the whole \
                 run), or the fused update was switched on within it"
            )));
        }
        if rebuild {
            self.sync_host_optimizer()?;
            let shape = self.fused_shape(separate);
            let settings = self.fused_settings();
            let f = self.fused.as_mut().expect("checked above");
            let trainer = PpoTrainer::new(&f.device, &f.queue, shape, settings)
                .map_err(|e| RlError::Device(e.to_string()))?;
            f.trainer = Some(trainer);
            f.stale = true;
        }
        let trainer = (self.fused.as_mut().and_then(|f| f.trainer.as_mut())).expect("built above");
        trainer
            .write_step(t, obs, critic_obs, actions)
            .map_err(|e| RlError::Device(e.to_string()))
    }

    /// The networks' and the rollout's shape for the trainer.
    fn fused_shape(&self, separate_critic: bool) -> PpoShape {
        let s = &self.storage;
        PpoShape {
            actor_widths: self.model.actor.widths(),
            critic_widths: self.model.critic.widths(),
            activation: kernel_activation(self.model.actor.activation()),
            log_std: self.model.noise_std_type() == NoiseStdType::Log,
            batch: s.batch_size(),
            minibatches: self.cfg.num_mini_batches,
            separate_critic,
        }
    }

    /// The PPO settings for the trainer.
    fn fused_settings(&self) -> PpoSettings {
        let c = &self.cfg;
        PpoSettings {
            clip: c.clip_param,
            value_coef: c.value_loss_coef,
            entropy_coef: c.entropy_coef,
            clipped_value_loss: c.use_clipped_value_loss,
            desired_kl: (c.schedule == Schedule::Adaptive).then_some(c.desired_kl),
            max_grad_norm: c.max_grad_norm,
            per_network_clip: c.grad_clip == GradClip::PerNetwork,
            epochs: c.num_learning_epochs,
        }
    }

    /// Marks the device's state as behind the host's (after a load).
    pub(super) fn fused_reload(&mut self) {
        if let Some(f) = &mut self.fused {
            f.stale = true;
            f.host_moments_stale = false;
        }
    }

    /// Sets the learning rate on the device too.
    pub(super) fn fused_set_learning_rate(&mut self, learning_rate: f64) {
        if let Some(f) = &mut self.fused
            && let (Some(trainer), false) = (&mut f.trainer, f.stale)
        {
            trainer.set_learning_rate(learning_rate as f32);
        }
    }

    /// The optimiser as it stands: the host's, with the device's moments and step count
    /// where they are newer.
    pub(super) fn current_optimizer(&self) -> Result<Adam, RlError> {
        let mut adam = self.optimizer.clone();
        if let Some(f) = &self.fused
            && let (Some(trainer), true) = (&f.trainer, f.host_moments_stale)
        {
            let (first, second) = trainer
                .moments()
                .map_err(|e| RlError::Device(e.to_string()))?;
            adam.set_flat_state(&self.model, (&first, &second), f.steps, self.learning_rate);
        }
        Ok(adam)
    }

    /// Brings the host's optimiser up to the device's (see [`Self::current_optimizer`]).
    fn sync_host_optimizer(&mut self) -> Result<(), RlError> {
        self.optimizer = self.current_optimizer()?;
        if let Some(f) = &mut self.fused {
            f.host_moments_stale = false;
        }
        Ok(())
    }

    /// The PPO update on the device (see [`Ppo::update`]).
    pub(super) fn fused_update(&mut self) -> Result<LossStats, RlError> {
        self.rollout_model = None;
        if self.collective.is_some() {
            return Err(RlError::Device(
                "data-parallel training averages gradients on the host after every \
                 minibatch, which the fused GPU update does not: set `gpu_update: Burn`"
                    .into(),
            ));
        }
        let b = self.storage.batch_size();
        let m = b / self.cfg.num_mini_batches;
        if m == 0 || b > MAX_ROLLOUT_ROWS {
            return Err(RlError::EnvMismatch(format!(
                "a rollout of {b} transitions cannot fill {} minibatches of an update (at \
                 most {MAX_ROLLOUT_ROWS} rows)",
                self.cfg.num_mini_batches
            )));
        }
        let perm = self.take_shuffle(self.shuffle_len());
        let advantages = RolloutStorage::update_advantages(
            &self.storage,
            &perm,
            m,
            self.cfg.normalize_advantage_per_mini_batch,
        );
        let Some(f) = &mut self.fused else {
            unreachable!("called on a fused learner")
        };
        let Some(trainer) = &mut f.trainer else {
            return Err(RlError::EnvMismatch(
                "an update needs a collected rollout first".into(),
            ));
        };
        let device_error = |e: orbit_mlp_wgpu::MlpError| RlError::Device(e.to_string());
        // The host's state goes up only where the device's is behind it.
        if f.stale {
            let params = self.model.parameter_values();
            let (first, second) = self.optimizer.flat_moments(&self.model);
            let (steps, learning_rate) = (self.optimizer.steps(), self.learning_rate as f32);
            trainer
                .load_state(&params, (&first, &second), steps, learning_rate)
                .map_err(device_error)?;
            f.stale = false;
        }
        let s = &self.storage;
        let out = trainer
            .update(UpdateInputs {
                mu: &s.mu,
                log_prob: &s.actions_log_prob,
                advantages: &advantages,
                returns: &s.returns,
                values: &s.values,
                sigma: &s.sigma,
                perm: &perm,
            })
            .map_err(device_error)?;
        let steps = (self.cfg.num_learning_epochs * self.cfg.num_mini_batches) as f32;
        if !out.applied {
            return Err(RlError::NonFinite(format!(
                "training diverged: the PPO loss is not finite (mean value loss {}, surrogate \
                 {} over the update; rollout {}); lower the learning rate or check the rewards",
                out.value / steps,
                out.surrogate / steps,
                self.storage.extremes()
            )));
        }
        f.host_moments_stale = true;
        f.steps = out.steps;
        self.model = self.model.clone().with_parameter_values(&out.params);
        self.learning_rate = f64::from(out.learning_rate);
        self.optimizer.set_learning_rate(self.learning_rate);
        self.updates += 1;
        self.storage.step = 0;
        self.step_tensors.clear();
        Ok(LossStats {
            value: out.value / steps,
            surrogate: out.surrogate / steps,
            entropy: out.entropy / steps,
        })
    }
}

impl FusedUpdate {
    /// Whether the trainer was built for a critic with observations of its own.
    fn separate_critic(&self) -> Option<bool> {
        self.trainer.as_ref().map(PpoTrainer::separate_critic)
    }
}

#[cfg(test)]
mod tests {
    use burn::module::{Module, ModuleVisitor, Param};
    use burn::optim::GradientsParams;
    use burn::tensor::Tensor;

    use crate::RlError;
    use crate::cfg::{GradClip, NoiseStdType, Schedule};
    use crate::model::ActorCritic;
    use crate::ppo::fixtures::{ppo, rollout, whole_rollout};
    use crate::ppo::{Ppo, values};

    /// A fused learner like [`ppo`]'s, on the test GPU (lavapipe in CI); `None` without one.
    fn fused(num_envs: usize, num_steps: usize, tweak: impl Fn(&mut Ppo)) -> Option<Ppo> {
        if !orbit_physics_wgpu::gpu_available_for_tests() {
            return None;
        }
        let gpu = orbit_physics_wgpu::gpu().expect("checked above");
        crate::share_wgpu_device(gpu.device.clone(), gpu.queue.clone());
        let mut p = ppo(num_envs, num_steps);
        tweak(&mut p);
        p.use_fused_update().expect("a shared device");
        Some(p)
    }

    /// Every parameter's gradient in `model`'s visit order, one vector per parameter.
    fn gradients(model: &ActorCritic, grads: &GradientsParams) -> Vec<Vec<f32>> {
        struct Collect<'a>(&'a GradientsParams, Vec<Vec<f32>>);
        impl ModuleVisitor for Collect<'_> {
            fn visit_float<const D: usize>(&mut self, param: &Param<Tensor<D>>) {
                let g = self
                    .0
                    .get::<D>(param.id)
                    .expect("every parameter has a gradient");
                self.1.push(values(g));
            }
        }
        let mut c = Collect(grads, Vec::new());
        model.visit(&mut c);
        c.1
    }

    /// The fused kernels' gradient of PPO's loss (one minibatch: the whole rollout) equals
    /// burn's autodiff gradient of the same loss to float rounding, for every parameter of
    /// both networks and the noise (either parameterisation), with and without value
    /// clipping, with layers narrower and wider than the kernels' 64-wide tiles; so do the
    /// minibatch's surrogate, value loss and KL divergence.
    #[test]
    fn fused_gradients_match_burns() {
        for (noise, clipped) in [(NoiseStdType::Scalar, true), (NoiseStdType::Log, false)] {
            let wide = noise == NoiseStdType::Log;
            let setup = |p: &mut Ppo| {
                p.cfg.num_learning_epochs = 1;
                p.cfg.num_mini_batches = 1;
                p.cfg.schedule = Schedule::Fixed;
                p.cfg.use_clipped_value_loss = clipped;
                // A large limit: the gradient the kernels keep is the one before clipping.
                p.cfg.max_grad_norm = 1e6;
                if wide {
                    let policy = crate::cfg::PolicyCfg {
                        init_noise_std: 0.7,
                        actor_hidden_dims: vec![130, 70],
                        critic_hidden_dims: vec![70],
                        activation: crate::cfg::Activation::Elu,
                        noise_std_type: NoiseStdType::Log,
                    };
                    p.model = ActorCritic::new(&policy, 3, 3, 2, 5, &p.device);
                }
            };
            let Some(mut f) = fused(64, 4, setup) else {
                return;
            };
            let mut b = ppo(64, 4);
            setup(&mut b);
            rollout(&mut b);
            rollout(&mut f);
            // The same rollout: both sampled with burn's forward pass on the CPU.
            assert_eq!(b.storage.mu, f.storage.mu);
            let l = b.minibatch_losses(whole_rollout(&b));
            let expected_losses = [
                l.surrogate.clone().into_scalar::<f32>(),
                l.value.clone().into_scalar::<f32>(),
                l.kl.into_scalar::<f32>(),
            ];
            let loss = l.surrogate + l.value.mul_scalar(b.cfg.value_loss_coef)
                - l.entropy.mul_scalar(b.cfg.entropy_coef);
            let grads = GradientsParams::from_grads(loss.backward(), &b.model);
            let expected = gradients(&b.model, &grads);
            f.update().expect("a finite update");
            let trainer = f.fused.as_ref().and_then(|x| x.trainer.as_ref()).unwrap();
            let got = trainer.last_gradients().expect("gradients");
            let mut at = 0;
            for (i, e) in expected.iter().enumerate() {
                let g = &got[at..at + e.len()];
                at += e.len();
                let scale = e.iter().fold(0.0f32, |m, v| m.max(v.abs()));
                let worst = g
                    .iter()
                    .zip(e)
                    .map(|(a, b)| (a - b).abs())
                    .fold(0.0, f32::max);
                assert!(
                    scale > 0.0 && worst <= 1e-4 * scale,
                    "{noise:?}, clipped {clipped}: parameter {i} differs by {worst} (scale \
                     {scale}): {g:?} vs {e:?}"
                );
            }
            for (k, e) in expected_losses.iter().enumerate() {
                let g = got[at + k];
                assert!(
                    (g - e).abs() <= 1e-5 * e.abs().max(1e-2),
                    "loss {k}: {g} vs {e}"
                );
            }
        }
    }

    /// Two fused learners with the same seed take the same parameters, bit for bit, through
    /// two updates of several minibatches with the adaptive rate and per-network clipping.
    #[test]
    fn fused_updates_repeat_bit_for_bit() {
        let setup = |p: &mut Ppo| p.cfg.grad_clip = GradClip::PerNetwork;
        let run = || {
            let mut p = fused(32, 8, setup)?;
            for _ in 0..2 {
                rollout(&mut p);
                p.update().expect("a finite update");
            }
            Some((p.model.parameter_values(), p.learning_rate()))
        };
        let Some(first) = run() else {
            return;
        };
        assert_eq!(Some(first.clone()), run());
        assert_ne!(first.0, ppo(32, 8).model.parameter_values(), "it learned");
    }

    /// A fused update whose losses turn non-finite fails and leaves the parameters, Adam's
    /// state and the learning rate as they were: the next finite update gives what a clean
    /// learner's first update gives.
    #[test]
    fn a_failed_fused_update_changes_nothing() {
        let Some(mut clean) = fused(16, 4, |_| {}) else {
            return;
        };
        rollout(&mut clean);
        clean.update().unwrap();
        let mut p = fused(16, 4, |_| {}).unwrap();
        rollout(&mut p);
        let returns = std::mem::replace(&mut p.storage.returns, vec![f32::NAN; 64]);
        assert!(matches!(p.update(), Err(RlError::NonFinite(_))));
        assert_eq!(
            p.model.parameter_values(),
            ppo(16, 4).model.parameter_values()
        );
        p.storage.returns = returns;
        p.update().unwrap();
        assert_eq!(p.model.parameter_values(), clean.model.parameter_values());
        assert_eq!(p.learning_rate(), clean.learning_rate());
    }

    /// A critic that starts reading observations of its own in the middle of a rollout is
    /// refused (the rows already sent lack them); at a rollout's first step it is taken.
    #[test]
    fn critic_inputs_change_only_between_rollouts() {
        let Some(mut p) = fused(4, 2, |_| {}) else {
            return;
        };
        let obs: Vec<f32> = (0..12).map(|i| i as f32 * 0.1).collect();
        let own = obs.clone();
        let mut actions = vec![0.0; 8];
        p.act(&obs, &obs, &mut actions).unwrap();
        p.process_env_step(&[0.0; 4], &[false; 4], &[false; 4]);
        let err = p.act(&obs, &own, &mut actions).unwrap_err();
        assert!(matches!(err, RlError::EnvMismatch(_)), "{err}");
        p.storage.step = 0;
        p.act(&obs, &own, &mut actions).unwrap();
        assert!(p.fused.as_ref().unwrap().separate_critic().unwrap());
    }

    /// A checkpoint written after fused updates holds the device's Adam state: a fresh fused
    /// learner loaded from it takes the same next update as the learner that wrote it.
    #[test]
    fn fused_checkpoints_resume_exactly() {
        let Some(mut p) = fused(16, 4, |_| {}) else {
            return;
        };
        rollout(&mut p);
        p.update().unwrap();
        let base = std::env::temp_dir().join(format!("orbit-fused-{}", std::process::id()));
        p.save(&base).unwrap();
        let mut resumed = fused(16, 4, |_| {}).unwrap();
        resumed.load(&base, true).unwrap();
        resumed.set_learning_rate(p.learning_rate());
        resumed.updates = p.updates;
        // The action noise's streams are the run's, not the checkpoint's.
        resumed.noise = p.noise.clone();
        for learner in [&mut p, &mut resumed] {
            rollout(learner);
            learner.update().unwrap();
        }
        assert_eq!(p.model.parameter_values(), resumed.model.parameter_values());
        for ext in ["bpk", "adam.bpk"] {
            std::fs::remove_file(base.with_extension(ext)).unwrap();
        }
    }
}
