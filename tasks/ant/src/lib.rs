//! Ant locomotion, after Isaac Lab's `Isaac-Ant-v0`: effort on the eight joints of a
//! four-legged floating base that earns its progress towards a target 1 km ahead, staying
//! upright and facing it. Its terms are the classic locomotion ones of `orbit-managers`
//! (`base_yaw_roll`, `base_angle_to_target`, `base_up_proj`, `base_heading_proj`,
//! `progress_reward`, `upright_posture_bonus`, `move_to_target_bonus`, `power_consumption`,
//! `joint_pos_limits_penalty_ratio`) and generic ones; the robot is the registered `ant`
//! asset.
//!
//! Where it differs from Isaac Lab's task: the observation leaves out the 24 values of the
//! feet's incoming joint wrenches (PhysX's `body_incoming_wrench`; neither backend reports joint
//! reaction forces), so it has 36 values, as Isaac Lab's direct-workflow Ant does; the target
//! lies 1 km ahead of each env's own origin, where Isaac Lab's is one world point that envs off
//! the x axis see at an angle; a reset restarts the progress from the horizontal distance,
//! where Isaac Lab's uses the full one for that first difference.

#![warn(missing_docs)]

/// The task id.
pub const TASK_ID: &str = "Isaac-Ant-v0";

inventory::submit! {
    orbit_managers::TaskTable {
        root: "ant",
        files: orbit_managers::config_files!("env/ant.ron", "agents/ppo.ron"),
        tasks: &[orbit_managers::TaskDef {
            id: TASK_ID,
            description: "Ant: run towards a far target on four legs (Isaac Lab's Isaac-Ant-v0), effort actions",
            env: "env/ant.ron",
            agent: Some("agents/ppo.ron"),
            black_box: None,
            cpu_agent: None,
        }],
    }
}
