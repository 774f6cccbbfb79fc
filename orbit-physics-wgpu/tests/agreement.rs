//! The GPU backend against the CPU (rapier) backend on the same model, without contacts: the
//! Franka from its raised home pose (clear of the table) under Fancy Gym's torque law with
//! sinusoidal actions (each backend adding its own bias forces every substep), the box moved
//! out of reach, 1 s.

use orbit_core::physics::{PhysicsBackend, SimCfg, build_backend};
use orbit_core::scene::RootState;
use orbit_physics_rapier as _;
use orbit_physics_wgpu::gpu_available_for_tests;

fn run(backend: &str) -> Vec<Vec<f32>> {
    let scene = orbit_assets::box_pushing_scene(&[]).expect("bundled scene");
    let sim = SimCfg {
        backend: backend.into(),
        ..SimCfg::default()
    };
    let mut b: Box<dyn PhysicsBackend> = build_backend(&scene, 1, &sim).expect("backend");
    let home = [0.0, 0.0, 0.0, -1.5, 0.0, 1.5, 0.0];
    b.write_joint_state(0, &[0], &home, &[0.0; 7]).unwrap();
    let mut away = RootState::default();
    away.pose.pos = glam::Vec3::new(2.0, 2.0, 0.0);
    b.write_root_state(0, &[0], &[away]).unwrap();
    b.set_bias_compensation(0, &(0..7).collect::<Vec<_>>(), true)
        .unwrap();
    let mut trajectory = Vec::new();
    for k in 0..50 {
        let t = k as f32 * 0.02;
        // Gentle enough to stay clear of the joint limits and the table.
        // The wrist's inertia is ~50× smaller than the shoulder's.
        let amplitude = [0.5, 0.5, 0.5, 0.5, 0.01, 0.01, 0.01];
        let efforts: Vec<f32> = (0..7)
            .map(|i| amplitude[i] * (std::f32::consts::PI * t + i as f32).sin())
            .collect();
        b.set_joint_efforts(0, &efforts).unwrap();
        b.step_n(10).unwrap();
        trajectory.push(b.articulation(0).joint_pos.to_vec());
    }
    trajectory
}

/// Joint positions agree within 5e-3 rad over the first 0.2 s and 0.1 rad over 1 s, while the
/// arm swings through up to 3 rad (measured: docs/fidelity.md).
#[test]
fn contact_free_tracking_matches_rapier() {
    if !gpu_available_for_tests() {
        return;
    }
    let (gpu, cpu) = (run("wgpu"), run("rapier"));
    // Worst joint difference over the first `steps` env steps.
    let worst = |steps: usize| {
        gpu.iter()
            .zip(&cpu)
            .take(steps)
            .flat_map(|(g, c)| g.iter().zip(c).map(|(a, b)| (a - b).abs()))
            .fold(0.0f32, f32::max)
    };
    let (early, whole) = (worst(10), worst(50));
    let travel = cpu
        .last()
        .unwrap()
        .iter()
        .zip(&cpu[0])
        .map(|(a, b)| (a - b).abs())
        .fold(0.0f32, f32::max);
    println!(
        "wgpu vs rapier, contact-free: worst joint difference {early:.2e} rad over 0.2 s, {whole:.2e} rad over 1 s (largest joint travel {travel:.3} rad)"
    );
    assert!(travel > 0.05, "the arm barely moved ({travel} rad)");
    assert!(early < 5e-3, "backends differ by {early} rad within 0.2 s");
    assert!(whole < 0.1, "backends differ by {whole} rad within 1 s");
}
