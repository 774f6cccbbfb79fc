//! The black-box wrapper's config (RON, e.g. `tasks/box_pushing/config/black_box/promp.ron`):
//! the movement primitive, the tracking controller, the context and replanning.

use orbit_mp::{ProDmpCfg, ProMpCfg};
use serde::{Deserialize, Serialize};

/// A black-box env's settings (RON, e.g. `tasks/box_pushing/config/black_box/promp.ron`).
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct BlackBoxCfg {
    /// The movement primitive. Its `num_dof`, `dt` and `num_steps` default to the env's action
    /// dimension, step and episode length.
    pub trajectory: TrajectoryCfg,
    /// How desired joint positions and velocities become the env's actions.
    pub controller: ControllerCfg,
    /// Index ranges `[start, end)` of the env's `policy` observation that form the context
    /// (Fancy Gym's `context_mask`); default: the whole observation.
    #[serde(default)]
    pub context: Option<Vec<(usize, usize)>>,
    /// Replan during the episode (Fancy Gym's `ReplanMPWrapper`); requires a ProDMP.
    #[serde(default)]
    pub replanning: Option<ReplanCfg>,
}

/// The movement primitive of a black-box env.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub enum TrajectoryCfg {
    /// A ProMP (Paraschos et al. 2013).
    ProMp(ProMpCfg),
    /// A ProDMP (Li et al. 2023).
    ProDmp(ProDmpCfg),
}

/// The tracking controller of a black-box env.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub enum ControllerCfg {
    /// Fancy Gym's PD law on the measured joint state, used as the env's action:
    /// `a = clip(Kp ∘ (q_d − q) + Kd ∘ (q̇_d − q̇), clip)`. On the torque env (`10·a + bias`)
    /// this is Fancy Gym's controller.
    Pd {
        /// Kp, one per action value.
        p_gains: Vec<f32>,
        /// Kd, one per action value.
        d_gains: Vec<f32>,
        /// Range of the action (the env's action bounds).
        #[serde(default = "unit_range")]
        clip: (f32, f32),
    },
    /// The desired positions as joint position targets of the env's `joint_position` action
    /// terms (inverting their `scale` and offset), tracked by the implicit PD drives: Orbit's
    /// way.
    JointPosition,
}

fn unit_range() -> (f32, f32) {
    (-1.0, 1.0)
}

/// When to replan (Fancy Gym: every 25 steps, at most 4 plans, conditioned on the desired
/// state).
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ReplanCfg {
    /// Env steps per segment.
    pub interval: u32,
    /// Plans per episode; the last runs to the episode's end.
    pub max_plans: u32,
    /// Start a new plan from the previous plan's desired state (else the measured one).
    #[serde(default)]
    pub condition_on_desired: bool,
}
