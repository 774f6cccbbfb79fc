//! The box-pushing task on the GPU backend, selected by one config value
//! (`sim.backend="wgpu"`): Fancy Gym's zero-action reference return, and the same step on both
//! backends while the arm moves freely. Skips without a Vulkan adapter unless
//! `ORBIT_REQUIRE_GPU=1`.

use orbit_managers::make;
use orbit_physics_rapier as _;
use orbit_physics_wgpu::gpu_available_for_tests;
use orbit_task_box_pushing as _;

mod common;
use common::{TASK, seed0_target_override};

/// Zero action from the default reset and the seed-0 target: Fancy Gym's Dense return is
/// −194.5184 (MuJoCo); the GPU backend must agree within 1 %, like the CPU backend.
#[test]
fn zero_action_dense_return_on_the_gpu() {
    if !gpu_available_for_tests() {
        return;
    }
    let overrides = [
        "num_envs=2".to_string(),
        "sim.backend=\"wgpu\"".to_string(),
        seed0_target_override(),
    ];
    let mut env = make(TASK, &overrides).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(env.scene().backend.name(), "wgpu");
    env.reset().unwrap();
    let zero = vec![0.0; 2 * env.action_dim()];
    let mut ret = [0.0f64; 2];
    for step in 1..=100 {
        let r = env.step(&zero).unwrap();
        for (acc, &x) in ret.iter_mut().zip(r.reward) {
            *acc += f64::from(x);
        }
        assert_eq!(r.time_outs[0], step == 100, "time-out flag at step {step}");
    }
    let expected = -194.5184247;
    let rel = (ret[0] - expected).abs() / expected.abs();
    println!(
        "wgpu zero-action Dense return {:.4} vs Fancy Gym {expected} (rel. error {rel:.2e})",
        ret[0]
    );
    assert!(rel < 0.01, "Dense return {} vs {expected}", ret[0]);
    assert_eq!(
        ret[0], ret[1],
        "two envs with the same start give the same bits"
    );
}
