//! The stacked forward pass against a double-precision reference on the host, on whatever
//! Vulkan device the process has (lavapipe in CI).

use orbit_mlp_wgpu::{Activation, MlpError, StackedMlp};

/// A reproducible value in [-1, 1) for index `i` of stream `s` (a hash, no dependency).
fn value(s: u64, i: usize) -> f32 {
    let mut h =
        (i as u64 ^ s.wrapping_mul(0x9e37_79b9_7f4a_7c15)).wrapping_mul(0xff51_afd7_ed55_8ccd);
    h ^= h >> 33;
    h = h.wrapping_mul(0xc4ce_b9fe_1a85_ec53);
    h ^= h >> 33;
    (h >> 40) as f32 / (1u64 << 23) as f32 - 1.0
}

fn activate(v: f64, a: Activation) -> f64 {
    match a {
        Activation::Elu => {
            if v > 0.0 {
                v
            } else {
                v.exp() - 1.0
            }
        }
        Activation::Selu => {
            1.050_700_987_355_480_5
                * if v > 0.0 {
                    v
                } else {
                    1.673_263_242_354_377_3 * (v.exp() - 1.0)
                }
        }
        Activation::Relu => v.max(0.0),
        Activation::LeakyRelu => {
            if v > 0.0 {
                v
            } else {
                0.01 * v
            }
        }
        Activation::Tanh => v.tanh(),
        Activation::Sigmoid => 1.0 / (1.0 + (-v).exp()),
    }
}

/// Each layer's weights `[stacks, k, n]` and biases `[stacks, n]`.
type Parameters = Vec<(Vec<f32>, Vec<f32>)>;

/// Weights and biases of every layer, scaled like a default initialisation (`1/√k`) so the
/// activations stay of order one.
fn parameters(stacks: usize, widths: &[usize]) -> Parameters {
    widths
        .windows(2)
        .enumerate()
        .map(|(l, d)| {
            let scale = 1.0 / (d[0] as f32).sqrt();
            let w = (0..stacks * d[0] * d[1])
                .map(|i| scale * value(2 * l as u64 + 1, i))
                .collect();
            let b = (0..stacks * d[1])
                .map(|i| 0.5 * value(2 * l as u64 + 2, i))
                .collect();
            (w, b)
        })
        .collect()
}

/// `[stacks, rows, outputs]` in f64 on the host.
fn reference(
    params: &Parameters,
    widths: &[usize],
    inputs: &[Vec<f32>],
    stacks: usize,
    rows: usize,
    activation: Activation,
) -> Vec<f64> {
    let mut out = Vec::new();
    for z in 0..stacks {
        let input = &inputs[z.min(inputs.len() - 1)];
        for r in 0..rows {
            let mut x: Vec<f64> = input[r * widths[0]..(r + 1) * widths[0]]
                .iter()
                .map(|&v| v as f64)
                .collect();
            for (l, (w, b)) in params.iter().enumerate() {
                let (k, n) = (widths[l], widths[l + 1]);
                x = (0..n)
                    .map(|j| {
                        let sum: f64 = (0..k)
                            .map(|i| x[i] * w[z * k * n + i * n + j] as f64)
                            .sum::<f64>()
                            + b[z * n + j] as f64;
                        if l + 2 < widths.len() {
                            activate(sum, activation)
                        } else {
                            sum
                        }
                    })
                    .collect();
            }
            out.extend(x);
        }
    }
    out
}

fn device() -> Option<(orbit_mlp_wgpu::wgpu::Device, orbit_mlp_wgpu::wgpu::Queue)> {
    if !orbit_physics_wgpu::gpu_available_for_tests() {
        return None;
    }
    let gpu = orbit_physics_wgpu::gpu().expect("checked above");
    Some((gpu.device.clone(), gpu.queue.clone()))
}

fn network(
    rows: usize,
    stacks: usize,
    widths: &[usize],
    activation: Activation,
) -> Option<(StackedMlp, Parameters)> {
    let (device, queue) = device()?;
    let mut mlp = StackedMlp::new(&device, &queue, rows, stacks, widths, activation).unwrap();
    let params = parameters(stacks, widths);
    for (l, (w, b)) in params.iter().enumerate() {
        mlp.load_layer(l, w, b).unwrap();
    }
    Some((mlp, params))
}

/// Every activation, two networks with their own inputs, widths and rows that are not
/// multiples of the kernel's tiles (64) or slices (16): each output agrees with the f64
/// reference within 2e-5 + 2e-5·|y| (sums of at most 70 products of order-one values in f32).
#[test]
fn outputs_match_a_double_precision_reference() {
    let (rows, stacks, widths) = (203, 2, [37, 70, 33, 5]);
    for activation in [
        Activation::Elu,
        Activation::Selu,
        Activation::Relu,
        Activation::LeakyRelu,
        Activation::Tanh,
        Activation::Sigmoid,
    ] {
        let Some((mut mlp, params)) = network(rows, stacks, &widths, activation) else {
            return;
        };
        let inputs: Vec<Vec<f32>> = (0..stacks)
            .map(|z| {
                (0..rows * widths[0])
                    .map(|i| 2.0 * value(100 + z as u64, i))
                    .collect()
            })
            .collect();
        let mut out = vec![0.0; stacks * rows * widths[3]];
        let views: Vec<&[f32]> = inputs.iter().map(Vec::as_slice).collect();
        mlp.forward(&views, &mut out).unwrap();
        let expected = reference(&params, &widths, &inputs, stacks, rows, activation);
        let worst = out
            .iter()
            .zip(&expected)
            .map(|(&y, &e)| (y as f64 - e).abs() / (2e-5 + 2e-5 * e.abs()))
            .fold(0.0, f64::max);
        assert!(
            worst <= 1.0,
            "{activation:?}: error {worst} times the tolerance"
        );
    }
}

/// One input read by both networks gives the same bits as two copies of it, and passes
/// alternating between the two forms, or repeated, give the same bits each time.
#[test]
fn a_shared_input_equals_its_copies_bit_for_bit() {
    let (rows, widths) = (130, [20, 64, 3]);
    let Some((mut mlp, _)) = network(rows, 2, &widths, Activation::Elu) else {
        return;
    };
    let x: Vec<f32> = (0..rows * widths[0]).map(|i| value(7, i)).collect();
    let mut shared = vec![0.0; 2 * rows * 3];
    let mut copies = shared.clone();
    let mut again = shared.clone();
    mlp.forward(&[&x], &mut shared).unwrap();
    mlp.forward(&[&x, &x], &mut copies).unwrap();
    mlp.forward(&[&x], &mut again).unwrap();
    assert_eq!(shared, copies);
    assert_eq!(shared, again);
    // The two networks' weights differ, so their halves must too.
    assert_ne!(shared[..rows * 3], shared[rows * 3..]);
}

/// Inputs, outputs or weights of the wrong length are errors that name the expected shape,
/// and leave the networks usable.
#[test]
fn wrong_lengths_are_errors() {
    let (rows, widths) = (16, [4, 8, 2]);
    let Some((mut mlp, params)) = network(rows, 2, &widths, Activation::Tanh) else {
        return;
    };
    let x = vec![0.5; rows * 4];
    let mut out = vec![0.0; 2 * rows * 2];
    let short = vec![0.5; rows * 4 - 1];
    let err = mlp.forward(&[&short], &mut out).unwrap_err();
    assert!(
        matches!(&err, MlpError::Shape(m) if m.contains("16 × 4")),
        "{err}"
    );
    assert!(mlp.forward(&[&x, &x, &x], &mut out).is_err());
    assert!(mlp.forward(&[&x], &mut out[1..]).is_err());
    assert!(mlp.load_layer(2, &params[0].0, &params[0].1).is_err());
    assert!(mlp.load_layer(1, &params[0].0, &params[0].1).is_err());
    mlp.forward(&[&x], &mut out).unwrap();
    assert!(out.iter().all(|v| v.is_finite()));
    assert!(
        StackedMlp::new(
            &mlp_device().0,
            &mlp_device().1,
            0,
            2,
            &widths,
            Activation::Tanh
        )
        .is_err()
    );
}

fn mlp_device() -> (orbit_mlp_wgpu::wgpu::Device, orbit_mlp_wgpu::wgpu::Queue) {
    device().expect("a device, as the caller checked")
}
