//! Adam whose learning rate is a tensor on the learner's device.
//!
//! burn's optimisers take the learning rate as a host number, so RSL-RL's KL-adaptive rule
//! (which changes the rate before every gradient step from that minibatch's KL divergence)
//! would have to read the KL back from the device once per step; on a GPU that wait cost
//! 6–10 ms of each 35 ms step at 65 536 envs (docs/benchmarks.md). Here the rate stays on the
//! device, the rule ([`adapt_learning_rate`]) runs there too, and a whole update queues its
//! steps without waiting. The arithmetic is PyTorch's and burn's Adam (ε inside the
//! bias-corrected denominator); one step counter serves every parameter, as PPO steps them
//! all together. The moments keep their parameters' shapes (stored rank-erased, as burn's own
//! optimisers keep theirs): reshaping them in every step added two operations per parameter
//! to the host's stream and made small steps a third slower.

use std::path::Path;

use burn::module::{Module, ModuleMapper, ModuleVisitor, Param};
use burn::optim::GradientsParams;
use burn::tensor::kind::BridgeTensor;
use burn::tensor::{Device, Tensor};

use crate::RlError;
use crate::ppo::tensor1;

/// The adaptive rule's bounds on the learning rate (RSL-RL's clamp).
const MIN_LEARNING_RATE: f32 = 1e-5;
const MAX_LEARNING_RATE: f32 = 1e-2;
/// The adaptive rule's factor.
const LEARNING_RATE_FACTOR: f32 = 1.5;

/// RSL-RL's KL-adaptive learning rate, on the device: divided by 1.5 (at least 1e-5) when
/// `kl > 2·desired`, multiplied by 1.5 (at most 1e-2) when `0 < kl < desired/2`, else (a NaN
/// KL included) unchanged. `learning_rate` and `kl` are `[1]` tensors.
pub fn adapt_learning_rate(learning_rate: Tensor<1>, kl: Tensor<1>, desired: f32) -> Tensor<1> {
    let too_far = kl.clone().greater_elem(2.0 * desired);
    let too_close = kl
        .clone()
        .greater_elem(0.0)
        .bool_and(kl.lower_elem(desired / 2.0));
    let lowered = learning_rate
        .clone()
        .div_scalar(LEARNING_RATE_FACTOR)
        .clamp_min(MIN_LEARNING_RATE);
    let raised = learning_rate
        .clone()
        .mul_scalar(LEARNING_RATE_FACTOR)
        .clamp_max(MAX_LEARNING_RATE);
    learning_rate
        .mask_where(too_far, lowered)
        .mask_where(too_close, raised)
}

/// Adam's state: the learning rate (`[1]`, on the device), the step count and the first and
/// second moments of every parameter, in the order the module visits them.
#[derive(Clone, Debug)]
pub struct Adam {
    beta_1: f32,
    beta_2: f32,
    epsilon: f32,
    learning_rate: Tensor<1>,
    steps: u32,
    moments: Vec<Moments>,
}

/// A parameter's first and second moments, in its shape (rank-erased).
#[derive(Clone, Debug)]
struct Moments {
    first: BridgeTensor,
    second: BridgeTensor,
}

/// Adam's moments and step count as a module, so a checkpoint stores them as burnpack.
#[derive(Module, Debug)]
struct AdamRecord {
    first: Vec<Param<Tensor<1>>>,
    second: Vec<Param<Tensor<1>>>,
    steps: Param<Tensor<1>>,
}

impl Adam {
    /// Adam with PyTorch's defaults (β₁ 0.9, β₂ 0.999, ε 1e-8) at `learning_rate`.
    pub fn new(learning_rate: f64, device: &Device) -> Self {
        Self {
            beta_1: 0.9,
            beta_2: 0.999,
            epsilon: 1e-8,
            learning_rate: scalar_tensor(learning_rate, device),
            steps: 0,
            moments: Vec::new(),
        }
    }

    /// The learning rate, as a `[1]` tensor on the device (reading it waits for the device).
    pub fn learning_rate(&self) -> Tensor<1> {
        self.learning_rate.clone()
    }

    /// Sets the learning rate.
    pub fn set_learning_rate(&mut self, learning_rate: f64) {
        self.learning_rate = scalar_tensor(learning_rate, &self.learning_rate.device());
    }

    /// Applies RSL-RL's adaptive rule to the learning rate (see [`adapt_learning_rate`]).
    pub fn adapt(&mut self, kl: Tensor<1>, desired_kl: f32) {
        self.learning_rate =
            adapt_learning_rate(self.learning_rate.clone(), kl.inner(), desired_kl);
    }

    /// Number of steps taken.
    pub fn steps(&self) -> u32 {
        self.steps
    }

    /// One Adam step of `module` along `grads`, at the current learning rate. A parameter
    /// without a gradient keeps its value and its moments.
    pub fn step<M: Module>(&mut self, module: M, mut grads: GradientsParams) -> M {
        self.steps += 1;
        let t = self.steps as i32;
        let bias_correction_2 = (1.0 - self.beta_2.powi(t)).sqrt();
        let step_factor = bias_correction_2 / (1.0 - self.beta_1.powi(t));
        let epsilon = self.epsilon * bias_correction_2;
        let mut step = AdamStep {
            adam: self,
            grads: &mut grads,
            step_factor,
            epsilon,
            index: 0,
            rates: Vec::new(),
        };
        module.map(&mut step)
    }

    /// The first and second moments of `module`'s parameters, flattened in visit order
    /// (zeros before the first step).
    pub fn flat_moments<M: Module>(&self, module: &M) -> (Vec<f32>, Vec<f32>) {
        struct Flatten<'a> {
            moments: &'a [Moments],
            index: usize,
            first: Vec<f32>,
            second: Vec<f32>,
        }
        impl ModuleVisitor for Flatten<'_> {
            fn visit_float<const D: usize>(&mut self, param: &Param<Tensor<D>>) {
                let n = param.shape().num_elements();
                match self.moments.get(self.index) {
                    Some(m) => {
                        let values = |t: &BridgeTensor| -> Vec<f32> {
                            crate::ppo::values(Tensor::<D>::from_bridge(t.clone()))
                        };
                        self.first.extend(values(&m.first));
                        self.second.extend(values(&m.second));
                    }
                    None => {
                        self.first.extend(std::iter::repeat_n(0.0, n));
                        self.second.extend(std::iter::repeat_n(0.0, n));
                    }
                }
                self.index += 1;
            }
        }
        let mut flat = Flatten {
            moments: &self.moments,
            index: 0,
            first: Vec::new(),
            second: Vec::new(),
        };
        module.visit(&mut flat);
        (flat.first, flat.second)
    }

    /// Replaces the moments by `first` and `second` (flattened in `module`'s visit order, as
    /// [`flat_moments`](Self::flat_moments) gives them), the step count by `steps` and the
    /// learning rate by `learning_rate`.
    pub fn set_flat_state<M: Module>(
        &mut self,
        module: &M,
        (first, second): (&[f32], &[f32]),
        steps: u32,
        learning_rate: f64,
    ) {
        struct Shape<'a> {
            first: std::slice::Iter<'a, f32>,
            second: std::slice::Iter<'a, f32>,
            device: burn::tensor::Device,
            moments: Vec<Moments>,
        }
        impl ModuleVisitor for Shape<'_> {
            fn visit_float<const D: usize>(&mut self, param: &Param<Tensor<D>>) {
                let n = param.shape().num_elements();
                let device = &self.device;
                let shaped = |values: &mut std::slice::Iter<'_, f32>| {
                    let v: Vec<f32> = values.by_ref().take(n).copied().collect();
                    assert_eq!(v.len(), n, "one moment per parameter");
                    tensor1(v, device)
                        .inner()
                        .reshape::<D, _>(param.dims())
                        .into_bridge()
                };
                let first = shaped(&mut self.first);
                let second = shaped(&mut self.second);
                self.moments.push(Moments { first, second });
            }
        }
        let mut shape = Shape {
            first: first.iter(),
            second: second.iter(),
            device: self.learning_rate.device(),
            moments: Vec::new(),
        };
        module.visit(&mut shape);
        self.moments = shape.moments;
        self.steps = steps;
        self.set_learning_rate(learning_rate);
    }

    /// Saves the moments and the step count of `module`'s parameters (the module stepped) to
    /// `path` (burnpack).
    pub fn save<M: Module>(&self, module: &M, path: &Path) -> Result<(), RlError> {
        struct Flatten<'a> {
            moments: &'a [Moments],
            first: Vec<Param<Tensor<1>>>,
            second: Vec<Param<Tensor<1>>>,
        }
        impl ModuleVisitor for Flatten<'_> {
            fn visit_float<const D: usize>(&mut self, param: &Param<Tensor<D>>) {
                let flat = |t: Tensor<D>| {
                    let n = t.shape().num_elements();
                    Param::from_tensor(t.reshape([n]))
                };
                let (m, v) = match self.moments.get(self.first.len()) {
                    Some(m) => (
                        Tensor::<D>::from_bridge(m.first.clone()),
                        Tensor::<D>::from_bridge(m.second.clone()),
                    ),
                    // Not stepped yet: zero moments, as a first step would start from.
                    None => {
                        let zeros = param.val().inner().zeros_like();
                        (zeros.clone(), zeros)
                    }
                };
                self.first.push(flat(m));
                self.second.push(flat(v));
            }
        }
        let mut flat = Flatten {
            moments: &self.moments,
            first: Vec::new(),
            second: Vec::new(),
        };
        module.visit(&mut flat);
        let device = self.learning_rate.device();
        let record = AdamRecord {
            first: flat.first,
            second: flat.second,
            steps: Param::from_tensor(scalar_tensor(f64::from(self.steps), &device)),
        };
        record
            .save_file(path)
            .map_err(|e| RlError::checkpoint(path, e))
    }

    /// Loads the moments and the step count saved by [`Adam::save`] for the parameters of
    /// `module` (which fixes their number and shapes); the learning rate is kept.
    pub fn load<M: Module>(&mut self, module: &M, path: &Path) -> Result<(), RlError> {
        struct Sizes(Vec<usize>);
        impl ModuleVisitor for Sizes {
            fn visit_float<const D: usize>(&mut self, param: &Param<Tensor<D>>) {
                self.0.push(param.shape().num_elements());
            }
        }
        let mut sizes = Sizes(Vec::new());
        module.visit(&mut sizes);
        let device = self.learning_rate.device();
        let zeros: Vec<Param<Tensor<1>>> = (sizes.0.iter())
            .map(|&n| Param::from_tensor(Tensor::zeros([n], &device)))
            .collect();
        let template = AdamRecord {
            first: zeros.clone(),
            second: zeros,
            steps: Param::from_tensor(Tensor::zeros([1], &device)),
        };
        let record = template
            .try_load_file(path)
            .map_err(|e| RlError::checkpoint(path, e))?;
        let steps = record.steps.val().into_scalar::<f32>();
        if !(steps >= 0.0 && steps.fract() == 0.0 && steps <= u32::MAX as f32) {
            return Err(RlError::checkpoint(
                path,
                format!("the step count {steps} is not a whole number"),
            ));
        }
        // Each flat moment back in its parameter's shape.
        struct Shape {
            flat: std::vec::IntoIter<(Param<Tensor<1>>, Param<Tensor<1>>)>,
            moments: Vec<Moments>,
        }
        impl ModuleVisitor for Shape {
            fn visit_float<const D: usize>(&mut self, param: &Param<Tensor<D>>) {
                let (m, v) = self.flat.next().expect("one record entry per parameter");
                let shaped = |t: Param<Tensor<1>>| {
                    t.val().inner().reshape::<D, _>(param.dims()).into_bridge()
                };
                self.moments.push(Moments {
                    first: shaped(m),
                    second: shaped(v),
                });
            }
        }
        let flat: Vec<_> = record.first.into_iter().zip(record.second).collect();
        let mut shape = Shape {
            flat: flat.into_iter(),
            moments: Vec::new(),
        };
        module.visit(&mut shape);
        self.moments = shape.moments;
        self.steps = steps as u32;
        Ok(())
    }
}

/// A `[1]` tensor holding `value`, off the autodiff graph.
fn scalar_tensor(value: f64, device: &Device) -> Tensor<1> {
    tensor1(vec![value as f32], device).inner()
}

/// One Adam step as a module mapper: the parameters come in visit order, `index` counts them.
struct AdamStep<'a> {
    adam: &'a mut Adam,
    grads: &'a mut GradientsParams,
    /// `√(1 − β₂ᵗ) / (1 − β₁ᵗ)`.
    step_factor: f32,
    /// `ε·√(1 − β₂ᵗ)`.
    epsilon: f32,
    index: usize,
    /// The learning rate shaped `[1; D]` for each rank `D` met so far (one reshape per rank
    /// and step, not per parameter).
    rates: Vec<Option<BridgeTensor>>,
}

impl AdamStep<'_> {
    /// The learning rate as a `[1; D]` tensor.
    fn rate<const D: usize>(&mut self) -> Tensor<D> {
        if self.rates.len() <= D {
            self.rates.resize(D + 1, None);
        }
        let rate = self.rates[D].get_or_insert_with(|| {
            self.adam
                .learning_rate
                .clone()
                .reshape([1; D])
                .into_bridge()
        });
        Tensor::from_bridge(rate.clone())
    }
}

impl ModuleMapper for AdamStep<'_> {
    fn map_float<const D: usize>(&mut self, param: Param<Tensor<D>>) -> Param<Tensor<D>> {
        let index = self.index;
        self.index += 1;
        let (id, tensor, mapper) = param.consume();
        if self.adam.moments.len() == index {
            let zeros = tensor.clone().inner().zeros_like().into_bridge();
            self.adam.moments.push(Moments {
                first: zeros.clone(),
                second: zeros,
            });
        }
        let Some(grad) = self.grads.remove::<D>(id) else {
            return Param::from_mapped_value(id, tensor, mapper);
        };
        let rate = self.rate::<D>();
        let adam = &mut *self.adam;
        let moments = &mut adam.moments[index];
        let m = Tensor::<D>::from_bridge(moments.first.clone())
            .mul_scalar(adam.beta_1)
            .add(grad.clone().mul_scalar(1.0 - adam.beta_1));
        let v = Tensor::<D>::from_bridge(moments.second.clone())
            .mul_scalar(adam.beta_2)
            .add(grad.square().mul_scalar(1.0 - adam.beta_2));
        let delta = m
            .clone()
            .mul_scalar(self.step_factor)
            .div(v.clone().sqrt().add_scalar(self.epsilon))
            .mul(rate);
        moments.first = m.into_bridge();
        moments.second = v.into_bridge();
        let updated = leaf_like(tensor.clone().inner() - delta, &tensor);
        Param::from_mapped_value(id, updated, mapper)
    }
}

/// `value` (off the autodiff graph) as a fresh leaf with the gradient settings of the
/// parameter tensor `like`: a parameter given new values (an Adam step, another rank's
/// values) keeps requiring gradients. burn's optimiser also restores a distributed-training
/// marker; the learner's replicas exchange through host memory instead.
pub(crate) fn leaf_like<const D: usize>(value: Tensor<D>, like: &Tensor<D>) -> Tensor<D> {
    let mut leaf = Tensor::from_inner(value);
    if let Some(strategy) = like.gradient_checkpointing_strategy() {
        leaf = leaf.with_gradient_checkpointing_strategy(strategy);
    }
    if like.is_require_grad() {
        leaf = leaf.require_grad();
    }
    leaf
}

#[cfg(test)]
mod tests {
    use super::*;
    use burn::nn::{Linear, LinearConfig};
    use burn::optim::AdamConfig;
    use burn::tensor::TensorData;

    fn device() -> Device {
        Device::flex().autodiff()
    }

    fn layer(device: &Device) -> Linear {
        let mut l = LinearConfig::new(3, 2).init(device);
        let w = TensorData::new(vec![0.5f32, -0.3, 0.2, 0.8, -0.6, 0.1], [3, 2]);
        l.weight = Param::from_tensor(Tensor::from_data(w, device));
        l.bias = Some(Param::from_tensor(Tensor::from_data(
            TensorData::new(vec![0.05f32, -0.02], [2]),
            device,
        )));
        l
    }

    /// The gradients of `Σ (layer(x) − 1)²` for a fixed `x` scaled by `scale`.
    fn grads(l: &Linear, scale: f32, device: &Device) -> GradientsParams {
        let x = Tensor::<2>::from_data(
            TensorData::new(vec![1.0f32, 2.0, -1.0, 0.5, -0.3, 0.7], [2, 3]),
            device,
        );
        let loss = l
            .forward(x.mul_scalar(scale))
            .sub_scalar(1.0)
            .powi_scalar(2)
            .sum();
        GradientsParams::from_grads(loss.backward(), l)
    }

    fn params(l: &Linear) -> Vec<f32> {
        let mut v = crate::ppo::values(l.weight.val());
        v.extend(crate::ppo::values(l.bias.as_ref().unwrap().val()));
        v
    }

    /// Adam's first step moves every parameter by the learning rate against its gradient's
    /// sign: the bias-corrected moments are `g` and `g²`, so the step is `lr·g/(|g| + ε)`.
    #[test]
    fn the_first_step_moves_each_parameter_by_the_learning_rate() {
        let device = device();
        let l = layer(&device);
        let before = params(&l);
        let mut adam = Adam::new(1e-3, &device);
        let g = grads(&l, 1.0, &device);
        let after = params(&adam.step(l, g));
        assert_eq!(adam.steps(), 1);
        for (b, a) in before.iter().zip(&after) {
            assert!(((b - a).abs() - 1e-3).abs() < 1e-7, "{b} → {a}");
        }
    }

    /// Ten steps agree with burn's Adam (ε 1e-8) at the same fixed rate to f32 rounding.
    #[test]
    fn steps_agree_with_burns_adam() {
        let device = device();
        let (mut ours, mut theirs) = (layer(&device), layer(&device));
        let mut adam = Adam::new(1e-2, &device);
        let mut reference = AdamConfig::new().with_epsilon(1e-8).init();
        for k in 0..10 {
            let scale = 1.0 + 0.1 * k as f32;
            let g = grads(&ours, scale, &device);
            ours = adam.step(ours, g);
            let g = grads(&theirs, scale, &device);
            theirs = reference.step(1e-2, theirs, g);
        }
        for (a, b) in params(&ours).iter().zip(params(&theirs)) {
            assert!((a - b).abs() < 1e-6, "{a} vs {b}");
        }
    }

    /// The KL rule: ÷1.5 above twice the target, ×1.5 strictly between 0 and half of it,
    /// unchanged otherwise (a NaN KL included), clamped to [1e-5, 1e-2].
    #[test]
    fn the_learning_rate_follows_rsl_rls_kl_rule() {
        let device = device();
        let rate = |lr: f32, kl: f32| {
            let t = |v: f32| Tensor::<1>::from_data(TensorData::new(vec![v], [1]), &device);
            adapt_learning_rate(t(lr), t(kl), 0.01).into_scalar::<f32>()
        };
        assert_eq!(rate(3e-3, 0.03), 3e-3 / 1.5);
        assert_eq!(rate(3e-3, 0.001), 3e-3 * 1.5);
        for kl in [0.0, 0.005, 0.01, 0.02, f32::NAN] {
            assert_eq!(rate(3e-3, kl), 3e-3, "kl {kl}");
        }
        assert_eq!(rate(1.2e-5, 0.5), 1e-5);
        assert_eq!(rate(8e-3, 1e-4), 1e-2);
    }

    /// A saved and reloaded optimiser takes the same next step, bit for bit; a checkpoint for
    /// other parameter sizes is refused.
    #[test]
    fn a_reloaded_optimiser_continues_exactly() {
        let device = device();
        let mut l = layer(&device);
        let mut adam = Adam::new(1e-2, &device);
        for _ in 0..3 {
            let g = grads(&l, 1.0, &device);
            l = adam.step(l, g);
        }
        let path = std::env::temp_dir().join(format!("orbit-adam-{}.bpk", std::process::id()));
        adam.save(&l, &path).unwrap();
        let mut reloaded = Adam::new(1e-2, &device);
        reloaded.load(&l, &path).unwrap();
        assert_eq!(reloaded.steps(), 3);
        let next = params(&adam.step(l.clone(), grads(&l, 1.0, &device)));
        let resumed = params(&reloaded.step(l.clone(), grads(&l, 1.0, &device)));
        assert_eq!(next, resumed);

        let other = LinearConfig::new(4, 2).init(&device);
        let err = Adam::new(1e-2, &device).load(&other, &path).unwrap_err();
        assert!(matches!(err, RlError::Checkpoint { .. }), "{err}");
        std::fs::remove_file(&path).unwrap();
    }
}
