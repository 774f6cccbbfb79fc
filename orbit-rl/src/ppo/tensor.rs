//! Tensor helpers shared by the learner: host values to and from the device, row indices, and
//! whole-tensor reductions whose bits do not depend on the kernels cubecl's autotune picks.

use burn::tensor::{Device, Int, Tensor, TensorData};

/// A `[rows, cols]` tensor from row-major values.
pub(crate) fn tensor2(values: Vec<f32>, rows: usize, cols: usize, device: &Device) -> Tensor<2> {
    Tensor::from_data(TensorData::new(values, [rows, cols]), device)
}

/// A `[n]` tensor.
pub(crate) fn tensor1(values: Vec<f32>, device: &Device) -> Tensor<1> {
    let n = values.len();
    Tensor::from_data(TensorData::new(values, [n]), device)
}

/// Row indices (below [`MAX_ROLLOUT_ROWS`](super::MAX_ROLLOUT_ROWS)) as an `i32` tensor, for
/// `select`.
pub(super) fn index_tensor(idx: &[u32], device: &Device) -> Tensor<1, Int> {
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
pub(super) fn sum_all<const D: usize>(x: Tensor<D>) -> Tensor<1> {
    let n = x.shape().num_elements();
    x.reshape([n]).sum_dim(0)
}

/// The mean of `x`'s values as a `[1]` tensor, reduced as in [`sum_all`].
pub(super) fn mean_all(x: Tensor<1>) -> Tensor<1> {
    x.mean_dim(0)
}

/// A tensor's values, row-major.
pub(crate) fn values<const D: usize>(t: Tensor<D>) -> Vec<f32> {
    t.into_data()
        .try_into_vec::<f32>()
        .expect("float tensors hold f32 values")
}
