//! The actor-critic network (RSL-RL's `ActorCritic`): two MLPs and a state-independent
//! Gaussian noise parameter.

use burn::module::{Module, ModuleMapper, ModuleVisitor, Param};
use burn::nn::Linear;
use burn::tensor::{Device, Tensor, TensorData, activation};
use orbit_core::rng::EnvRng;

use crate::cfg::{Activation, NoiseStdType, PolicyCfg};

mod stacked;
pub use stacked::StackedActorCritic;

/// A multi-layer perceptron: `Linear, act, Linear, act, …, Linear` (no output activation).
#[derive(Module, Debug)]
pub struct Mlp {
    layers: Vec<Linear>,
    #[module(skip)]
    activation: Activation,
}

/// A linear layer initialised as PyTorch does (`U(−k, k)` for weights and biases,
/// `k = 1/√fan_in`), drawn from a counter-based stream so it is the same on every device.
fn linear(d_in: usize, d_out: usize, rng: &mut EnvRng, device: &Device) -> Linear {
    let k = 1.0 / (d_in as f32).sqrt();
    let mut draw = |n: usize| -> Vec<f32> { (0..n).map(|_| rng.uniform_range(-k, k)).collect() };
    // burn stores weights as [d_in, d_out].
    let weight = TensorData::new(draw(d_in * d_out), [d_in, d_out]);
    let bias = TensorData::new(draw(d_out), [d_out]);
    Linear {
        weight: Param::from_tensor(Tensor::from_data(weight, device)),
        bias: Some(Param::from_tensor(Tensor::from_data(bias, device))),
    }
}

impl Mlp {
    /// An MLP with layer widths `dims` (`[input, hidden…, output]`).
    pub fn new(dims: &[usize], activation: Activation, rng: &mut EnvRng, device: &Device) -> Self {
        let layers = dims
            .windows(2)
            .map(|w| linear(w[0], w[1], rng, device))
            .collect();
        Self { layers, activation }
    }

    /// The widths: inputs, then each layer's outputs.
    pub fn widths(&self) -> Vec<usize> {
        let mut widths: Vec<usize> = self
            .layers
            .iter()
            .take(1)
            .map(|l| l.weight.dims()[0])
            .collect();
        widths.extend(self.layers.iter().map(|l| l.weight.dims()[1]));
        widths
    }

    /// The activation between layers.
    pub fn activation(&self) -> Activation {
        self.activation
    }

    /// Applies the network to a batch of rows. Large batches go through as `[chunks, rows,
    /// features]` batched products (see [`row_chunks`]): the result is the same up to float
    /// rounding, but the backward pass's sums over the rows (the weight and bias gradients)
    /// become many partial sums added afterwards.
    pub fn forward(&self, x: Tensor<2>) -> Tensor<2> {
        let [n, d] = x.dims();
        let chunks = row_chunks(n, min_chunk_rows(&x.device()));
        if chunks == 1 {
            return self.forward_rows(x);
        }
        let y = self.apply(x.reshape([chunks, n / chunks, d]), chunked_linear);
        let out = y.dims()[2];
        y.reshape([n, out])
    }

    /// The network on `[rows, features]` as one batch, through burn's `Linear`.
    fn forward_rows(&self, x: Tensor<2>) -> Tensor<2> {
        self.apply(x, |layer, x| layer.forward(x))
    }

    /// The layers in order, each through `linear`, with the activation between them.
    fn apply<const D: usize>(
        &self,
        mut x: Tensor<D>,
        linear: impl Fn(&Linear, Tensor<D>) -> Tensor<D>,
    ) -> Tensor<D> {
        let last = self.layers.len() - 1;
        for (i, layer) in self.layers.iter().enumerate() {
            x = linear(layer, x);
            if i < last {
                x = activate(self.activation, x);
            }
        }
        x
    }
}

/// The kernels' name for an activation.
pub(crate) fn kernel_activation(a: Activation) -> orbit_mlp_wgpu::Activation {
    use orbit_mlp_wgpu::Activation as Kernel;
    match a {
        Activation::Elu => Kernel::Elu,
        Activation::Selu => Kernel::Selu,
        Activation::Relu => Kernel::Relu,
        Activation::Lrelu => Kernel::LeakyRelu,
        Activation::Tanh => Kernel::Tanh,
        Activation::Sigmoid => Kernel::Sigmoid,
    }
}

/// The configured activation, element-wise.
fn activate<const D: usize>(kind: Activation, x: Tensor<D>) -> Tensor<D> {
    match kind {
        Activation::Elu => elu(x, 1.0, 1.0),
        Activation::Selu => elu(x, SELU_SCALE, SELU_SCALE * SELU_ALPHA),
        Activation::Relu => activation::relu(x),
        Activation::Lrelu => activation::leaky_relu(x, 0.01),
        Activation::Tanh => activation::tanh(x),
        Activation::Sigmoid => activation::sigmoid(x),
    }
}

/// `x·W + b` for `x` of shape `[chunks, rows, d_in]`, with the bias first spread over the
/// chunks (`[chunks, 1, d_out]`). The bias gradient is then a sum over each chunk's rows
/// (`chunks × d_out` sums, in parallel) followed by a small sum over the chunks. burn's
/// `Linear` sums all rows into the `d_out` outputs in one reduction, which a GPU runs with
/// `d_out` outputs' worth of parallelism, far too little for a rollout of hundreds of thousands
/// of rows (docs/benchmarks.md).
fn chunked_linear(layer: &Linear, x: Tensor<3>) -> Tensor<3> {
    let chunks = x.dims()[0];
    let y = burn::tensor::module::linear(x, layer.weight.val(), None);
    match &layer.bias {
        Some(bias) => {
            let d_out = bias.dims()[0];
            y + bias.val().reshape([1, 1, d_out]).expand([chunks, 1, d_out])
        }
        None => y,
    }
}

/// The number of equal chunks (a power of two, at most 256, each of at least `min_rows` rows)
/// a batch of `n` rows is split into. A layer's weight gradient is `xᵀ g`: a small
/// `d_in × d_out` product over all `n` rows, which a GPU matmul kernel tiles over its output
/// only, so a few workgroups do all the work. As a batched product each chunk gets its own
/// workgroups and the partial gradients are summed afterwards ("split-K"); at 65 536 envs this
/// halves the update on an H100. The bias gradients are split the same way
/// ([`chunked_linear`]; docs/benchmarks.md).
fn row_chunks(n: usize, min_rows: usize) -> usize {
    const MAX_CHUNKS: usize = 256;
    let mut c = 1;
    while c < MAX_CHUNKS && n.is_multiple_of(2 * c) && n / (2 * c) >= min_rows {
        c *= 2;
    }
    c
}

/// The fewest rows of a chunk on `device`: 256 on a GPU, where below 512 rows cubecl's fixed
/// product kernels unroll half as much work per thread, so the learner compiles them seconds
/// sooner and updates as fast (docs/experiments/learner-compile-chain.md); 1 024 on the CPU.
fn min_chunk_rows(device: &Device) -> usize {
    if crate::on_cpu(device) { 1024 } else { 256 }
}

/// SELU's constants (Klambauer et al. 2017, as in PyTorch).
const SELU_ALPHA: f64 = 1.673_263_242_354_377_3;
const SELU_SCALE: f64 = 1.050_700_987_355_480_5;

/// `scale·x` for `x > 0`, `alpha·(eˣ − 1)` otherwise (ELU with `scale = alpha = 1`, SELU with
/// its constants). burn's own ELU and SELU take `eˣ` of every element and mask it out where
/// `x > 0`; for `x > 88` that is ∞ in `f32`, and the backward pass multiplies the masked-out
/// zero gradient by it: NaN weights once a pre-activation passes 88. Both forms below keep the
/// exponent at or below 0 and give the same values.
fn elu<const D: usize>(x: Tensor<D>, scale: f64, alpha: f64) -> Tensor<D> {
    if crate::on_cpu(&x.device()) {
        elu_by_mask(x, scale, alpha)
    } else {
        elu_by_clamps(x, scale, alpha)
    }
}

/// ELU as `scale·max(x, 0) + alpha·(e^min(x, 0) − 1)`: the GPU learner's form.
/// Factors of 1 (ELU's) are left out: each operation costs a GPU learner host time.
fn elu_by_clamps<const D: usize>(x: Tensor<D>, scale: f64, alpha: f64) -> Tensor<D> {
    let scaled = |t: Tensor<D>, factor: f64| {
        if factor == 1.0 {
            t
        } else {
            t.mul_scalar(factor)
        }
    };
    let positive = scaled(x.clone().clamp_min(0.0), scale);
    let negative = scaled(x.clamp_max(0.0).exp().sub_scalar(1.0), alpha);
    positive + negative
}

/// ELU as `scale·x·m + alpha·(e^(x·(1 − m)) − 1)` with the constant mask `m = [x > 0]`: the CPU
/// learner's form. Its backward pass is products with the mask, which burn's CPU backend
/// vectorises, where a clamp's backward pass is an element-wise branch there (the update of
/// box pushing's CPU config takes about a quarter less time).
fn elu_by_mask<const D: usize>(x: Tensor<D>, scale: f64, alpha: f64) -> Tensor<D> {
    let positive_mask = x.clone().greater_elem(0.0).float();
    let negative_mask = positive_mask.clone().neg().add_scalar(1.0);
    let positive = (x.clone() * positive_mask).mul_scalar(scale);
    let negative = (x * negative_mask).exp().sub_scalar(1.0).mul_scalar(alpha);
    positive + negative
}

/// Actor (Gaussian mean), critic (value) and the per-action noise parameter.
#[derive(Module, Debug)]
pub struct ActorCritic {
    /// Observations → action means (no squashing).
    pub actor: Mlp,
    /// Critic observations → value.
    pub critic: Mlp,
    /// The noise parameter: the standard deviation, or its log (see [`NoiseStdType`]).
    pub std: Param<Tensor<1>>,
    #[module(skip)]
    noise_std_type: NoiseStdType,
}

impl ActorCritic {
    /// Every parameter's values, flattened, in visit order (the order replicas exchange
    /// them in).
    pub fn parameter_values(&self) -> Vec<f32> {
        struct Flatten(Vec<f32>);
        impl ModuleVisitor for Flatten {
            fn visit_float<const D: usize>(&mut self, param: &Param<Tensor<D>>) {
                self.0.extend(crate::ppo::values(param.val()));
            }
        }
        let mut flat = Flatten(Vec::new());
        self.visit(&mut flat);
        flat.0
    }

    /// The model with every parameter's values taken from `flat` (in visit order, as
    /// [`parameter_values`](Self::parameter_values) gives them); gradient settings are kept.
    pub fn with_parameter_values(self, flat: &[f32]) -> Self {
        struct Replace<'a>(std::slice::Iter<'a, f32>);
        impl ModuleMapper for Replace<'_> {
            fn map_float<const D: usize>(&mut self, param: Param<Tensor<D>>) -> Param<Tensor<D>> {
                let (id, tensor, mapper) = param.consume();
                let dims = tensor.dims();
                let n = tensor.shape().num_elements();
                let data: Vec<f32> = self.0.by_ref().take(n).copied().collect();
                assert_eq!(data.len(), n, "one value per parameter");
                let device = tensor.clone().inner().device();
                let value = crate::adam::leaf_like(
                    Tensor::from_data(TensorData::new(data, dims), &device),
                    &tensor,
                );
                Param::from_mapped_value(id, value, mapper)
            }
        }
        self.map(&mut Replace(flat.iter()))
    }

    /// How the noise parameter is stored.
    pub fn noise_std_type(&self) -> NoiseStdType {
        self.noise_std_type
    }

    /// Builds the network for `num_obs` actor inputs, `num_critic_obs` critic inputs and
    /// `num_actions` outputs; weights are drawn from `seed`'s stream.
    pub fn new(
        cfg: &PolicyCfg,
        num_obs: usize,
        num_critic_obs: usize,
        num_actions: usize,
        seed: u64,
        device: &Device,
    ) -> Self {
        let mut rng = EnvRng::new(seed, 0, crate::streams::INIT);
        let dims = |input: usize, hidden: &[usize], output: usize| {
            std::iter::once(input)
                .chain(hidden.iter().copied())
                .chain(std::iter::once(output))
                .collect::<Vec<_>>()
        };
        let actor = Mlp::new(
            &dims(num_obs, &cfg.actor_hidden_dims, num_actions),
            cfg.activation,
            &mut rng,
            device,
        );
        let critic = Mlp::new(
            &dims(num_critic_obs, &cfg.critic_hidden_dims, 1),
            cfg.activation,
            &mut rng,
            device,
        );
        let init = match cfg.noise_std_type {
            NoiseStdType::Scalar => cfg.init_noise_std,
            NoiseStdType::Log => cfg.init_noise_std.ln(),
        };
        let std = Tensor::from_data(
            TensorData::new(vec![init; num_actions], [num_actions]),
            device,
        );
        Self {
            actor,
            critic,
            std: Param::from_tensor(std),
            noise_std_type: cfg.noise_std_type,
        }
    }

    /// Action means for a batch of observations, `[rows, num_actions]`.
    pub fn action_mean(&self, obs: Tensor<2>) -> Tensor<2> {
        self.actor.forward(obs)
    }

    /// Values for a batch of critic observations, `[rows, 1]`.
    pub fn value(&self, critic_obs: Tensor<2>) -> Tensor<2> {
        self.critic.forward(critic_obs)
    }

    /// The standard deviation of the action noise, `[num_actions]`. A scalar parameter is
    /// clamped at 1e-6 so a step that drives it negative cannot produce an invalid Gaussian
    /// (RSL-RL 5 clamps the same way).
    pub fn action_std(&self) -> Tensor<1> {
        match self.noise_std_type {
            NoiseStdType::Scalar => self.std.val().clamp_min(1e-6),
            NoiseStdType::Log => self.std.val().exp(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// ELU's gradient is 1 for a large positive input and e^x for a negative one; neither is
    /// NaN, even where eˣ overflows `f32`.
    #[test]
    fn elu_gradient_is_finite_for_large_inputs() {
        let device = Device::flex().autodiff();
        let x = Tensor::<2>::from_data(TensorData::new(vec![100.0f32, -2.0], [1, 2]), &device)
            .require_grad();
        let y = elu(x.clone(), 1.0, 1.0);
        let out: Vec<f32> = y.clone().into_data().try_into_vec().unwrap();
        assert_eq!(out[0], 100.0);
        assert!((out[1] - ((-2.0f32).exp() - 1.0)).abs() < 1e-6);
        let grads = y.sum().backward();
        let g: Vec<f32> = x.grad(&grads).unwrap().into_data().try_into_vec().unwrap();
        assert_eq!(g[0], 1.0);
        assert!((g[1] - (-2.0f32).exp()).abs() < 1e-6, "{g:?}");
    }

    /// The CPU learner's ELU and the GPU learner's give the same values and, away from 0,
    /// the same gradients (SELU's constants included).
    #[test]
    fn elu_forms_agree() {
        let device = Device::flex().autodiff();
        let inputs: Vec<f32> = (-40..=40).map(|i| i as f32 * 0.37 + 0.011).collect();
        for (scale, alpha) in [(1.0, 1.0), (SELU_SCALE, SELU_SCALE * SELU_ALPHA)] {
            let run = |form: fn(Tensor<2>, f64, f64) -> Tensor<2>| {
                let x = Tensor::<2>::from_data(
                    TensorData::new(inputs.clone(), [1, inputs.len()]),
                    &device,
                )
                .require_grad();
                let y = form(x.clone(), scale, alpha);
                let values: Vec<f32> = y.clone().into_data().try_into_vec().unwrap();
                let grads = y.sum().backward();
                let g: Vec<f32> = x.grad(&grads).unwrap().into_data().try_into_vec().unwrap();
                (values, g)
            };
            let (mask, clamps) = (run(elu_by_mask), run(elu_by_clamps));
            assert_eq!(mask.0, clamps.0, "values");
            assert!(max_abs_diff(&mask.1, &clamps.1) <= 1e-7, "gradients");
        }
    }

    /// Chunk counts: powers of two, at most 256, chunks of at least `min_rows` rows.
    #[test]
    fn row_chunks_split_large_batches_only() {
        // (rows, fewest rows per chunk, chunks)
        let cases = [
            (393_216, 1024, 256),
            (24_576, 1024, 16),
            (4_096, 1024, 4),
            (1_536, 1024, 1),
            (3_000, 1024, 2),
            (1_001, 1024, 1),
            (393_216, 256, 256),
            (32_768, 256, 128),
            (4_096, 256, 16),
            (1_536, 256, 4),
            (511, 256, 1),
            (512, 256, 2),
        ];
        for (n, min_rows, chunks) in cases {
            assert_eq!(
                row_chunks(n, min_rows),
                chunks,
                "{n} rows, {min_rows} per chunk"
            );
        }
    }

    /// The largest `|a[i] − b[i]|`.
    fn max_abs_diff(a: &[f32], b: &[f32]) -> f32 {
        assert_eq!(a.len(), b.len());
        a.iter()
            .zip(b)
            .map(|(p, q)| (p - q).abs())
            .fold(0.0, f32::max)
    }

    /// The chunked forward pass gives the rows, weight and bias gradients of the plain one (to
    /// float rounding: the gradients sum their rows in another order).
    #[test]
    fn chunked_forward_matches_plain() {
        let device = Device::flex().autodiff();
        let mut rng = EnvRng::new(7, 0, 0);
        let mlp = Mlp::new(&[5, 16, 3], Activation::Elu, &mut rng, &device);
        let n = 4096;
        let data: Vec<f32> = (0..n * 5).map(|_| rng.uniform_range(-2.0, 2.0)).collect();
        let x = Tensor::<2>::from_data(TensorData::new(data, [n, 5]), &device);
        assert_eq!(row_chunks(n, min_chunk_rows(&device)), 4);
        let chunked = mlp.forward(x.clone());
        let plain = mlp.forward_rows(x);
        let a: Vec<f32> = chunked.clone().into_data().try_into_vec().unwrap();
        let b: Vec<f32> = plain.clone().into_data().try_into_vec().unwrap();
        let worst = max_abs_diff(&a, &b);
        assert!(worst < 1e-5, "outputs differ by {worst}");
        // Every layer's weight and bias gradients, in order.
        let gradients = |y: Tensor<2>| -> Vec<Vec<f32>> {
            let grads = y.powf_scalar(2.0).sum().backward();
            let values = |g: Option<Tensor<2>>| -> Vec<f32> {
                g.unwrap().into_data().try_into_vec().unwrap()
            };
            mlp.layers
                .iter()
                .flat_map(|l| {
                    let bias = l.bias.as_ref().unwrap().val().grad(&grads);
                    [
                        values(l.weight.val().grad(&grads)),
                        values(bias.map(|b| b.unsqueeze())),
                    ]
                })
                .collect()
        };
        for (ga, gb) in gradients(chunked).iter().zip(&gradients(plain)) {
            let scale = gb.iter().fold(0.0f32, |m, g| m.max(g.abs()));
            let worst = max_abs_diff(ga, gb);
            assert!(
                scale > 0.0 && worst < 1e-5 * scale,
                "gradients differ by {worst} (scale {scale})"
            );
        }
    }
}
