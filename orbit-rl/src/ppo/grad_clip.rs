//! Gradient-norm clipping on the device: all parameters together, or the actor's (with the
//! noise parameter) and the critic's each (RSL-RL 5).

use burn::module::{Module, ModuleVisitor, Param};
use burn::optim::GradientsParams;
use burn::tensor::Tensor;

use super::tensor::sum_all;
use crate::cfg::GradClip;
use crate::model::ActorCritic;

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
pub(super) fn clip_gradients(
    model: &ActorCritic,
    grads: &mut GradientsParams,
    mode: GradClip,
    max_norm: f32,
) {
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

#[cfg(test)]
mod tests {
    use burn::module::{Module, ModuleVisitor, Param};
    use burn::optim::GradientsParams;
    use burn::tensor::Tensor;

    use super::{actor_grad_norm_squared, clip_gradients, grad_norm_squared};
    use crate::cfg::GradClip;
    use crate::ppo::fixtures::{ppo, rollout, whole_rollout};

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
}
