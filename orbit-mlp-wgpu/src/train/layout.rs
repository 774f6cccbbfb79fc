//! Where the trainer keeps what: the flat parameters of both networks and the sections of a
//! rollout and of a minibatch, as the kernels' `Hyper` uniform describes them.

use super::{PpoSettings, PpoShape};
use crate::MlpError;

/// The fewest rows of a chunk of a minibatch and the most chunks: weight gradients are summed
/// per chunk, then the chunks in order, so that a small product over thousands of rows still
/// spreads over many workgroups. A workgroup's sum over a chunk is a chain of its rows / 16
/// steps, so short chunks finish sooner; more chunks mean more partial sums to add.
const MIN_CHUNK_ROWS: usize = 64;
const MAX_CHUNKS: usize = 128;

/// Rows per chunk for minibatches of `m` rows: at least [`MIN_CHUNK_ROWS`], at most
/// [`MAX_CHUNKS`] chunks, a multiple of 16 (the kernel's slice).
pub(super) fn chunk_rows(m: usize) -> usize {
    m.div_ceil(MAX_CHUNKS)
        .next_multiple_of(16)
        .max(MIN_CHUNK_ROWS)
}

/// The kernels' `Hyper` uniform (`ppo.wgsl`), field for field.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub(super) struct Hyper {
    pub rows: u32,
    pub batch: u32,
    pub minibatches: u32,
    pub actions: u32,
    pub params: u32,
    pub critic_at: u32,
    pub noise_at: u32,
    pub chunks: u32,
    pub chunk_rows: u32,
    pub clipped_value_loss: u32,
    pub log_std: u32,
    pub per_network_clip: u32,
    pub adaptive: u32,
    pub clip: f32,
    pub value_coef: f32,
    pub entropy_coef: f32,
    pub desired_kl: f32,
    pub max_grad_norm: f32,
    pub beta_1: f32,
    pub beta_2: f32,
    pub epsilon: f32,
    pub obs_width: u32,
    pub critic_width: u32,
    pub rollout_obs: u32,
    pub rollout_critic: u32,
    pub rollout_actions: u32,
    pub rollout_mu: u32,
    pub rollout_scalars: u32,
    pub mb_obs: u32,
    pub mb_critic: u32,
    pub mb_actions: u32,
    pub mb_mu: u32,
    pub mb_scalars: u32,
    pub separate_critic: u32,
}

/// A layer's place in the flat parameters.
#[derive(Clone, Copy, Debug)]
pub(super) struct LayerAt {
    /// Inputs and outputs.
    pub k: usize,
    pub n: usize,
    /// Where its `W [k, n]` begins; `b [n]` follows.
    pub weight: usize,
}

/// The offsets of everything, from a shape.
#[derive(Clone, Debug)]
pub(super) struct Layout {
    pub actor: Vec<LayerAt>,
    pub critic: Vec<LayerAt>,
    /// Parameters, without the three loss slots that follow them in the gradients.
    pub params: usize,
    /// Minibatch rows and chunks of them.
    pub rows: usize,
    pub chunks: usize,
    pub chunk_rows: usize,
    /// Floats of the rollout and of the minibatch buffers.
    pub rollout_floats: usize,
    pub minibatch_floats: usize,
    pub hyper: Hyper,
}

/// The layers of a network of `widths`, from flat index `at`; returns the index after them.
fn layers(widths: &[usize], mut at: usize) -> (Vec<LayerAt>, usize) {
    let layers = widths
        .windows(2)
        .map(|w| {
            let layer = LayerAt {
                k: w[0],
                n: w[1],
                weight: at,
            };
            at += w[0] * w[1] + w[1];
            layer
        })
        .collect();
    (layers, at)
}

impl Layout {
    /// The layout of `shape`, checked against what the kernels index with 32-bit integers,
    /// `max_binding` bytes per buffer and `max_groups` workgroups per dimension of a dispatch.
    pub(super) fn new(
        shape: &PpoShape,
        settings: &PpoSettings,
        (max_binding, max_groups): (u64, u32),
    ) -> Result<Self, MlpError> {
        let (actor_w, critic_w) = (&shape.actor_widths, &shape.critic_widths);
        if actor_w.len() < 2 || critic_w.len() < 2 || actor_w.contains(&0) || critic_w.contains(&0)
        {
            return Err(MlpError::Shape(format!(
                "the actor and the critic need two non-zero widths at least, got {actor_w:?} \
                 and {critic_w:?}"
            )));
        }
        if critic_w.last() != Some(&1) {
            return Err(MlpError::Shape(format!(
                "the critic has one output (the value), got widths {critic_w:?}"
            )));
        }
        let a = *actor_w.last().expect("two widths");
        let (no, nc) = (actor_w[0], critic_w[0]);
        if !shape.separate_critic && no != nc {
            return Err(MlpError::Shape(format!(
                "a critic that reads the actor's {no} observations cannot take {nc} inputs"
            )));
        }
        let b = shape.batch;
        if shape.minibatches == 0 || b < shape.minibatches {
            return Err(MlpError::Shape(format!(
                "{b} rollout rows cannot fill {} minibatches",
                shape.minibatches
            )));
        }
        let m = b / shape.minibatches;
        // A minibatch's rows are spread over workgroups of 64 rows in one dimension.
        let max_rows = 64 * max_groups as usize;
        if m > max_rows {
            return Err(MlpError::Shape(format!(
                "a minibatch of {m} rows is more than the update's kernels take ({max_rows}): \
                 use more minibatches"
            )));
        }
        let (actor, critic_at) = layers(actor_w, 0);
        let (critic, noise_at) = layers(critic_w, critic_at);
        let params = noise_at + a;
        let chunk_rows = chunk_rows(m);
        let chunks = m.div_ceil(chunk_rows);
        // Sections: observations, critic observations (the actor's where the critic has none of
        // its own), actions, means, four scalars per row.
        let sections = |rows: usize| {
            let obs = 0;
            let (critic, actions) = if shape.separate_critic {
                (obs + rows * no, obs + rows * (no + nc))
            } else {
                (obs, obs + rows * no)
            };
            let mu = actions + rows * a;
            let scalars = mu + rows * a;
            ([obs, critic, actions, mu, scalars], scalars + 4 * rows)
        };
        let (rollout, rollout_floats) = sections(b);
        let (mini, minibatch_floats) = sections(m);
        let widest = actor_w.iter().chain(critic_w).max().copied().unwrap_or(1);
        let largest = [rollout_floats, chunks * (params + 3), m * widest.max(a + 3)]
            .into_iter()
            .max()
            .expect("three sizes");
        let max_floats = (max_binding / 4).min(u64::from(u32::MAX)) as usize;
        if largest > max_floats {
            return Err(MlpError::Shape(format!(
                "a rollout of {b} rows needs a buffer of {largest} floats, more than the \
                 {max_floats} the device binds: use fewer envs or steps per env"
            )));
        }
        let u = |v: usize| v as u32;
        let hyper = Hyper {
            rows: u(m),
            batch: u(b),
            minibatches: u(shape.minibatches),
            actions: u(a),
            params: u(params),
            critic_at: u(critic_at),
            noise_at: u(noise_at),
            chunks: u(chunks),
            chunk_rows: u(chunk_rows),
            clipped_value_loss: u32::from(settings.clipped_value_loss),
            log_std: u32::from(shape.log_std),
            per_network_clip: u32::from(settings.per_network_clip),
            adaptive: u32::from(settings.desired_kl.is_some()),
            clip: settings.clip,
            value_coef: settings.value_coef,
            entropy_coef: settings.entropy_coef,
            desired_kl: settings.desired_kl.unwrap_or(0.0),
            max_grad_norm: settings.max_grad_norm,
            beta_1: 0.9,
            beta_2: 0.999,
            epsilon: 1e-8,
            obs_width: u(no),
            critic_width: u(nc),
            rollout_obs: u(rollout[0]),
            rollout_critic: u(rollout[1]),
            rollout_actions: u(rollout[2]),
            rollout_mu: u(rollout[3]),
            rollout_scalars: u(rollout[4]),
            mb_obs: u(mini[0]),
            mb_critic: u(mini[1]),
            mb_actions: u(mini[2]),
            mb_mu: u(mini[3]),
            mb_scalars: u(mini[4]),
            separate_critic: u32::from(shape.separate_critic),
        };
        Ok(Self {
            actor,
            critic,
            params,
            rows: m,
            chunks,
            chunk_rows,
            rollout_floats,
            minibatch_floats,
            hyper,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::{Layout, chunk_rows};
    use crate::Activation;
    use crate::train::{PpoSettings, PpoShape};

    fn shape(batch: usize, minibatches: usize) -> PpoShape {
        PpoShape {
            actor_widths: vec![53, 256, 128, 64, 7],
            critic_widths: vec![53, 256, 128, 64, 1],
            activation: Activation::Elu,
            log_std: false,
            batch,
            minibatches,
            separate_critic: false,
        }
    }

    fn settings() -> PpoSettings {
        PpoSettings {
            clip: 0.2,
            value_coef: 1.0,
            entropy_coef: 0.0,
            clipped_value_loss: true,
            desired_kl: Some(0.01),
            max_grad_norm: 1.0,
            per_network_clip: true,
            epochs: 5,
        }
    }

    /// Parameters follow each other as the learner visits them: each layer's weights then
    /// biases, the actor's layers, the critic's, then the noise; the loss slots are not
    /// parameters.
    #[test]
    fn parameters_are_laid_out_in_visit_order() {
        let l = Layout::new(&shape(4096 * 24, 16), &settings(), (1 << 31, 65535)).unwrap();
        let layer = |k: usize, n: usize| k * n + n;
        let actor = layer(53, 256) + layer(256, 128) + layer(128, 64) + layer(64, 7);
        let critic = layer(53, 256) + layer(256, 128) + layer(128, 64) + layer(64, 1);
        assert_eq!(l.hyper.critic_at as usize, actor);
        assert_eq!(l.hyper.noise_at as usize, actor + critic);
        assert_eq!(l.params, actor + critic + 7);
        assert_eq!(l.critic[1].weight, actor + layer(53, 256));
    }

    /// Chunks hold at least 64 rows and number at most 128, in whole slices of 16 rows.
    #[test]
    fn chunks_are_short_and_few() {
        for (m, rows) in [(100, 64), (6144, 64), (8192, 64), (8193, 80), (32768, 256)] {
            assert_eq!(chunk_rows(m), rows, "{m} rows");
            assert!(m.div_ceil(rows) <= 128);
        }
    }

    /// A minibatch with more rows than a dispatch's workgroups can cover (262 144 envs × 24
    /// steps in one minibatch, 65 535 groups of 64 rows) is refused with what to change, as is
    /// a rollout larger than a buffer binding.
    #[test]
    fn oversized_minibatches_and_rollouts_are_refused() {
        let err = Layout::new(&shape(262_144 * 24, 1), &settings(), (u64::MAX, 65535))
            .unwrap_err()
            .to_string();
        assert!(err.contains("use more minibatches"), "{err}");
        assert!(Layout::new(&shape(262_144 * 24, 2), &settings(), (u64::MAX, 65535)).is_ok());
        let err = Layout::new(&shape(131_072 * 24, 4), &settings(), (1 << 27, 65535))
            .unwrap_err()
            .to_string();
        assert!(err.contains("use fewer envs"), "{err}");
    }
}
