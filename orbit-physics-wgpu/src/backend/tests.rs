//! The step kernel compiled without wgpu's run-time checks against the fully checked one.

use std::path::Path;

use orbit_core::physics::{PhysicsBackend, SimCfg};
use orbit_core::scene::SceneDesc;

use super::WgpuBackend;
use crate::gpu::{KernelChecks, gpu_available_for_tests};

/// The whole state, as bits, of `n` envs of `scene` after 20 dispatches of 5 steps under
/// efforts of amplitude `effort` that differ per env and per dispatch.
fn stepped_state(scene: &SceneDesc, checks: KernelChecks, n: usize, effort: f32) -> Vec<u32> {
    let mut b = WgpuBackend::build(scene, n, &SimCfg::default(), checks).expect("backend");
    let dofs = b.layout().articulations[0].num_dofs();
    for k in 0..20 {
        let efforts: Vec<f32> = (0..n * dofs)
            .map(|i| effort * (0.7 * k as f32 + 0.37 * i as f32).sin())
            .collect();
        b.set_joint_efforts(0, &efforts).unwrap();
        b.step_n(5).unwrap();
    }
    let state = b.state_f32();
    assert!(
        state.iter().all(|x| x.is_finite()),
        "the state stays finite"
    );
    state.iter().map(|x| x.to_bits()).collect()
}

/// Asserts that without wgpu's index clamps and loop counters the kernel of bundled scene
/// `name` gives the same state, bit for bit, as with them: where an index left its array, the
/// checked kernel would read a clamped element and the trusted one other memory.
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
    let differ = checked.iter().zip(&trusted).filter(|(a, b)| a != b).count();
    assert_eq!(
        differ,
        0,
        "{name}: {differ} of {} state floats differ",
        checked.len()
    );
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
