//! [`PpoTrainer`]: PPO's update of an MLP actor and critic as kernels of this crate, on the
//! device that collects the rollouts.
//!
//! A gradient step is a fixed list of dispatches recorded once: gather the minibatch's rows,
//! the layers forward (`matmul.wgsl`), the per-row loss and its gradients, the layers backward
//! with each weight gradient summed per chunk of rows, the chunks summed in order, the
//! gradient norms, the KL-adaptive learning rate and Adam (`ppo.wgsl`). Whatever changes from
//! step to step (the minibatch, Adam's step count, the learning rate) lives in a small buffer
//! on the device, so a whole update is one submission and the host reads its results once.

mod kernels;
mod layout;
mod step;

use crate::{Activation, MlpError};
use layout::Layout;
use step::{Buffers, Dispatch};

/// The networks and the rollout a trainer is built for.
#[derive(Clone, Debug, PartialEq)]
pub struct PpoShape {
    /// The actor's widths: observations, hidden layers, actions.
    pub actor_widths: Vec<usize>,
    /// The critic's widths: critic observations, hidden layers, 1.
    pub critic_widths: Vec<usize>,
    /// The activation after every hidden layer.
    pub activation: Activation,
    /// Whether the noise parameter is `log σ` (else σ itself, clamped at 1e-6).
    pub log_std: bool,
    /// Rows of a rollout (steps × envs).
    pub batch: usize,
    /// Minibatches per epoch (the rollout's rows are split evenly; a remainder is unused).
    pub minibatches: usize,
    /// Whether the critic reads observations of its own (else the actor's).
    pub separate_critic: bool,
}

/// PPO's settings (RSL-RL's).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PpoSettings {
    /// ε of the clipped surrogate and of the value clipping.
    pub clip: f32,
    /// Weight of the value loss.
    pub value_coef: f32,
    /// Weight of the entropy bonus.
    pub entropy_coef: f32,
    /// Clip the value loss around the old values.
    pub clipped_value_loss: bool,
    /// The KL divergence the adaptive learning rate aims at; `None` keeps the rate fixed.
    pub desired_kl: Option<f32>,
    /// The gradient-norm limit.
    pub max_grad_norm: f32,
    /// Clip the actor's (with the noise parameter) and the critic's gradients each, instead
    /// of all together.
    pub per_network_clip: bool,
    /// Passes over the rollout per update.
    pub epochs: usize,
}

/// What an update needs besides the observations and actions of
/// [`PpoTrainer::write_step`], each `[batch]` or `[batch, actions]` in rollout order.
#[derive(Clone, Copy, Debug)]
pub struct UpdateInputs<'a> {
    /// The sampling policy's action means.
    pub mu: &'a [f32],
    /// Its log-probabilities of the taken actions.
    pub log_prob: &'a [f32],
    /// The advantages, normalised as the update should see them.
    pub advantages: &'a [f32],
    /// The critic's targets.
    pub returns: &'a [f32],
    /// The critic's values at sampling time (for value clipping).
    pub values: &'a [f32],
    /// The sampling policy's σ, `[actions]`.
    pub sigma: &'a [f32],
    /// The rows in the order the minibatches take them (every epoch takes the same order).
    pub perm: &'a [u32],
}

/// What an update did.
#[derive(Clone, Debug, PartialEq)]
pub struct UpdateOutcome {
    /// Every parameter after the update (or as before it, if it was not applied).
    pub params: Vec<f32>,
    /// The value loss summed over the update's gradient steps.
    pub value: f32,
    /// The surrogate loss summed over the update's gradient steps.
    pub surrogate: f32,
    /// The policy's entropy summed over the update's gradient steps.
    pub entropy: f32,
    /// The learning rate at the end of the update.
    pub learning_rate: f32,
    /// Adam steps taken since the start (or the last [`PpoTrainer::load_state`]).
    pub steps: u32,
    /// Whether the update was kept: one whose value or surrogate loss sum is not finite is
    /// undone (parameters, Adam's moments and step count, the learning rate).
    pub applied: bool,
}

/// Gradient steps recorded per submission.
const STEPS_PER_SUBMISSION: usize = 8;

/// The `Scalars` struct of `ppo.wgsl`: 8 four-byte fields.
const SCALARS_BYTES: u64 = 32;

/// PPO's update of an MLP actor-critic on a wgpu device (see the module's documentation).
pub struct PpoTrainer {
    device: wgpu::Device,
    queue: wgpu::Queue,
    layout: Layout,
    shape: PpoShape,
    epochs: usize,
    buffers: Buffers,
    step: Vec<Dispatch>,
}

impl PpoTrainer {
    /// A trainer for `shape` with `settings`, with zero parameters until
    /// [`load_state`](Self::load_state).
    pub fn new(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        shape: PpoShape,
        settings: PpoSettings,
    ) -> Result<Self, MlpError> {
        if settings.epochs == 0 {
            return Err(MlpError::Shape("an update takes at least one epoch".into()));
        }
        let limits = device.limits();
        let max_binding = limits
            .max_storage_buffer_binding_size
            .min(limits.max_buffer_size);
        let max_groups = limits.max_compute_workgroups_per_dimension;
        let layout = Layout::new(&shape, &settings, (max_binding, max_groups))?;
        let (buffers, step) = step::record(device, queue, &layout, &shape)?;
        Ok(Self {
            device: device.clone(),
            queue: queue.clone(),
            layout,
            shape,
            epochs: settings.epochs,
            buffers,
            step,
        })
    }

    /// Whether the critic reads observations of its own.
    pub fn separate_critic(&self) -> bool {
        self.shape.separate_critic
    }

    /// Parameters of both networks and the noise, in the order of
    /// [`load_state`](Self::load_state).
    pub fn num_params(&self) -> usize {
        self.layout.params
    }

    /// Sets the parameters (the actor's layers, each `W [k, n]` row-major then `b`, the
    /// critic's, then the noise parameter), Adam's moments in the same order, its step count
    /// and the learning rate.
    pub fn load_state(
        &mut self,
        params: &[f32],
        moments: (&[f32], &[f32]),
        steps: u32,
        learning_rate: f32,
    ) -> Result<(), MlpError> {
        let p = self.layout.params;
        if params.len() != p || moments.0.len() != p || moments.1.len() != p {
            return Err(MlpError::Shape(format!(
                "the networks have {p} parameters, got {} values and moments of {} and {}",
                params.len(),
                moments.0.len(),
                moments.1.len()
            )));
        }
        let b = &self.buffers;
        self.queue
            .write_buffer(&b.params, 0, bytemuck::cast_slice(params));
        self.queue
            .write_buffer(&b.first, 0, bytemuck::cast_slice(moments.0));
        self.queue
            .write_buffer(&b.second, 0, bytemuck::cast_slice(moments.1));
        let scalars: [u32; 8] = [learning_rate.to_bits(), steps, 0, 0, 0, 0, 0, 0];
        self.queue
            .write_buffer(&b.scal, 0, bytemuck::cast_slice(&scalars));
        Ok(())
    }

    /// Sets the learning rate (the adaptive schedule changes it on the device).
    pub fn set_learning_rate(&mut self, learning_rate: f32) {
        self.queue
            .write_buffer(&self.buffers.scal, 0, bytemuck::bytes_of(&learning_rate));
    }

    /// Stores step `step` of the rollout: `envs` rows of observations, of the critic's own
    /// observations (where it has them) and of actions.
    pub fn write_step(
        &mut self,
        step: usize,
        obs: &[f32],
        critic_obs: Option<&[f32]>,
        actions: &[f32],
    ) -> Result<(), MlpError> {
        let s = &self.shape;
        let (no, nc) = (s.actor_widths[0], s.critic_widths[0]);
        let a = s.actor_widths[s.actor_widths.len() - 1];
        let envs = actions.len() / a.max(1);
        let steps = s.batch / envs.max(1);
        if envs == 0
            || step >= steps
            || actions.len() != envs * a
            || obs.len() != envs * no
            || critic_obs.is_some() != s.separate_critic
            || critic_obs.is_some_and(|c| c.len() != envs * nc)
        {
            return Err(MlpError::Shape(format!(
                "step {step} of a rollout of {} rows: expected rows of {no} observations, {} \
                 and {a} actions, got {} observations, {:?} critic observations and {} actions",
                s.batch,
                if s.separate_critic {
                    format!("{nc} critic observations")
                } else {
                    "no critic observations".into()
                },
                obs.len(),
                critic_obs.map(<[f32]>::len),
                actions.len()
            )));
        }
        let hy = &self.layout.hyper;
        let row = step * envs;
        let write = |section: u32, width: usize, values: &[f32]| {
            let at = 4 * (section as usize + row * width);
            self.queue.write_buffer(
                &self.buffers.rollout,
                at as u64,
                bytemuck::cast_slice(values),
            );
        };
        write(hy.rollout_obs, no, obs);
        if let Some(c) = critic_obs {
            write(hy.rollout_critic, nc, c);
        }
        write(hy.rollout_actions, a, actions);
        Ok(())
    }

    /// One update over the rollout (epochs × minibatches gradient steps in one submission),
    /// waiting for the device.
    pub fn update(&mut self, inputs: UpdateInputs) -> Result<UpdateOutcome, MlpError> {
        let (bsz, a) = (self.shape.batch, self.layout.hyper.actions as usize);
        let lengths = [
            (inputs.mu.len(), bsz * a),
            (inputs.log_prob.len(), bsz),
            (inputs.advantages.len(), bsz),
            (inputs.returns.len(), bsz),
            (inputs.values.len(), bsz),
            (inputs.sigma.len(), a),
            (inputs.perm.len(), self.layout.rows * self.shape.minibatches),
        ];
        if lengths.iter().any(|(got, want)| got != want)
            || inputs.perm.iter().any(|&i| i as usize >= bsz)
        {
            return Err(MlpError::Shape(format!(
                "an update of {bsz} rows and {a} actions takes means, log-probabilities, \
                 advantages, returns, values, σ and a permutation of (length, expected): \
                 {lengths:?}, all indices below {bsz}"
            )));
        }
        let b = &self.buffers;
        let hy = &self.layout.hyper;
        let q = &self.queue;
        q.write_buffer(
            &b.rollout,
            4 * u64::from(hy.rollout_mu),
            bytemuck::cast_slice(inputs.mu),
        );
        let scalars = [
            inputs.log_prob,
            inputs.advantages,
            inputs.returns,
            inputs.values,
        ];
        for (s, values) in scalars.iter().enumerate() {
            let at = 4 * (hy.rollout_scalars as usize + s * bsz);
            q.write_buffer(&b.rollout, at as u64, bytemuck::cast_slice(values));
        }
        q.write_buffer(&b.old_sigma, 0, bytemuck::cast_slice(inputs.sigma));
        q.write_buffer(&b.perm, 0, bytemuck::cast_slice(inputs.perm));
        // The minibatch counter and the loss totals start at 0.
        q.write_buffer(&b.scal, 8, bytemuck::bytes_of(&0u32));
        q.write_buffer(&b.scal, 20, bytemuck::cast_slice(&[0f32; 3]));
        let encoder = |label| {
            self.device
                .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some(label) })
        };
        let mut backup = encoder("orbit ppo backup");
        for (from, to) in [&b.params, &b.first, &b.second, &b.scal]
            .into_iter()
            .zip(&b.backup)
        {
            backup.copy_buffer_to_buffer(from, 0, to, 0, from.size());
        }
        self.queue.submit([backup.finish()]);
        // Submitted in parts, so that the device runs the first steps while the host records
        // the next ones.
        let steps = self.epochs * self.shape.minibatches;
        for first in (0..steps).step_by(STEPS_PER_SUBMISSION) {
            let mut steps_encoder = encoder("orbit ppo update");
            {
                let mut pass = steps_encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                    label: Some("orbit ppo update"),
                    timestamp_writes: None,
                });
                for _ in first..(first + STEPS_PER_SUBMISSION).min(steps) {
                    for d in &self.step {
                        pass.set_pipeline(&d.pipeline);
                        pass.set_bind_group(0, &d.bind_group, &[]);
                        let [x, y, z] = d.groups;
                        pass.dispatch_workgroups(x, y, z);
                    }
                }
            }
            self.queue.submit([steps_encoder.finish()]);
        }
        let read = self.read(&[&b.params, &b.scal])?;
        let p = self.layout.params;
        let scal = &read[p..];
        let (value, surrogate, entropy) = (scal[5], scal[6], scal[7]);
        let applied = value.is_finite() && surrogate.is_finite();
        let params = if applied {
            read[..p].to_vec()
        } else {
            self.restore()?
        };
        Ok(UpdateOutcome {
            params,
            value,
            surrogate,
            entropy,
            learning_rate: scal[0],
            steps: scal[1].to_bits(),
            applied,
        })
    }

    /// Adam's first and second moments, in the parameters' order.
    pub fn moments(&self) -> Result<(Vec<f32>, Vec<f32>), MlpError> {
        let mut both = self.read(&[&self.buffers.first, &self.buffers.second])?;
        let second = both.split_off(self.layout.params);
        Ok((both, second))
    }

    /// The last gradient step's gradient of every parameter (before the norm clip), then its
    /// mean surrogate loss, value loss and KL divergence.
    pub fn last_gradients(&self) -> Result<Vec<f32>, MlpError> {
        let mut g = self.read(&[&self.buffers.grads])?;
        g.truncate(self.layout.params + 3);
        Ok(g)
    }

    /// Runs one more gradient step (on the last update's rollout; it changes the parameters)
    /// with each dispatch timed on the device: what each computes and its time in seconds.
    /// `None` on a device without timestamp queries.
    pub fn profile_step(&mut self) -> Result<Option<Vec<(String, f64)>>, MlpError> {
        if !self
            .device
            .features()
            .contains(wgpu::Features::TIMESTAMP_QUERY)
        {
            return Ok(None);
        }
        let count = 2 * self.step.len() as u32;
        let queries = self.device.create_query_set(&wgpu::QuerySetDescriptor {
            label: Some("orbit ppo profile"),
            ty: wgpu::QueryType::Timestamp,
            count,
        });
        let resolved = self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("orbit ppo profile"),
            size: 8 * u64::from(count),
            usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let mut encoder = self
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("orbit ppo profile"),
            });
        for (i, d) in self.step.iter().enumerate() {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some(&d.label),
                timestamp_writes: Some(wgpu::ComputePassTimestampWrites {
                    query_set: &queries,
                    beginning_of_pass_write_index: Some(2 * i as u32),
                    end_of_pass_write_index: Some(2 * i as u32 + 1),
                }),
            });
            pass.set_pipeline(&d.pipeline);
            pass.set_bind_group(0, &d.bind_group, &[]);
            let [x, y, z] = d.groups;
            pass.dispatch_workgroups(x, y, z);
        }
        encoder.resolve_query_set(&queries, 0..count, &resolved, 0);
        self.queue.submit([encoder.finish()]);
        let ticks: Vec<u64> = bytemuck::pod_collect_to_vec(&self.read(&[&resolved])?);
        let period = f64::from(self.queue.get_timestamp_period()) * 1e-9;
        Ok(Some(
            self.step
                .iter()
                .zip(ticks.chunks_exact(2))
                .map(|(d, t)| (d.label.clone(), t[1].saturating_sub(t[0]) as f64 * period))
                .collect(),
        ))
    }

    /// Puts back the parameters, moments and scalars copied before the last update; returns
    /// the parameters.
    fn restore(&self) -> Result<Vec<f32>, MlpError> {
        let b = &self.buffers;
        let mut encoder = self
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("orbit ppo restore"),
            });
        for (from, to) in b
            .backup
            .iter()
            .zip([&b.params, &b.first, &b.second, &b.scal])
        {
            encoder.copy_buffer_to_buffer(from, 0, to, 0, to.size());
        }
        self.queue.submit([encoder.finish()]);
        let mut params = self.read(&[&b.params])?;
        params.truncate(self.layout.params);
        Ok(params)
    }

    /// The contents of `buffers`, one after the other, as floats (waits for the device).
    fn read(&self, buffers: &[&wgpu::Buffer]) -> Result<Vec<f32>, MlpError> {
        let bytes: u64 = buffers.iter().map(|b| b.size()).sum();
        let staging = self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("orbit train readback"),
            size: bytes,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let mut encoder = self
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("orbit train readback"),
            });
        let mut at = 0;
        for b in buffers {
            encoder.copy_buffer_to_buffer(b, 0, &staging, at, b.size());
            at += b.size();
        }
        let submission = self.queue.submit([encoder.finish()]);
        crate::readback::read_mapped(
            &self.device,
            submission,
            (&staging, bytes),
            "update",
            <[f32]>::to_vec,
        )
    }
}
