//! The learner as one replica of a data-parallel run (RSL-RL's multi-GPU PPO): rank 0's
//! parameters to start, and every minibatch the gradients and the KL divergence averaged over
//! the ranks before the clip, the adaptive learning rate and the Adam step. The values travel
//! through host memory (one read and one upload per minibatch), whatever the device.

use std::sync::Arc;

use burn::module::{Module, ModuleVisitor, Param};
use burn::optim::GradientsParams;
use burn::tensor::Tensor;
use orbit_core::rng::EnvRng;

use super::{Ppo, tensor1, values};
use crate::collective::{self, Collective};
use crate::model::ActorCritic;
use crate::streams;

impl Ppo {
    /// Makes this learner a replica of a data-parallel run: it takes rank 0's parameters now,
    /// and from then on averages gradients, KL divergences and normalisation statistics with
    /// the other ranks. Its envs are numbered from `rank · num_envs` for the action noise,
    /// as if one learner held every rank's envs.
    pub fn distribute(&mut self, c: Arc<dyn Collective>) {
        let first =
            u32::try_from(c.rank() * self.storage.num_envs).expect("env numbers fit in u32");
        self.noise = (0..self.storage.num_envs as u32)
            .map(|e| EnvRng::new(self.seed, first + e, streams::ACTION_NOISE))
            .collect();
        self.model = broadcast_parameters(&*c, self.model.clone());
        self.rollout_model = None;
        self.collective = Some(c);
    }

    /// The rank group, when this learner is a replica of a data-parallel run.
    pub fn collective(&self) -> Option<&dyn Collective> {
        self.collective.as_deref()
    }
}

/// `model` with rank 0's parameter values.
fn broadcast_parameters(c: &dyn Collective, model: ActorCritic) -> ActorCritic {
    let root = collective::from_rank_0(c, &model.parameter_values());
    model.with_parameter_values(&root)
}

/// Replaces `grads` by their mean over the ranks and returns the mean of `kl` (shape `[1]`, off
/// the autodiff graph), with one read from the device and one upload.
pub(super) fn average_gradients(
    c: &dyn Collective,
    model: &ActorCritic,
    grads: &mut GradientsParams,
    kl: Tensor<1>,
) -> Tensor<1> {
    // Each gradient has its parameter's shape: the flat mean is cut back along the same visit.
    struct Flatten<'a> {
        grads: &'a GradientsParams,
        parts: Vec<Tensor<1>>,
    }
    impl ModuleVisitor for Flatten<'_> {
        fn visit_float<const D: usize>(&mut self, param: &Param<Tensor<D>>) {
            if let Some(g) = self.grads.get::<D>(param.id) {
                let n = g.shape().num_elements();
                self.parts.push(g.reshape([n]));
            }
        }
    }
    let kl = kl.inner();
    let device = kl.device();
    let mut flat = Flatten {
        grads,
        parts: Vec::new(),
    };
    model.visit(&mut flat);
    let mut parts = flat.parts;
    parts.push(kl);
    let local = values(Tensor::cat(parts, 0));
    let mean = tensor1(collective::mean_f32(c, &local), &device);
    struct Register<'a> {
        grads: &'a mut GradientsParams,
        mean: &'a Tensor<1>,
        offset: usize,
    }
    impl ModuleVisitor for Register<'_> {
        fn visit_float<const D: usize>(&mut self, param: &Param<Tensor<D>>) {
            if self.grads.get::<D>(param.id).is_some() {
                let shape = param.dims();
                let n: usize = shape.iter().product();
                let g = self
                    .mean
                    .clone()
                    .slice(self.offset..self.offset + n)
                    .reshape(shape);
                self.offset += n;
                self.grads.register(param.id, g);
            }
        }
    }
    let mut register = Register {
        grads,
        mean: &mean,
        offset: 0,
    };
    model.visit(&mut register);
    let offset = register.offset;
    Tensor::from_inner(mean.slice(offset..offset + 1))
}

#[cfg(test)]
mod tests {
    use std::sync::Arc;

    use crate::collective::Collective;
    use crate::collective::threads::group;
    use crate::normalizer::EmpiricalNormalizer;
    use crate::ppo::Ppo;
    use crate::ppo::fixtures::ppo;

    const ENVS: usize = 16;
    const STEPS: usize = 4;

    /// A learner for `envs` envs: one minibatch per epoch, three epochs, value normalisation.
    fn learner(envs: usize) -> Ppo {
        let mut p = ppo(envs, STEPS);
        p.cfg.num_mini_batches = 1;
        p.cfg.num_learning_epochs = 3;
        p.cfg.normalize_value = true;
        p.value_normalizer = Some(EmpiricalNormalizer::new(1, u64::MAX));
        p
    }

    /// Collects a rollout over the envs `first..first + p.num_envs` of a fixed global batch
    /// (observations, rewards and episode ends a function of the global env and the step),
    /// updates, and returns the parameters and the learning rate.
    fn rollout_and_update(p: &mut Ppo, first: usize) -> (Vec<f32>, f64) {
        let n = p.storage.num_envs;
        let obs_of = |t: usize| -> Vec<f32> {
            (first..first + n)
                .flat_map(|g| {
                    (0..3).map(move |k| (((g * 7 + t * 3 + k * 5) % 11) as f32) * 0.2 - 1.0)
                })
                .collect()
        };
        let mut actions = vec![0.0; n * 2];
        for t in 0..STEPS {
            let obs = obs_of(t);
            p.act(&obs, &obs, &mut actions).unwrap();
            let rewards: Vec<f32> = actions
                .chunks(2)
                .enumerate()
                .map(|(e, a)| 1.0 - a[0] * a[0] + 0.1 * ((first + e) % 4) as f32)
                .collect();
            let dones: Vec<bool> = (first..first + n).map(|g| (g + t) % 3 == 0).collect();
            let time_outs: Vec<bool> = (first..first + n).map(|g| (g + t) % 6 == 0).collect();
            p.process_env_step(&rewards, &dones, &time_outs);
        }
        p.compute_returns(&obs_of(STEPS));
        p.update().unwrap();
        (p.model.parameter_values(), p.learning_rate())
    }

    /// Two ranks with half the envs each end an update with bit-identical parameters, equal
    /// (within 1e-6, while the update moves them by more than 1e-3) to one learner's update
    /// on all the envs: the same rows, gradients averaged over the ranks, advantages and
    /// return statistics pooled.
    #[test]
    fn two_ranks_update_as_one_learner_on_the_whole_batch() {
        let mut before = learner(ENVS);
        let initial = before.model.parameter_values();
        let (whole, whole_rate) = rollout_and_update(&mut before, 0);
        let ranks: Vec<(Vec<f32>, f64)> = std::thread::scope(|s| {
            let handles: Vec<_> = group(2)
                .into_iter()
                .map(|rank| {
                    s.spawn(move || {
                        let rank: Arc<dyn Collective> = Arc::new(rank);
                        let mut p = learner(ENVS / 2);
                        p.distribute(rank.clone());
                        rollout_and_update(&mut p, rank.rank() * ENVS / 2)
                    })
                })
                .collect();
            handles.into_iter().map(|h| h.join().unwrap()).collect()
        });
        assert_eq!(ranks[0], ranks[1], "the replicas differ");
        assert_eq!(ranks[0].1, whole_rate);
        let moved = whole
            .iter()
            .zip(&initial)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0f32, f32::max);
        assert!(moved > 1e-3, "the update moved the parameters by {moved}");
        let diff = whole
            .iter()
            .zip(&ranks[0].0)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0f32, f32::max);
        assert!(diff < 1e-6, "two ranks differ from one learner by {diff}");
    }
}
