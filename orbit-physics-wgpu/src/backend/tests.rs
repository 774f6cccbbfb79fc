//! The step kernel compiled without wgpu's run-time checks against the fully checked one, and
//! its looped form against its straight-line one.

use std::path::Path;

use orbit_core::physics::{PhysicsBackend, SimCfg};
use orbit_core::scene::SceneDesc;

use super::WgpuBackend;
use crate::codegen::KernelForm;
use crate::gpu::{KernelChecks, gpu_available_for_tests};

/// The whole state of `n` envs of `scene` after 5 dispatches of `steps` steps under efforts
/// of amplitude `effort` that differ per env and per dispatch.
fn stepped_state(
    scene: &SceneDesc,
    (checks, form): (KernelChecks, Option<KernelForm>),
    (n, steps): (usize, usize),
    effort: f32,
) -> Vec<f32> {
    let mut b = WgpuBackend::build(scene, n, &SimCfg::default(), checks, form).expect("backend");
    let dofs = b.layout().articulations[0].num_dofs();
    for k in 0..5 {
        let efforts: Vec<f32> = (0..n * dofs)
            .map(|i| effort * (0.7 * k as f32 + 0.37 * i as f32).sin())
            .collect();
        b.set_joint_efforts(0, &efforts).unwrap();
        b.step_n(steps).unwrap();
    }
    let state = b.state_f32().to_vec();
    assert!(
        state.iter().all(|x| x.is_finite()),
        "the state stays finite"
    );
    state
}

/// Bundled scene `name`.
fn bundled_scene(name: &str) -> SceneDesc {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../orbit-assets/assets/scenes")
        .join(format!("{name}.ron"));
    orbit_assets::load_scene(&path, &[]).expect("bundled scene")
}

/// Asserts that states `a` and `b` of scene `name` agree within `tol` of each value (relative
/// beyond 1).
fn assert_states_agree(name: &str, (a, b): (&[f32], &[f32]), what: (&str, &str), tol: f32) {
    for (i, (x, y)) in a.iter().zip(b).enumerate() {
        assert!(
            (x - y).abs() <= tol * x.abs().max(1.0),
            "{name}: state float {i} is {x} {} and {y} {}",
            what.0,
            what.1
        );
    }
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
    let scene = bundled_scene(name);
    let checked = stepped_state(&scene, (KernelChecks::Checked, None), (8, 5), effort);
    let trusted = stepped_state(&scene, (KernelChecks::Trusted, None), (8, 5), effort);
    let what = ("checked", "trusted");
    assert_states_agree(name, (&checked, &trusted), what, 1e-4);
}

/// Asserts that the looped kernel of bundled scene `name` steps it as the straight-line one,
/// within `tol` of each value (relative beyond 1) after 10 steps. The two do the same
/// arithmetic except where the driver folds the straight-line form's literals, and where the
/// straight-line form factorises a serial chain's system matrix densely (the looped one always
/// along the tree of dofs). Their rounding differs, and on the Ant, tumbling on the ground
/// under these efforts, a difference grows fast. On lavapipe after 10 steps: 2e-5 on box
/// pushing, 1.7e-6 on the Ant (factorised along the tree in both forms; 6e-5 with the dense
/// factorisation, which reached 3e-3 after 20 steps and 0.5 after 25).
fn assert_looped_steps_as_straight_line(name: &str, effort: f32, tol: f32) {
    if !gpu_available_for_tests() {
        return;
    }
    let scene = bundled_scene(name);
    let kernel = |form| (KernelChecks::Trusted, Some(form));
    let straight = stepped_state(&scene, kernel(KernelForm::StraightLine), (8, 2), effort);
    let looped = stepped_state(&scene, kernel(KernelForm::Looped), (8, 2), effort);
    let what = ("straight-line", "looped");
    assert_states_agree(name, (&straight, &looped), what, tol);
}

#[test]
fn the_looped_kernel_steps_box_pushing_as_the_straight_line_one() {
    assert_looped_steps_as_straight_line("box_pushing", 20.0, 1e-3);
}

#[test]
fn the_looped_kernel_steps_the_ant_as_the_straight_line_one() {
    assert_looped_steps_as_straight_line("ant", 10.0, 1e-4);
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

/// The Ant without its ground (no contacts) steps with a thread per leg as with one thread per
/// env, within 1e-4 of each value (relative beyond 1) after 30 steps. Under these efforts its
/// joints spend about a third of the steps within 0.01 rad of a limit, so limit rows and their
/// warm starts are in play. The two forms sum the legs' shares of the root's force, inertia and
/// Schur complement in other orders, and the thread-per-leg sweeps move a leg's dofs by the
/// root's change once per turn rather than once per row: on lavapipe they differ by up to
/// 1.0e-4 in values up to 48.
#[test]
fn the_thread_per_leg_kernel_steps_the_ant_as_the_straight_line_one() {
    if !gpu_available_for_tests() {
        return;
    }
    let mut scene = bundled_scene("ant");
    scene.static_objects.clear();
    let kernel = |form| (KernelChecks::Trusted, Some(form));
    let straight = stepped_state(&scene, kernel(KernelForm::StraightLine), (8, 6), 30.0);
    let lanes = stepped_state(&scene, kernel(KernelForm::ThreadPerBranch), (8, 6), 30.0);
    let what = ("straight-line", "thread per leg");
    assert_states_agree("ant without ground", (&straight, &lanes), what, 1e-4);
}

/// The Ant on its ground steps with a thread per leg as with one thread per env, within 1e-4
/// of each value (relative beyond 1) after 10 steps, its feet on the ground: both visit the
/// contacts leg by leg (the narrow phase lists them so), and before a joint reaches its limit
/// the sweeps' orders agree. On lavapipe they differ by about 2e-6. Later the orders differ
/// (a leg's contacts, then its limit rows, against every contact, then every limit row), and
/// projected Gauss–Seidel with friction ends at other solutions for other orders.
#[test]
fn the_thread_per_leg_kernel_steps_the_ant_on_its_ground_as_the_straight_line_one() {
    if !gpu_available_for_tests() {
        return;
    }
    let scene = bundled_scene("ant");
    let kernel = |form| (KernelChecks::Trusted, Some(form));
    let straight = stepped_state(&scene, kernel(KernelForm::StraightLine), (8, 2), 10.0);
    let lanes = stepped_state(&scene, kernel(KernelForm::ThreadPerBranch), (8, 2), 10.0);
    let what = ("straight-line", "thread per leg");
    assert_states_agree("ant", (&straight, &lanes), what, 1e-4);
}
