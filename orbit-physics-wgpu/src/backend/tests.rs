//! The step kernel compiled without wgpu's run-time checks against the fully checked one.

use std::path::Path;

use orbit_core::physics::{PhysicsBackend, SimCfg};
use orbit_core::scene::SceneDesc;

use super::WgpuBackend;
use crate::gpu::{KernelChecks, gpu_available_for_tests};

/// The whole state of `n` envs of `scene` after 5 dispatches of 5 steps under efforts of
/// amplitude `effort` that differ per env and per dispatch.
fn stepped_state(scene: &SceneDesc, checks: KernelChecks, n: usize, effort: f32) -> Vec<f32> {
    let mut b = WgpuBackend::build(scene, n, &SimCfg::default(), checks).expect("backend");
    let dofs = b.layout().articulations[0].num_dofs();
    for k in 0..5 {
        let efforts: Vec<f32> = (0..n * dofs)
            .map(|i| effort * (0.7 * k as f32 + 0.37 * i as f32).sin())
            .collect();
        b.set_joint_efforts(0, &efforts).unwrap();
        b.step_n(5).unwrap();
    }
    let state = b.state_f32().to_vec();
    assert!(
        state.iter().all(|x| x.is_finite()),
        "the state stays finite"
    );
    state
}

/// Asserts that without wgpu's index clamps and loop counters the kernel of bundled scene
/// `name` gives the state it gives with them, within 1e-4 of each value (relative beyond 1).
/// An index out of its array would read a clamped element in one kernel and other memory in
/// the other. Rounding may differ, since the driver fuses multiplies and adds where it sees
/// fit: on lavapipe the states are the same bit for bit; on an H200 the box-pushing scene's
/// are the same after 10 steps and differ by up to 1.5e-5 after 25.
fn assert_trusted_steps_as_checked(name: &str, effort: f32) {
    if !gpu_available_for_tests() {
        return;
    }
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../orbit-assets/assets/scenes")
        .join(format!("{name}.ron"));
    let scene = orbit_assets::load_scene(&path, &[]).expect("bundled scene");
    let checked = stepped_state(&scene, KernelChecks::Checked, 8, effort);
    let trusted = stepped_state(&scene, KernelChecks::Trusted, 8, effort);
    for (i, (a, b)) in checked.iter().zip(&trusted).enumerate() {
        assert!(
            (a - b).abs() <= 1e-4 * a.abs().max(1.0),
            "{name}: state float {i} is {a} checked and {b} trusted"
        );
    }
}

/// The arm with a free box: contacts between links and objects, rows in private memory.
#[test]
fn the_trusted_kernel_steps_box_pushing_as_the_checked_one() {
    assert_trusted_steps_as_checked("box_pushing", 20.0);
}

/// The Ant: a floating base on the ground plane.
#[test]
fn the_trusted_kernel_steps_the_ant_as_the_checked_one() {
    assert_trusted_steps_as_checked("ant", 10.0);
}

/// The Humanoid: rows in a storage buffer, limit rows listed before they are built.
#[test]
fn the_trusted_kernel_steps_the_humanoid_as_the_checked_one() {
    assert_trusted_steps_as_checked("humanoid", 20.0);
}
