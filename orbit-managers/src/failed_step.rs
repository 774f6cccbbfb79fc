//! A step that broke the physics, as the env logs it when it keeps the state from before each
//! step (`sim.keep_pre_step_state`): the failing env's actions and the state it began from,
//! as RON that the `replay_step` example reads.

use orbit_core::physics::EnvState;
use serde::{Deserialize, Serialize};

/// One env's failing step: enough to replay it in a one-env copy of the task.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FailedStep {
    /// Env steps since the env was built, the failing one included.
    pub step: u64,
    /// The env's index in its batch.
    pub env: usize,
    /// The env's action of the step, as the policy gave it (before the action terms).
    pub action: Vec<f32>,
    /// The env's physics state before the step.
    pub state: EnvState,
}

impl FailedStep {
    /// One line of RON (floats written to round-trip exactly).
    pub fn to_ron(&self) -> String {
        ron::to_string(self).expect("a failed step serialises")
    }

    /// Reads what [`Self::to_ron`] wrote.
    pub fn from_ron(text: &str) -> Result<Self, String> {
        ron::from_str(text.trim()).map_err(|e| format!("not a failed step's RON: {e}"))
    }
}

#[cfg(test)]
mod tests {
    use std::collections::BTreeMap;

    use glam::{Quat, Vec3};
    use orbit_core::physics::ArticulationState;
    use orbit_core::scene::RootStateCfg;

    use super::*;

    /// The RON of a failed step reads back to the bit: floats that need all of f32's digits,
    /// a negative zero and a subnormal included.
    #[test]
    fn a_failed_step_round_trips_through_ron_exactly() {
        let root = RootStateCfg {
            pos: Vec3::new(83.123_46, -0.1, 1.0 / 3.0),
            rot: Quat::from_xyzw(0.0, 0.0, 1.0, 0.0),
            lin_vel: Vec3::new(-0.0, 1.0e-38, 7.0e3),
            ang_vel: Vec3::new(f32::MIN_POSITIVE, -99.999_99, 0.3),
        };
        let articulation = ArticulationState {
            root: Some(root.clone()),
            joint_pos: vec![0.1, -2.0 / 3.0, 1.0e-7],
            joint_vel: vec![100.0, -100.0, 2.718_281_7e-3],
        };
        let failed = FailedStep {
            step: 15_423,
            env: 1147,
            action: vec![0.25, -1.7, 12.345_679],
            state: EnvState {
                articulations: BTreeMap::from([("robot".to_string(), articulation)]),
                rigid_objects: BTreeMap::from([("box".to_string(), root)]),
            },
        };
        let text = failed.to_ron();
        let back = FailedStep::from_ron(&text).expect("reads back");
        assert_eq!(back, failed, "{text}");
        let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        let lin = back.state.rigid_objects["box"].lin_vel.to_array();
        assert_eq!(
            bits(&lin),
            bits(&[-0.0, 1.0e-38, 7.0e3]),
            "signs and subnormals"
        );
        assert!(FailedStep::from_ron("(step: 1)").is_err());
    }
}
