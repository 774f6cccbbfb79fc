//! Franka reach, after Isaac Lab's `Isaac-Reach-Franka-v0` (spec §5.2): the push rod's tip
//! (`tcp`) tracks poses sampled in front of the robot through joint-position actions. It learns
//! in minutes, which makes it the task that shows learning in CI.

#![warn(missing_docs)]

mod rewards;

pub use rewards::PoseTrackingParams;

const CONFIG: &str = include_str!("../config/reach.ron");
const FILE: &str = "reach.ron (bundled)";

/// The task id.
pub const TASK_ID: &str = "Reach-Franka-v0";

inventory::submit! {
    orbit_managers::TaskDef {
        id: TASK_ID,
        description: "Franka reach: the rod tip tracks sampled poses (Isaac Lab's Isaac-Reach-Franka-v0), joint-position actions",
        file_name: FILE,
        config: CONFIG,
        overrides: &[],
    }
}

inventory::submit! {
    orbit_managers::AgentCfgDef {
        task: TASK_ID,
        library: "rsl_rl",
        file_name: "reach_ppo.ron (bundled)",
        config: include_str!("../config/reach_ppo.ron"),
    }
}
