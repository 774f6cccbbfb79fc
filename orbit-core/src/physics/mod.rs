//! The physics-backend contract: a backend builds `num_envs` copies of a resolved scene and
//! steps them together. State is published as batched arrays, one row per env (structure of
//! arrays: one array per quantity). All poses are relative to each env's own origin.

mod contact;
mod health;
mod layout;
mod memory;
mod registry;
mod snapshot;

use glam::{Quat, Vec3};
use serde::{Deserialize, Serialize};

pub use contact::{ContactCfg, ContactModel};
pub use health::*;
pub use layout::*;
pub use memory::*;
pub use registry::*;
pub use snapshot::*;

use crate::scene::RootState;

/// Simulation settings (Isaac Lab `SimulationCfg`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SimCfg {
    /// Physics time step in seconds.
    #[serde(default = "default_dt")]
    pub dt: f32,
    /// Gravity vector (m/s²).
    #[serde(default = "default_gravity")]
    pub gravity: Vec3,
    /// Velocity-solver iterations per step (0 = the backend's own default: 4 for rapier; for
    /// wgpu 12 sweeps with MuJoCo's contacts, 4 with the soft step).
    #[serde(default)]
    pub solver_iterations: usize,
    /// Name of the physics backend (`"rapier"`, `"wgpu"`), or `"auto"`: a GPU if there is one,
    /// else Mesa's lavapipe, else rapier.
    #[serde(default = "default_backend")]
    pub backend: String,
    /// Worker threads for CPU backends (0 = one per core).
    #[serde(default)]
    pub num_threads: usize,
    /// Contact softness in MuJoCo's terms (the wgpu backend; rapier keeps its own).
    #[serde(default)]
    pub contact: ContactCfg,
    /// Keep every env's state from before each step (a copy of the joint states, floating
    /// roots and objects per step), so that a step that breaks the physics is reported with
    /// the state it began from, ready to replay (the `replay_step` example).
    #[serde(default)]
    pub keep_pre_step_state: bool,
}

fn default_dt() -> f32 {
    0.002
}
fn default_gravity() -> Vec3 {
    Vec3::new(0.0, 0.0, -9.81)
}
fn default_backend() -> String {
    AUTO_BACKEND.to_string()
}

impl Default for SimCfg {
    fn default() -> Self {
        Self {
            dt: default_dt(),
            gravity: default_gravity(),
            solver_iterations: 0,
            backend: default_backend(),
            num_threads: 0,
            contact: ContactCfg::default(),
            keep_pre_step_state: false,
        }
    }
}

impl SimCfg {
    /// Checks the values are usable.
    pub fn validate(&self) -> Result<(), PhysicsError> {
        if !(self.dt.is_finite() && self.dt > 0.0) {
            return Err(PhysicsError::InvalidInput(format!(
                "sim.dt must be a positive number of seconds, got {}",
                self.dt
            )));
        }
        if self.num_threads > MAX_THREADS {
            return Err(PhysicsError::InvalidInput(format!(
                "sim.num_threads must be 0 (one per core) or at most {MAX_THREADS}, got {}",
                self.num_threads
            )));
        }
        if !self.gravity.is_finite() {
            return Err(PhysicsError::InvalidInput(format!(
                "sim.gravity must be finite, got {:?}",
                self.gravity
            )));
        }
        self.contact.validate()
    }

    /// The solver iterations to run: `solver_iterations`, or the backend's `default` when it
    /// is 0.
    pub fn iterations_or(&self, default: usize) -> usize {
        if self.solver_iterations == 0 {
            default
        } else {
            self.solver_iterations
        }
    }
}

/// The most worker threads `SimCfg::num_threads` may ask for: more only waits on spawning.
pub const MAX_THREADS: usize = 1024;

/// Errors reported by physics backends.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum PhysicsError {
    /// No backend of that name is registered.
    #[error("unknown physics backend `{name}`; registered backends: {available:?}")]
    UnknownBackend {
        /// Requested name.
        name: String,
        /// Registered names.
        available: Vec<String>,
    },
    /// The scene cannot be represented by this backend.
    #[error("the `{backend}` backend cannot build this scene: {reason}")]
    Unsupported {
        /// Backend name.
        backend: String,
        /// What is unsupported.
        reason: String,
    },
    /// An entity name or id that does not exist.
    #[error("no {kind} named `{name}`; available: {available:?}")]
    UnknownEntity {
        /// "articulation", "rigid object", "body", …
        kind: &'static str,
        /// Requested name.
        name: String,
        /// Known names.
        available: Vec<String>,
    },
    /// Wrong buffer length, env id out of range, non-finite values.
    #[error("invalid input: {0}")]
    InvalidInput(String),
}

/// Batched state of one articulation: each slice holds `num_envs` rows.
#[derive(Clone, Copy, Debug)]
pub struct ArticulationView<'a> {
    /// Links per env (row length of the link arrays).
    pub num_links: usize,
    /// Joint positions, `num_envs × num_dofs`.
    pub joint_pos: &'a [f32],
    /// Joint velocities, `num_envs × num_dofs`.
    pub joint_vel: &'a [f32],
    /// Generalized bias forces (gravity + Coriolis/centrifugal), `num_envs × num_dofs`: the
    /// joint efforts that hold the current velocity with zero acceleration (MuJoCo `qfrc_bias`).
    pub bias_forces: &'a [f32],
    /// Efforts applied by the drives and the effort input in the last step, `num_envs × num_dofs`.
    pub applied_effort: &'a [f32],
    /// Link origin positions, `num_envs × num_links`.
    pub link_pos: &'a [Vec3],
    /// Link orientations, `num_envs × num_links`.
    pub link_quat: &'a [Quat],
    /// Link origin linear velocities (world axes), `num_envs × num_links`.
    pub link_lin_vel: &'a [Vec3],
    /// Link angular velocities (world axes), `num_envs × num_links`.
    pub link_ang_vel: &'a [Vec3],
}

impl ArticulationView<'_> {
    /// Pose of link `link` in env `e`.
    pub fn link_pose(&self, e: usize, link: usize) -> crate::math::Pose {
        let i = e * self.num_links + link;
        crate::math::Pose::new(self.link_pos[i], self.link_quat[i])
    }

    /// Pose of a frame rigidly attached to `link` at `offset`, in env `e`.
    pub fn frame_pose(
        &self,
        e: usize,
        link: usize,
        offset: &crate::math::Pose,
    ) -> crate::math::Pose {
        self.link_pose(e, link).mul_pose(offset)
    }
}

/// Batched state of one free rigid object: one entry per env.
#[derive(Clone, Copy, Debug)]
pub struct RigidObjectView<'a> {
    /// Body origin positions.
    pub pos: &'a [Vec3],
    /// Orientations.
    pub quat: &'a [Quat],
    /// Body origin linear velocities (world axes).
    pub lin_vel: &'a [Vec3],
    /// Angular velocities (world axes).
    pub ang_vel: &'a [Vec3],
}

/// A body whose physical parameters can be randomised per env.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BodyRef {
    /// Link `link` of articulation `articulation`.
    Link {
        /// Articulation index in the layout.
        articulation: usize,
        /// Link index.
        link: usize,
    },
    /// A free rigid object.
    RigidObject(usize),
}

/// A physics engine simulating `num_envs` independent copies of one scene.
///
/// Writes take full batches (`num_envs` rows) or rows for a set of env ids; reads return
/// borrowed batched arrays refreshed by every [`step`](PhysicsBackend::step) and every state
/// write. Invalid input returns an error and changes nothing.
pub trait PhysicsBackend: Send + Sync {
    /// The registered backend name.
    fn name(&self) -> &'static str;
    /// Number of environments.
    fn num_envs(&self) -> usize;
    /// Names and sizes of the simulated entities.
    fn layout(&self) -> &SceneLayout;
    /// The physics time step.
    fn dt(&self) -> f32;

    /// Advances every env by one time step.
    fn step(&mut self) -> Result<(), PhysicsError>;

    /// Bytes of accelerator memory the backend holds for its buffers (0 for CPU backends).
    fn device_memory_bytes(&self) -> usize {
        0
    }

    /// Makes the views show the last step's state now. A backend that runs its steps
    /// asynchronously (the GPU backend reads its state back only when it is looked at) waits
    /// here; the views would do the same on first use, so calling this only decides where the
    /// wait is spent (the env counts it as physics time). CPU backends have nothing to do.
    fn sync(&self) {}

    /// Accelerator time the last step (or `step_n`) spent in its kernels, where the backend
    /// measures it (`None` for CPU backends and devices without timestamp queries).
    fn last_kernel_time(&self) -> Option<std::time::Duration> {
        None
    }

    /// Advances every env by `n` time steps with the current inputs: an env step's decimation
    /// loop when no input changes in between (a GPU backend runs them in one dispatch, with one
    /// readback).
    fn step_n(&mut self, n: usize) -> Result<(), PhysicsError> {
        for _ in 0..n {
            self.step()?;
        }
        Ok(())
    }

    /// Batched state of articulation `a`.
    fn articulation(&self, a: usize) -> ArticulationView<'_>;
    /// Batched state of rigid object `o`.
    fn rigid_object(&self, o: usize) -> RigidObjectView<'_>;

    /// Sets the drives' position targets, `num_envs × num_dofs`.
    fn set_joint_position_targets(&mut self, a: usize, targets: &[f32])
    -> Result<(), PhysicsError>;
    /// Sets the drives' velocity targets, `num_envs × num_dofs`.
    fn set_joint_velocity_targets(&mut self, a: usize, targets: &[f32])
    -> Result<(), PhysicsError>;
    /// Sets feed-forward joint efforts held until changed, `num_envs × num_dofs`. The sum with
    /// the drive effort, evaluated on the state at the start of a step, is kept within each
    /// joint's effort limit (an implicit drive's effort at the end of the step can differ by its
    /// implicit correction).
    fn set_joint_efforts(&mut self, a: usize, efforts: &[f32]) -> Result<(), PhysicsError>;
    /// For the listed dofs of articulation `a` (all envs): whether every time step adds the bias
    /// forces of its starting state to the effort input, before the effort limit (gravity and
    /// Coriolis compensation as Fancy Gym's torque controller does, without a round trip
    /// through the caller between steps). Other dofs keep their setting (initially off).
    fn set_bias_compensation(
        &mut self,
        a: usize,
        dofs: &[usize],
        enabled: bool,
    ) -> Result<(), PhysicsError>;
    /// Overwrites joint positions and velocities of the listed envs (`env_ids.len() × num_dofs`
    /// each) and zeroes their targets' effect history.
    fn write_joint_state(
        &mut self,
        a: usize,
        env_ids: &[usize],
        pos: &[f32],
        vel: &[f32],
    ) -> Result<(), PhysicsError>;
    /// Overwrites the root state (pose, and velocity of the root link's origin) of
    /// floating-base articulation `a` in the listed envs; the joint state is kept. A fixed base
    /// is an error.
    fn write_articulation_root_state(
        &mut self,
        a: usize,
        env_ids: &[usize],
        states: &[RootState],
    ) -> Result<(), PhysicsError>;
    /// Overwrites the root state of a rigid object in the listed envs.
    fn write_root_state(
        &mut self,
        o: usize,
        env_ids: &[usize],
        states: &[RootState],
    ) -> Result<(), PhysicsError>;
    /// Sets the mass of a body in the listed envs, scaling its inertia with it.
    fn set_masses(
        &mut self,
        body: BodyRef,
        env_ids: &[usize],
        masses: &[f32],
    ) -> Result<(), PhysicsError>;
    /// Sets the friction coefficient of every shape of a body in the listed envs.
    fn set_friction(
        &mut self,
        body: BodyRef,
        env_ids: &[usize],
        friction: &[f32],
    ) -> Result<(), PhysicsError>;
}

/// Checks a batch buffer has `rows × cols` finite values.
pub fn check_batch(
    what: &str,
    values: &[f32],
    rows: usize,
    cols: usize,
) -> Result<(), PhysicsError> {
    if values.len() != rows * cols {
        return Err(PhysicsError::InvalidInput(format!(
            "{what}: expected {rows} × {cols} = {} values, got {}",
            rows * cols,
            values.len()
        )));
    }
    if let Some(i) = crate::parallel::first_non_finite(values) {
        return Err(PhysicsError::InvalidInput(format!(
            "{what}: value {} at row {} column {} is not finite",
            values[i],
            i / cols.max(1),
            i % cols.max(1)
        )));
    }
    Ok(())
}

/// Checks a batch of per-env parameters (`count` finite values) obeys `rule` (e.g. masses
/// `> 0`), naming the first value that does not.
pub fn check_values(
    what: &str,
    values: &[f32],
    count: usize,
    rule: &str,
    ok: impl Fn(f32) -> bool,
) -> Result<(), PhysicsError> {
    check_batch(what, values, count, 1)?;
    match values.iter().find(|&&v| !ok(v)) {
        Some(v) => Err(PhysicsError::InvalidInput(format!(
            "{what} must be {rule}, got {v}"
        ))),
        None => Ok(()),
    }
}

/// Checks `count` root states (one per env id): finite, with unit quaternions.
pub fn check_root_states(states: &[RootState], count: usize) -> Result<(), PhysicsError> {
    if states.len() != count {
        return Err(PhysicsError::InvalidInput(format!(
            "root states: expected {count} states (one per env id), got {}",
            states.len()
        )));
    }
    for s in states {
        let finite = s.pose.pos.is_finite()
            && s.pose.rot.is_finite()
            && s.lin_vel.is_finite()
            && s.ang_vel.is_finite();
        if !finite || (s.pose.rot.length() - 1.0).abs() > 1e-3 {
            return Err(PhysicsError::InvalidInput(format!(
                "root state {s:?} must be finite with a unit quaternion"
            )));
        }
    }
    Ok(())
}

/// Checks articulation `a` of `layout` (an index already checked) has a floating base, whose
/// root state can be written.
pub fn check_floating_base(layout: &SceneLayout, a: usize) -> Result<(), PhysicsError> {
    let art = &layout.articulations[a];
    if art.fixed_base {
        return Err(PhysicsError::InvalidInput(format!(
            "articulation `{}` has a fixed base, whose root state cannot be written; set \
             `fixed_base: false` in its config to make it a floating base",
            art.name
        )));
    }
    Ok(())
}

/// Checks dof indices of an articulation with `num_dofs` dofs are in range.
pub fn check_dof_ids(dofs: &[usize], num_dofs: usize) -> Result<(), PhysicsError> {
    match dofs.iter().find(|&&d| d >= num_dofs) {
        Some(d) => Err(PhysicsError::InvalidInput(format!(
            "dof {d} is out of range ({num_dofs} dofs)"
        ))),
        None => Ok(()),
    }
}

/// Checks env ids are in range and unique.
pub fn check_env_ids(env_ids: &[usize], num_envs: usize) -> Result<(), PhysicsError> {
    let mut seen = vec![false; num_envs];
    for &e in env_ids {
        if e >= num_envs {
            return Err(PhysicsError::InvalidInput(format!(
                "env id {e} is out of range (num_envs = {num_envs})"
            )));
        }
        if std::mem::replace(&mut seen[e], true) {
            return Err(PhysicsError::InvalidInput(format!(
                "env id {e} is listed twice"
            )));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A thread count no machine needs is refused before any thread is spawned.
    #[test]
    fn too_many_threads_are_refused() {
        let ok = SimCfg {
            num_threads: MAX_THREADS,
            ..SimCfg::default()
        };
        assert!(ok.validate().is_ok());
        let sim = SimCfg {
            num_threads: 100_000,
            ..SimCfg::default()
        };
        let message = sim.validate().unwrap_err().to_string();
        assert!(
            message.contains("sim.num_threads") && message.contains("100000"),
            "{message}"
        );
    }
}
