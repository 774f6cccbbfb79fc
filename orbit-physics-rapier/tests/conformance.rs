//! The backend conformance suite on the rapier backend.

use orbit_physics_rapier::BACKEND_NAME;

#[test]
fn free_fall() {
    orbit_conformance::free_fall(BACKEND_NAME);
}

#[test]
fn pendulum_period() {
    orbit_conformance::pendulum_period(BACKEND_NAME);
}

#[test]
fn cart_pendulum_period() {
    orbit_conformance::cart_pendulum_period(BACKEND_NAME);
}

#[test]
fn free_flight_momentum() {
    orbit_conformance::free_flight_momentum(BACKEND_NAME);
}

#[test]
fn floating_root_writes() {
    orbit_conformance::floating_root_writes(BACKEND_NAME);
}

#[test]
fn snapshot_replays_a_step() {
    orbit_conformance::snapshot_replays_a_step(BACKEND_NAME);
}

#[test]
fn ant_tracks_mujoco_rollout() {
    // Rapier moves positions with neither the new nor the old velocity alone (see `free_fall`):
    // in a fall of 0.29 s at 2 ms steps the two Euler variants part by g t h / 2 = 2.8 mm.
    let tolerance = orbit_conformance::StateError {
        root_pos: 4e-3,
        root_rot: 1e-3,
        joint_pos: 2e-3,
    };
    orbit_conformance::ant_tracks_mujoco_rollout(BACKEND_NAME, tolerance);
}

#[test]
fn ant_standing_height() {
    orbit_conformance::ant_standing_height(BACKEND_NAME);
}

#[test]
fn box_rests_on_table() {
    orbit_conformance::box_rests_on_table(BACKEND_NAME);
}

#[test]
fn sliding_box_decelerates_at_mu_g() {
    orbit_conformance::sliding_box_decelerates_at_mu_g(
        BACKEND_NAME,
        orbit_conformance::LowSpeedFriction::Coulomb,
    );
}

#[test]
fn writes_touch_only_listed_envs() {
    orbit_conformance::writes_touch_only_listed_envs(BACKEND_NAME);
}

#[test]
fn franka_forward_kinematics() {
    orbit_conformance::franka_forward_kinematics(BACKEND_NAME);
}

#[test]
fn franka_holds_pose_under_pd() {
    orbit_conformance::franka_holds_pose_under_pd(BACKEND_NAME);
}

/// MuJoCo agreement under Fancy Gym's torque law: the ProMP cases within 0.02 rad joint RMS
/// over the whole episode, every case within 0.005 rad before contact.
#[test]
fn franka_tracks_mujoco_rollouts() {
    orbit_conformance::franka_tracks_mujoco_rollouts(BACKEND_NAME, 0.02);
}

#[test]
fn deterministic_runs() {
    orbit_conformance::deterministic_runs(BACKEND_NAME);
}

#[test]
fn resets_leave_other_envs_untouched() {
    orbit_conformance::resets_leave_other_envs_untouched(BACKEND_NAME);
}

#[test]
fn a_reset_env_forgets_its_past() {
    orbit_conformance::a_reset_env_forgets_its_past(BACKEND_NAME);
}

#[test]
fn a_write_replaces_only_what_it_names() {
    orbit_conformance::a_write_replaces_only_what_it_names(BACKEND_NAME);
}

#[test]
fn batched_writes_equal_single_writes() {
    orbit_conformance::batched_writes_equal_single_writes(BACKEND_NAME);
}

#[test]
fn a_mass_change_touches_only_its_envs() {
    orbit_conformance::a_mass_change_touches_only_its_envs(BACKEND_NAME);
}

#[test]
fn substeps_after_a_write_do_not_depend_on_dispatch() {
    orbit_conformance::substeps_after_a_write_do_not_depend_on_dispatch(BACKEND_NAME);
}

/// As for the Ant: in a fall of 0.47 s the two Euler variants part by g t h / 2 = 4.6 mm.
const HUMANOID_TOLERANCE: orbit_conformance::StateError = orbit_conformance::StateError {
    root_pos: 6e-3,
    root_rot: 1e-3,
    joint_pos: 2e-3,
};

#[test]
fn humanoid_tracks_mujoco_rollout() {
    orbit_conformance::humanoid_tracks_mujoco_rollout(BACKEND_NAME, HUMANOID_TOLERANCE);
}

#[test]
fn humanoid_springs_track_mujoco_rollout() {
    // The joint springs are explicit as in MuJoCo; the root's position parts by semi-implicit
    // Euler's variants as in `humanoid_tracks_mujoco_rollout`.
    let tolerance = orbit_conformance::StateError {
        joint_pos: 1e-3,
        ..HUMANOID_TOLERANCE
    };
    orbit_conformance::humanoid_springs_track_mujoco_rollout(BACKEND_NAME, tolerance);
}

#[test]
fn ant_stands_like_mujoco() {
    // Standing is contact all along, and rapier's contacts are not MuJoCo's soft ones.
    orbit_conformance::ant_stands_like_mujoco(BACKEND_NAME, ANT_STANDING_TOLERANCE);
}

/// The Ant standing beside MuJoCo over a second: a torso that sinks or a leg that folds is off
/// by tenths; the contact models' differences (solver, friction cone) stay within these.
const ANT_STANDING_TOLERANCE: orbit_conformance::StateError = orbit_conformance::StateError {
    root_pos: 0.03,
    root_rot: 0.06,
    joint_pos: 0.04,
};

#[test]
fn humanoid_tracks_mujoco_rollout_far_from_origin() {
    orbit_conformance::humanoid_tracks_mujoco_rollout_far_from_origin(
        BACKEND_NAME,
        HUMANOID_TOLERANCE,
    );
}
