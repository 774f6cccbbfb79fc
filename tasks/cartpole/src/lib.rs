//! Cart-pole, after Isaac Lab's `Isaac-Cartpole-v0`: a force on the cart keeps the pole upright
//! on its rail. Its terms are the generic ones (`is_alive`, `is_terminated`,
//! `joint_pos_target_l2`, `joint_vel_l1`, `joint_pos_out_of_manual_limit`); the robot is the
//! registered `cartpole` asset.

#![warn(missing_docs)]

/// The task id.
pub const TASK_ID: &str = "Isaac-Cartpole-v0";

inventory::submit! {
    orbit_managers::TaskTable {
        root: "cartpole",
        files: orbit_managers::config_files!("env/cartpole.ron", "agents/ppo.ron"),
        tasks: &[orbit_managers::TaskDef {
            id: TASK_ID,
            description: "Cart-pole: push the cart to balance the pole (Isaac Lab's Isaac-Cartpole-v0), effort actions",
            env: "env/cartpole.ron",
            agent: Some("agents/ppo.ron"),
            black_box: None,
            cpu_agent: None,
        }],
    }
}
