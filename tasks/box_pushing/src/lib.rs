//! Fancy Gym's Franka box pushing (`fancy_gym/envs/mujoco/box_pushing`) as a manager-based
//! task: the target-pose command, Fancy Gym's reward terms, and the registered task ids with
//! their config files (`config/env/*.ron`: a base and one file per variant that includes it;
//! `config/agents/`, `config/black_box/`).
//!
//! Rewards follow Fancy Gym's per-step definitions; because Isaac Lab multiplies every reward
//! term by `step_dt` (0.02 s), the RON weights are Fancy Gym's coefficients × 50, so an episode
//! return equals Fancy Gym's.

#![warn(missing_docs)]

mod command;
mod ik;
mod observations;
mod rewards;

pub use command::{SUCCESS_ANGLE, SUCCESS_DISTANCE, TargetPoseParams};
pub use ik::{ArmIkParams, IkSolution, OfflineIk};
pub use rewards::*;

use orbit_managers::TaskDef;

/// Where the bundled configs of this crate live (`<bundled>/box_pushing/…`).
pub const CONFIG_ROOT: &str = "box_pushing";

/// The task table: `(id, env file, agent file, black-box file)`.
#[rustfmt::skip]
const TASKS: &[TaskDef] = &[
    task("BoxPushing-Torque-Franka-v0", "env/torque.ron", Some(PPO), None,
        "Franka box pushing, Fancy Gym's torque law (10·clip(a) + bias compensation), Dense reward"),
    task("BoxPushing-Torque-TemporalSparse-Franka-v0", "env/torque_temporal_sparse.ron", None, None,
        "Franka box pushing, torque law, TemporalSparse reward"),
    task("BoxPushing-Torque-TemporalSpatialSparse-Franka-v0", "env/torque_temporal_spatial_sparse.ron", None, None,
        "Franka box pushing, torque law, TemporalSpatialSparse reward"),
    task("BoxPushing-Torque-RandomInit-Franka-v0", "env/torque_random_init.ron", None, None,
        "Franka box pushing, torque law, Dense reward, random initial box pose with the arm placed by IK"),
    task("BoxPushing-JointPos-Franka-v0", "env/joint_pos.ron", Some(PPO), None,
        "Franka box pushing, joint position targets through implicit PD (k 400, d 80), Dense reward")
        .with_cpu_agent(PPO_CPU),
    task("BoxPushing-TaskSpace-Franka-v0", "env/task_space.ron", Some(PPO), None,
        "Franka box pushing, relative tcp pose commands through differential IK (DLS) and implicit PD, Dense reward"),
    task("BoxPushing-ProMP-Franka-v0", "env/torque.ron", Some(BBRL), Some("black_box/promp.ron"),
        "black-box box pushing: a ProMP per episode from the target pose, Fancy Gym's PD on the torque env, Dense reward"),
    task("BoxPushing-ProMP-JointPos-Franka-v0", "env/joint_pos.ron", Some(BBRL), Some("black_box/promp_joint_pos.ron"),
        "black-box box pushing: a ProMP per episode as joint position targets of the implicit PD drives (Orbit's way), Dense reward"),
    task("BoxPushing-ProMP-TemporalSparse-Franka-v0", "env/torque_temporal_sparse.ron", Some(BBRL), Some("black_box/promp.ron"),
        "black-box box pushing: a ProMP per episode, Fancy Gym's PD, TemporalSparse reward"),
    task("BoxPushing-ProMP-RandomInit-Franka-v0", "env/torque_random_init.ron", Some(BBRL), Some("black_box/promp_random_init.ron"),
        "black-box box pushing from a random box pose: a ProMP per episode from joints, box and target, Fancy Gym's PD, Dense reward"),
    task("BoxPushing-ProDMP-Franka-v0", "env/torque.ron", Some(BBRL), Some("black_box/prodmp.ron"),
        "black-box box pushing: a ProDMP (weights and goal) per episode, Fancy Gym's PD on the torque env, Dense reward"),
    task("BoxPushing-ProDMP-Replan-Franka-v0", "env/torque.ron", Some(BBRL), Some("black_box/prodmp_replan.ron"),
        "black-box box pushing with replanning: a ProDMP every 25 steps from the previous plan's desired state, Fancy Gym's PD, Dense reward"),
];

/// Step-based PPO, the Orbit port's settings.
const PPO: &str = "agents/ppo.ron";
/// Step-based PPO sized for physics on the CPU (the default task's main job without a GPU).
const PPO_CPU: &str = "agents/ppo_cpu.ron";
/// BBRL-PPO, the Orbit port's black-box settings.
const BBRL: &str = "agents/bbrl_ppo.ron";

const fn task(
    id: &'static str,
    env: &'static str,
    agent: Option<&'static str>,
    black_box: Option<&'static str>,
    description: &'static str,
) -> TaskDef {
    TaskDef {
        id,
        description,
        env,
        agent,
        black_box,
        cpu_agent: None,
    }
}

inventory::submit! {
    orbit_managers::TaskTable {
        root: CONFIG_ROOT,
        files: orbit_managers::config_files!(
            "env/base.ron",
            "env/torque.ron",
            "env/torque_temporal_sparse.ron",
            "env/torque_temporal_spatial_sparse.ron",
            "env/torque_random_init.ron",
            "env/implicit_pd.ron",
            "env/joint_pos.ron",
            "env/task_space.ron",
            "agents/ppo.ron",
            "agents/ppo_cpu.ron",
            "agents/bbrl_ppo.ron",
            "black_box/promp.ron",
            "black_box/promp_joint_pos.ron",
            "black_box/promp_random_init.ron",
            "black_box/prodmp.ron",
            "black_box/prodmp_replan.ron",
        ),
        tasks: TASKS,
    }
}
