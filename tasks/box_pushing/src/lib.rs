//! Fancy Gym's Franka box pushing (`shared/spec/box_pushing.md`) as a manager-based task: the
//! target-pose command, Fancy Gym's reward terms, and the registered task ids.
//!
//! Rewards follow Fancy Gym's per-step definitions; because Isaac Lab multiplies every reward
//! term by `step_dt` (0.02 s), the RON weights are Fancy Gym's coefficients × 50, so an episode
//! return equals Fancy Gym's.

#![warn(missing_docs)]

mod command;
mod rewards;

pub use command::TargetPoseParams;
pub use rewards::*;

inventory::submit! {
    orbit_managers::TaskDef {
        id: "BoxPushing-Torque-Franka-v0",
        description: "Franka box pushing, Fancy Gym's torque law (10·clip(a) + bias compensation), Dense reward",
        file_name: "box_pushing_torque.ron (bundled)",
        config: include_str!("../config/box_pushing_torque.ron"),
    }
}
