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

/// The sum of all of `x`'s values as a `[1]` tensor, reduced along one dimension at a time.
/// burn's whole-tensor `sum` (and `mean`) lets cubecl's autotune choose a kernel whose
/// workgroups add their partial sums atomically (`sum_one_shot`), in an order that changes from
/// run to run; it does choose it for the gradient norms' sums on an H100. A reduction along a
/// dimension gives each output to one workgroup, so the same inputs give the same bits. The
/// fixed kernels give each output to one thread, so the values are summed in stages of at
/// most [`MAX_STAGE`] (`[b, n / b]` along its `b` rows): one stage over a minibatch's losses
/// would be one thread's loop over tens of thousands of values.
pub(super) fn sum_all<const D: usize>(x: Tensor<D>) -> Tensor<1> {
    let mut n = x.shape().num_elements();
    let mut x = x.reshape([n]);
    loop {
        let b = stage_length(n);
        if b == n {
            return x.sum_dim(0);
        }
        n /= b;
        x = x.reshape([b, n]).sum_dim(0).reshape([n]);
    }
}

/// The mean of `x`'s values as a `[1]` tensor, summed as in [`sum_all`].
pub(super) fn mean_all(x: Tensor<1>) -> Tensor<1> {
    let n = x.dims()[0];
    sum_all(x).div_scalar(n as f32)
}

/// Longest run of values one thread adds in a stage of [`sum_all`].
const MAX_STAGE: usize = 64;

/// How many values each output of [`sum_all`]'s next stage adds for `n` values: all of them
/// when `n` is at most [`MAX_STAGE`] or has no divisor in `2..=MAX_STAGE` (a prime), otherwise
/// the largest such divisor.
fn stage_length(n: usize) -> usize {
    let b = largest_divisor_up_to(n, MAX_STAGE);
    if n <= MAX_STAGE || b == 1 { n } else { b }
}

/// `x` (`[1, k]`) repeated over `rows` rows. The gradient of a plain broadcast is one sum over
/// all rows for each of the `k` columns, which the fixed kernels give to one thread each (a
/// loop over a minibatch's tens of thousands of rows); spread as `[c, rows / c, k]` with `c`
/// near `√rows`, burn's backward pass sums it in two short stages.
pub(super) fn spread_rows(x: Tensor<2>, rows: usize) -> Tensor<2> {
    let k = x.dims()[1];
    let c = largest_divisor_up_to(rows, rows.isqrt());
    x.reshape([1, 1, k])
        .expand([c, rows / c, k])
        .reshape([rows, k])
}

/// The largest divisor of `n` that is at most `m` (1 when there is none larger).
fn largest_divisor_up_to(n: usize, m: usize) -> usize {
    (2..=m).rev().find(|d| n.is_multiple_of(*d)).unwrap_or(1)
}

/// A tensor's values, row-major.
pub(crate) fn values<const D: usize>(t: Tensor<D>) -> Vec<f32> {
    t.into_data()
        .try_into_vec::<f32>()
        .expect("float tensors hold f32 values")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sum_stages_divide_and_stay_short() {
        for n in 1..5_000 {
            let b = stage_length(n);
            assert_eq!(n % b, 0, "{b} does not divide {n}");
            assert!(b <= MAX_STAGE || b == n, "{b} values a thread for {n}");
        }
        assert_eq!(stage_length(32_768), 64);
        assert_eq!(stage_length(80_000), 64);
        assert_eq!(stage_length(1_250), 50);
        assert_eq!(stage_length(10_007), 10_007, "a prime");
        assert_eq!(largest_divisor_up_to(32_768, 32_768usize.isqrt()), 128);
        assert_eq!(largest_divisor_up_to(1_000, 1_000usize.isqrt()), 25);
        assert_eq!(largest_divisor_up_to(7, 2), 1);
    }

    /// Each row is `x`; the gradient of `Σ wᵢⱼ yᵢⱼ` is the column sums of `w`, exact here
    /// because the weights are small integers.
    #[test]
    fn spread_rows_repeats_the_row_and_sums_its_gradient() {
        let device = Device::flex().autodiff();
        for rows in [1, 6, 7, 1_024, 1_000] {
            let x = tensor2(vec![0.5, -2.0, 3.0], 1, 3, &device).require_grad();
            let y = spread_rows(x.clone(), rows);
            assert_eq!(y.dims(), [rows, 3]);
            let got = values(y.clone());
            assert!(got.chunks(3).all(|r| r == [0.5, -2.0, 3.0]), "{rows} rows");
            let w: Vec<f32> = (0..rows * 3).map(|i| (i % 5) as f32).collect();
            let column_sums: Vec<f32> = (0..3).map(|j| w.iter().skip(j).step_by(3).sum()).collect();
            let grads = y.mul(tensor2(w, rows, 3, &device)).sum().backward();
            assert_eq!(values(x.grad(&grads).unwrap()), column_sums, "{rows} rows");
        }
    }

    /// Integers up to 2²⁴ are exact in `f32`, so every summation order gives the exact sum.
    #[test]
    fn sums_and_means_of_all_values_are_exact_for_integers() {
        let device = Device::flex();
        for n in [1, 7, 12, 1_000, 10_007, 2 * 10_007, 32_768, 80_000] {
            let x: Vec<f32> = (0..n).map(|i| (i % 97) as f32).collect();
            let exact: f64 = x.iter().map(|&v| f64::from(v)).sum();
            let t = tensor2(x.clone(), 1, n, &device);
            assert_eq!(values(sum_all(t))[0] as f64, exact, "sum of {n} values");
            let mean = values(mean_all(tensor1(x, &device)))[0] as f64;
            assert!((mean - exact / n as f64).abs() <= 1e-6 * (exact / n as f64).max(1.0));
        }
    }
}
