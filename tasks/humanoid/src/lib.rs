//! Humanoid locomotion, after Isaac Lab's `Isaac-Humanoid-v0`: effort on the 21 joints of a
//! floating torso that earns its progress towards a target 1 km ahead, staying upright and
//! facing it. It shares the Ant's classic locomotion terms (`orbit-managers`'
//! `mdp::locomotion`) with the Humanoid's weights: alive 2.0, actions −0.01, energy −0.005
//! and joint limits −0.25 (threshold 0.98), both weighted by the joints' gears; angular
//! velocity observed at 0.25 and joint velocities at 0.1; an episode ends early when the torso
//! drops below 0.8 m. The robot is the registered `humanoid` asset (Isaac Gym's
//! `nv_humanoid`, with Isaac Lab's joint springs and dampers as drives towards 0).
//!
//! Where it differs from Isaac Lab's task: the observation leaves out the 12 values of the
//! feet's incoming joint wrenches (neither backend reports joint reaction forces), so it has
//! 75 values, as Isaac Lab's direct-workflow Humanoid does; the target lies 1 km ahead of each
//! env's own origin; the joints are in MuJoCo's order and names (the asset config lists
//! Isaac Lab's names beside them).

#![warn(missing_docs)]

/// The task id.
pub const TASK_ID: &str = "Isaac-Humanoid-v0";

inventory::submit! {
    orbit_managers::TaskTable {
        root: "humanoid",
        files: orbit_managers::config_files!("env/humanoid.ron", "agents/ppo.ron"),
        tasks: &[orbit_managers::TaskDef {
            id: TASK_ID,
            description: "Humanoid: run towards a far target on two legs (Isaac Lab's Isaac-Humanoid-v0), effort actions",
            env: "env/humanoid.ron",
            agent: Some("agents/ppo.ron"),
            black_box: None,
            cpu_agent: None,
        }],
    }
}
