//! Checks on the bundled Franka box-pushing scene: forward kinematics against MuJoCo's, holding
//! a pose under PD + gravity, and tracking MuJoCo rollouts under Fancy Gym's torque law; and
//! the facts of determinism and env independence (resets, writes, mass changes) on that scene.
//!
//! - `kinematics`: forward kinematics against MuJoCo's, and [`frame_pose`];
//! - `drives`: holding a pose under implicit PD and gravity;
//! - `rollouts`: agreement with the MuJoCo reference rollouts;
//! - `determinism`: repeatable runs and resets under random torques;
//! - `writes`: state writes and parameter changes touch only what they name.

use orbit_core::scene::SceneCfg;

mod determinism;
mod drives;
mod kinematics;
mod rollouts;
mod writes;

pub use determinism::{deterministic_runs, resets_leave_other_envs_untouched};
pub use drives::franka_holds_pose_under_pd;
pub use kinematics::{frame_pose, franka_forward_kinematics};
pub use rollouts::{
    RolloutAgreement, franka_mujoco_rollouts, franka_mujoco_rollouts_with,
    franka_tracks_mujoco_rollouts, franka_tracks_mujoco_rollouts_with,
};
pub use writes::{
    a_mass_change_touches_only_its_envs, a_reset_env_forgets_its_past,
    a_reset_env_forgets_its_past_with, a_write_replaces_only_what_it_names,
    a_write_replaces_only_what_it_names_with, batched_writes_equal_single_writes,
    substeps_after_a_write_do_not_depend_on_dispatch,
};

/// The bundled box-pushing scene config (Franka with push rod, table, box).
pub fn box_pushing_scene_cfg() -> SceneCfg {
    orbit_assets::box_pushing_scene_cfg(&[]).unwrap_or_else(|e| panic!("bundled scene: {e}"))
}
