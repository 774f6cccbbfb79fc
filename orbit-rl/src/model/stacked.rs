//! The actor and the critic evaluated together while a rollout is collected. Where both
//! networks read the same observations through the same hidden widths (Isaac Lab's and
//! RSL-RL's configs), each layer of the two is one batched product `[2, rows, d_in] ·
//! [2, d_in, d_out]`: half the tensor operations per step of a plain forward pass of each, and
//! one read of means and values together. A GPU learner spends most of a collection step on
//! the host's per-operation work, not on the device.

use burn::tensor::Tensor;

use super::{ActorCritic, Mlp, activate};
use crate::cfg::Activation;

/// An [`ActorCritic`]'s two networks stacked layer by layer (gradient-free).
#[derive(Debug)]
pub struct StackedActorCritic {
    /// Per layer, the weights `[2, d_in, d_out]` and biases `[2, 1, d_out]` (actor first). The
    /// critic's last layer is padded with zero columns to the actor's outputs.
    layers: Vec<(Tensor<3>, Tensor<3>)>,
    activation: Activation,
    num_actions: usize,
}

impl StackedActorCritic {
    /// The stacked networks, or `None` where the actor and critic differ in their hidden
    /// widths or input widths.
    pub fn new(model: &ActorCritic) -> Option<Self> {
        let (actor, critic) = (&model.actor, &model.critic);
        let widths = |m: &Mlp| m.layers.iter().map(|l| l.weight.dims()).collect::<Vec<_>>();
        let (a, c) = (widths(actor), widths(critic));
        let hidden_match = a.len() == c.len()
            && a[..a.len() - 1] == c[..c.len() - 1]
            && a.last().map(|d| d[0]) == c.last().map(|d| d[0]);
        if !hidden_match || c.last()?[1] != 1 || actor.activation != critic.activation {
            return None;
        }
        let num_actions = a.last()?[1];
        let last = a.len() - 1;
        let layers = actor
            .layers
            .iter()
            .zip(&critic.layers)
            .enumerate()
            .map(|(i, (la, lc))| {
                let (mut wc, mut bc) = (lc.weight.val(), lc.bias.as_ref()?.val());
                if i == last && num_actions > 1 {
                    let d_in = wc.dims()[0];
                    let device = wc.device();
                    wc = Tensor::cat(vec![wc, Tensor::zeros([d_in, num_actions - 1], &device)], 1);
                    bc = Tensor::cat(vec![bc, Tensor::zeros([num_actions - 1], &device)], 0);
                }
                let w = Tensor::stack(vec![la.weight.val(), wc], 0);
                let d_out = w.dims()[2];
                let b =
                    Tensor::stack::<2>(vec![la.bias.as_ref()?.val(), bc], 0).reshape([2, 1, d_out]);
                Some((w, b))
            })
            .collect::<Option<Vec<_>>>()?;
        Some(Self {
            layers,
            activation: actor.activation,
            num_actions,
        })
    }

    /// `[2, rows, num_actions]` for `[rows, inputs]` observations (the critic's own, or
    /// `None` where it reads the actor's): the action means, then the values in column 0 (the
    /// other columns are 0).
    pub fn forward(&self, obs: Tensor<2>, critic_obs: Option<Tensor<2>>) -> Tensor<3> {
        let [rows, d] = obs.dims();
        let last = self.layers.len() - 1;
        let mut x = match critic_obs {
            Some(critic_obs) => Tensor::stack(vec![obs, critic_obs], 0),
            None => obs.reshape([1, rows, d]).expand([2, rows, d]),
        };
        for (i, (w, b)) in self.layers.iter().enumerate() {
            x = x.matmul(w.clone()) + b.clone();
            if i < last {
                x = activate(self.activation, x);
            }
        }
        x
    }

    /// Actions per row of [`Self::forward`]'s output.
    pub fn num_actions(&self) -> usize {
        self.num_actions
    }

    /// The hidden layers' activation.
    pub fn activation(&self) -> Activation {
        self.activation
    }

    /// The widths: inputs, hidden layers, outputs (the actions).
    pub fn widths(&self) -> Vec<usize> {
        let mut widths = vec![self.layers[0].0.dims()[1]];
        widths.extend(self.layers.iter().map(|(w, _)| w.dims()[2]));
        widths
    }

    /// Every layer's weights `[2, d_in, d_out]` and biases `[2, d_out]`, row-major, read back
    /// from the device (for a forward pass outside burn).
    pub fn host_layers(&self) -> Vec<(Vec<f32>, Vec<f32>)> {
        self.layers
            .iter()
            .map(|(w, b)| (crate::ppo::values(w.clone()), crate::ppo::values(b.clone())))
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use burn::tensor::Device;

    use super::*;
    use crate::cfg::{NoiseStdType, PolicyCfg};
    use crate::ppo::{tensor2, values};

    fn cfg(actor: &[usize], critic: &[usize]) -> PolicyCfg {
        PolicyCfg {
            init_noise_std: 1.0,
            actor_hidden_dims: actor.to_vec(),
            critic_hidden_dims: critic.to_vec(),
            activation: Activation::Elu,
            noise_std_type: NoiseStdType::Scalar,
        }
    }

    /// The stacked pass gives the separate networks' means and values (to float rounding:
    /// the same products, summed by other kernels), and the same bits whether the critic's
    /// observations are the actor's or a copy of them.
    #[test]
    fn stacked_pass_matches_the_two_networks() {
        let device = Device::flex();
        let model = ActorCritic::new(&cfg(&[16, 8], &[16, 8]), 5, 5, 3, 11, &device);
        let stacked = StackedActorCritic::new(&model).expect("equal widths stack");
        let rows = 37;
        let obs: Vec<f32> = (0..rows * 5)
            .map(|i| ((i * 7) % 13) as f32 * 0.3 - 1.8)
            .collect();
        let obs = tensor2(obs, rows, 5, &device);
        let out = values(stacked.forward(obs.clone(), None));
        assert_eq!(out, values(stacked.forward(obs.clone(), Some(obs.clone()))));
        let mean = values(model.action_mean(obs.clone()));
        let value = values(model.value(obs));
        let scale = mean
            .iter()
            .chain(&value)
            .fold(1.0f32, |m, v| m.max(v.abs()));
        for (e, v) in value.iter().enumerate() {
            let row = &out[(rows + e) * 3..(rows + e + 1) * 3];
            assert!((row[0] - v).abs() <= 1e-5 * scale, "value of row {e}");
            assert_eq!(&row[1..], &[0.0, 0.0], "padding of row {e}");
        }
        let worst = out[..rows * 3]
            .iter()
            .zip(&mean)
            .fold(0.0f32, |m, (a, b)| m.max((a - b).abs()));
        assert!(worst <= 1e-5 * scale, "means differ by {worst}");
    }

    /// Networks of different hidden widths are not stacked.
    #[test]
    fn different_widths_do_not_stack() {
        let model = ActorCritic::new(&cfg(&[16, 8], &[16, 4]), 5, 5, 3, 11, &Device::flex());
        assert!(StackedActorCritic::new(&model).is_none());
        let model = ActorCritic::new(&cfg(&[16, 8], &[16, 8]), 5, 7, 3, 11, &Device::flex());
        assert!(
            StackedActorCritic::new(&model).is_none(),
            "other critic inputs"
        );
    }
}
