//! Franka reach, after Isaac Lab's `Isaac-Reach-Franka-v0`: the push rod's tip
//! (`tcp`) tracks poses sampled in front of the robot through joint-position actions. It learns
//! in minutes, which makes it the task that shows learning in CI.

#![warn(missing_docs)]

mod rewards;

pub use rewards::PoseTrackingParams;

/// The task id.
pub const TASK_ID: &str = "Reach-Franka-v0";

inventory::submit! {
    orbit_managers::TaskTable {
        root: "reach",
        files: orbit_managers::config_files!("env/reach.ron", "agents/ppo.ron"),
        tasks: &[orbit_managers::TaskDef {
            id: TASK_ID,
            description: "Franka reach: the rod tip tracks sampled poses (Isaac Lab's Isaac-Reach-Franka-v0), joint-position actions",
            env: "env/reach.ron",
            agent: Some("agents/ppo.ron"),
            black_box: None,
            cpu_agent: None,
        }],
    }
}
