//! The GPU learner collects rollouts with `orbit-mlp-wgpu`'s kernels, loaded from
//! [`StackedActorCritic::host_layers`]: fed those parameters, the kernels give the stacked
//! pass's means and values (on the Vulkan device the process has; lavapipe in CI).

use burn::tensor::{Device, Tensor, TensorData};
use orbit_mlp_wgpu::{Activation as KernelActivation, StackedMlp};
use orbit_rl::cfg::{Activation, NoiseStdType, PolicyCfg};
use orbit_rl::model::{ActorCritic, StackedActorCritic};

/// Means and values agree within 1e-5 of the outputs' largest magnitude (the same products in
/// f32, summed by different kernels), with the critic's padding columns exactly 0.
#[test]
fn kernels_reproduce_the_stacked_pass() {
    if !orbit_physics_wgpu::gpu_available_for_tests() {
        return;
    }
    let gpu = orbit_physics_wgpu::gpu().expect("checked above");
    let cfg = PolicyCfg {
        init_noise_std: 1.0,
        actor_hidden_dims: vec![64, 32],
        critic_hidden_dims: vec![64, 32],
        activation: Activation::Elu,
        noise_std_type: NoiseStdType::Scalar,
    };
    let (rows, num_obs, num_actions) = (150, 11, 3);
    let device = Device::flex();
    let model = ActorCritic::new(&cfg, num_obs, num_obs, num_actions, 3, &device);
    let stacked = StackedActorCritic::new(&model).expect("equal widths stack");
    assert_eq!(stacked.widths(), [num_obs, 64, 32, num_actions]);

    let mut mlp = StackedMlp::new(
        &gpu.device,
        &gpu.queue,
        rows,
        2,
        &stacked.widths(),
        KernelActivation::Elu,
    )
    .unwrap();
    for (l, (w, b)) in stacked.host_layers().iter().enumerate() {
        mlp.load_layer(l, w, b).unwrap();
    }
    let obs: Vec<f32> = (0..rows * num_obs)
        .map(|i| ((i * 7) % 13) as f32 * 0.3 - 1.8)
        .collect();
    let mut out = vec![0.0; 2 * rows * num_actions];
    mlp.forward(&[&obs], &mut out).unwrap();

    let x = Tensor::from_data(TensorData::new(obs, [rows, num_obs]), &device);
    let expected: Vec<f32> = stacked.forward(x, None).into_data().try_into_vec().unwrap();
    let scale = expected.iter().fold(1.0f32, |m, v| m.max(v.abs()));
    let worst = out
        .iter()
        .zip(&expected)
        .fold(0.0f32, |m, (a, b)| m.max((a - b).abs()));
    assert!(worst <= 1e-5 * scale, "outputs differ by {worst}");
    for row in out[rows * num_actions..].chunks(num_actions) {
        assert_eq!(&row[1..], &[0.0, 0.0], "the critic's padding");
    }
}
