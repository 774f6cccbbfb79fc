//! The physics state of the envs as it was before a step, kept on request
//! (`sim.keep_pre_step_state`) so that a step that breaks the physics can be reported with the
//! state it began from, and that state written back into an env to replay the step.

use std::collections::BTreeMap;

use glam::{Quat, Vec3};
use serde::{Deserialize, Serialize};

use super::{PhysicsBackend, PhysicsError};
use crate::math::Pose;
use crate::scene::{RootState, RootStateCfg};

/// One env's physics state: what the `write_*` calls of [`PhysicsBackend`] need to restore it.
/// Contact impulses that warm-start a solver are not part of it: an env written from it starts
/// its next step's solver cold.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EnvState {
    /// Each articulation's state, by scene name.
    pub articulations: BTreeMap<String, ArticulationState>,
    /// Each free rigid object's pose and velocities (of the body origin), by scene name.
    pub rigid_objects: BTreeMap<String, RootStateCfg>,
}

/// One articulation's state in one env.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ArticulationState {
    /// A floating base's root link: pose and velocities of its origin; `None` for a fixed
    /// base.
    pub root: Option<RootStateCfg>,
    /// Joint positions, in the articulation's joint order.
    pub joint_pos: Vec<f32>,
    /// Joint velocities, in the articulation's joint order.
    pub joint_vel: Vec<f32>,
}

/// Positions, orientations and velocities of one body per env.
#[derive(Default)]
struct BodyStates {
    pos: Vec<Vec3>,
    quat: Vec<Quat>,
    lin_vel: Vec<Vec3>,
    ang_vel: Vec<Vec3>,
}

impl BodyStates {
    /// Copies each env's first body from arrays of `stride` bodies per env.
    fn copy(&mut self, stride: usize, states: [&[Vec3]; 3], quat: &[Quat]) {
        let pick = |values: &[Vec3], out: &mut Vec<Vec3>| {
            out.clear();
            out.extend(values.iter().step_by(stride));
        };
        pick(states[0], &mut self.pos);
        pick(states[1], &mut self.lin_vel);
        pick(states[2], &mut self.ang_vel);
        self.quat.clear();
        self.quat.extend(quat.iter().step_by(stride));
    }

    fn state(&self, e: usize) -> RootStateCfg {
        RootStateCfg {
            pos: self.pos[e],
            rot: self.quat[e],
            lin_vel: self.lin_vel[e],
            ang_vel: self.ang_vel[e],
        }
    }
}

/// One articulation's states in every env.
#[derive(Default)]
struct ArticulationStates {
    joint_pos: Vec<f32>,
    joint_vel: Vec<f32>,
    root: Option<BodyStates>,
}

/// Every env's physics state at one moment, copied out of a backend. Capturing again reuses
/// the buffers, so keeping the state before every step allocates nothing after the first.
#[derive(Default)]
pub struct StateSnapshot {
    articulations: Vec<ArticulationStates>,
    rigid_objects: Vec<BodyStates>,
}

impl StateSnapshot {
    /// Copies the backend's current joint states, floating roots and free objects.
    pub fn capture(&mut self, backend: &dyn PhysicsBackend) {
        let layout = backend.layout();
        self.articulations
            .resize_with(layout.articulations.len(), Default::default);
        for (a, (art, states)) in layout
            .articulations
            .iter()
            .zip(&mut self.articulations)
            .enumerate()
        {
            let view = backend.articulation(a);
            states.joint_pos.clear();
            states.joint_pos.extend_from_slice(view.joint_pos);
            states.joint_vel.clear();
            states.joint_vel.extend_from_slice(view.joint_vel);
            if art.fixed_base {
                states.root = None;
            } else {
                let bodies = [view.link_pos, view.link_lin_vel, view.link_ang_vel];
                let root = states.root.get_or_insert_with(Default::default);
                root.copy(view.num_links, bodies, view.link_quat);
            }
        }
        self.rigid_objects
            .resize_with(layout.rigid_objects.len(), Default::default);
        for (o, states) in self.rigid_objects.iter_mut().enumerate() {
            let view = backend.rigid_object(o);
            states.copy(1, [view.pos, view.lin_vel, view.ang_vel], view.quat);
        }
    }

    /// Env `e`'s state as captured, named after `backend`'s scene (the backend it was
    /// captured from).
    pub fn env_state(&self, backend: &dyn PhysicsBackend, e: usize) -> EnvState {
        let layout = backend.layout();
        let articulations = layout
            .articulations
            .iter()
            .zip(&self.articulations)
            .map(|(art, states)| {
                let n = art.num_dofs();
                let state = ArticulationState {
                    root: states.root.as_ref().map(|root| root.state(e)),
                    joint_pos: states.joint_pos[e * n..(e + 1) * n].to_vec(),
                    joint_vel: states.joint_vel[e * n..(e + 1) * n].to_vec(),
                };
                (art.name.clone(), state)
            })
            .collect();
        let rigid_objects = layout
            .rigid_objects
            .iter()
            .zip(&self.rigid_objects)
            .map(|(name, states)| (name.clone(), states.state(e)))
            .collect();
        EnvState {
            articulations,
            rigid_objects,
        }
    }
}

impl EnvState {
    /// Writes this state into env `e` of `backend`, whose scene must have the same entities
    /// and joints.
    pub fn write(&self, backend: &mut dyn PhysicsBackend, e: usize) -> Result<(), PhysicsError> {
        for (name, state) in &self.articulations {
            let layout = backend.layout();
            let a = layout.articulation(name)?;
            let dofs = layout.articulations[a].num_dofs();
            if state.joint_pos.len() != dofs || state.joint_vel.len() != dofs {
                return Err(PhysicsError::InvalidInput(format!(
                    "the state of articulation `{name}` has {} joint positions and {} \
                     velocities; the scene's has {dofs} joints",
                    state.joint_pos.len(),
                    state.joint_vel.len()
                )));
            }
            if let Some(root) = &state.root {
                backend.write_articulation_root_state(a, &[e], &[root_state(root)])?;
            }
            backend.write_joint_state(a, &[e], &state.joint_pos, &state.joint_vel)?;
        }
        for (name, state) in &self.rigid_objects {
            let o = backend.layout().rigid_object(name)?;
            backend.write_root_state(o, &[e], &[root_state(state)])?;
        }
        Ok(())
    }
}

fn root_state(cfg: &RootStateCfg) -> RootState {
    RootState {
        pose: Pose::new(cfg.pos, cfg.rot),
        lin_vel: cfg.lin_vel,
        ang_vel: cfg.ang_vel,
    }
}
