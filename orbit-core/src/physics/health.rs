//! A check that a backend's state is still physical after a step: no NaN or infinity, and no
//! value far beyond anything a robot-learning scene reaches. A step that breaks this (a time
//! step too long for the stiffness, too few solver iterations) is reported as a physics
//! failure, before its NaNs reach rewards and the learner.

use glam::Vec3;

use super::PhysicsBackend;

/// Joint positions beyond this magnitude (rad or m) mean the state blew up.
pub const MAX_JOINT_POSITION: f32 = 1.0e4;
/// Joint speeds beyond this (rad/s or m/s) mean the state blew up.
pub const MAX_JOINT_VELOCITY: f32 = 1.0e4;
/// Object (and floating-base link) positions farther than this from the env origin, per axis
/// (m).
pub const MAX_OBJECT_POSITION: f32 = 1.0e3;
/// Object speeds beyond this, per axis (m/s).
pub const MAX_OBJECT_LINEAR_VELOCITY: f32 = 1.0e3;
/// Object angular speeds beyond this, per axis (rad/s).
pub const MAX_OBJECT_ANGULAR_VELOCITY: f32 = 1.0e4;

/// The first quantity found beyond its limit.
#[derive(Clone, Debug, PartialEq)]
pub struct Instability {
    /// What was out of range, e.g. "joint velocity `panda_joint4` of articulation `robot`".
    pub quantity: String,
    /// The first env holding such a value.
    pub env: usize,
    /// Its value (NaN, infinite or beyond `limit`).
    pub value: f32,
    /// The limit of the quantity.
    pub limit: f32,
    /// Envs whose value of this quantity is out of range.
    pub envs_affected: usize,
    /// All envs.
    pub num_envs: usize,
}

impl std::fmt::Display for Instability {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{} is {} in env {} (allowed: magnitude at most {:e}; {} of {} envs out of range)",
            self.quantity, self.value, self.env, self.limit, self.envs_affected, self.num_envs
        )
    }
}

/// The first out-of-range quantity in `backend`'s joint states, floating bases' link states
/// and free-object states, if any. Scans on every core; finds the same one whatever the
/// number of threads. A fixed-base articulation's link poses are not scanned: they follow
/// from its joint states.
pub fn check_state(backend: &dyn PhysicsBackend) -> Option<Instability> {
    let layout = backend.layout();
    let num_envs = backend.num_envs();
    for (a, art) in layout.articulations.iter().enumerate() {
        let view = backend.articulation(a);
        for (values, what, limit) in [
            (view.joint_pos, "joint position", MAX_JOINT_POSITION),
            (view.joint_vel, "joint velocity", MAX_JOINT_VELOCITY),
        ] {
            let found = scan(values, art.joint_names.len(), limit, num_envs, |column| {
                let joint = &art.joint_names[column];
                format!("{what} of joint `{joint}` of articulation `{}`", art.name)
            });
            if found.is_some() {
                return found;
            }
        }
        if !art.fixed_base {
            // A floating base's root state is not a joint state: scan the links' poses and
            // velocities (the root's and, following it, every other link's).
            let states = [view.link_pos, view.link_lin_vel, view.link_ang_vel];
            let found = scan_bodies(states, art.link_names.len(), num_envs, |what, l, axis| {
                let link = &art.link_names[l];
                format!(
                    "{what} ({axis}) of link `{link}` of articulation `{}`",
                    art.name
                )
            });
            if found.is_some() {
                return found;
            }
        }
    }
    for (o, name) in layout.rigid_objects.iter().enumerate() {
        let view = backend.rigid_object(o);
        let states = [view.pos, view.lin_vel, view.ang_vel];
        let found = scan_bodies(states, 1, num_envs, |what, _, axis| {
            format!("{what} ({axis}) of object `{name}`")
        });
        if found.is_some() {
            return found;
        }
    }
    None
}

/// Env `e`'s articulation states, one line per joint and per floating base's root, to log
/// with an [`Instability`]: which joints sit at a limit and how the base moves tell a stiff
/// contact from a drive that is too strong.
pub fn describe_env_state(backend: &dyn PhysicsBackend, e: usize) -> String {
    use std::fmt::Write;
    let layout = backend.layout();
    let mut out = format!("state of env {e} after the step:");
    for (a, art) in layout.articulations.iter().enumerate() {
        let view = backend.articulation(a);
        let n = art.joint_names.len();
        if !art.fixed_base {
            let root = e * view.num_links;
            let q = view.link_quat[root];
            write!(
                out,
                "\n  `{}` root: position {:?}, orientation (x, y, z, w) {:?}, linear velocity \
                 {:?}, angular velocity {:?}",
                art.name,
                view.link_pos[root].to_array(),
                q.to_array(),
                view.link_lin_vel[root].to_array(),
                view.link_ang_vel[root].to_array()
            )
            .expect("write to a string");
        }
        for (j, joint) in art.joint_names.iter().enumerate() {
            let i = e * n + j;
            write!(
                out,
                "\n  `{}` joint `{joint}`: position {}, velocity {}, applied effort {}",
                art.name, view.joint_pos[i], view.joint_vel[i], view.applied_effort[i]
            )
            .expect("write to a string");
        }
    }
    out
}

/// The first out-of-range position, linear or angular velocity (`[pos, lin_vel, ang_vel]`,
/// each `num_envs × bodies`) of bodies held to the free-object limits, named by
/// `describe(quantity, body, axis)`.
fn scan_bodies(
    states: [&[Vec3]; 3],
    bodies: usize,
    num_envs: usize,
    describe: impl Fn(&str, usize, &str) -> String,
) -> Option<Instability> {
    let limits = [
        ("position", MAX_OBJECT_POSITION),
        ("linear velocity", MAX_OBJECT_LINEAR_VELOCITY),
        ("angular velocity", MAX_OBJECT_ANGULAR_VELOCITY),
    ];
    for (values, (what, limit)) in states.into_iter().zip(limits) {
        let flat: &[f32] = bytemuck::cast_slice::<Vec3, f32>(values);
        let found = scan(flat, 3 * bodies, limit, num_envs, |column| {
            describe(what, column / 3, ["x", "y", "z"][column % 3])
        });
        if found.is_some() {
            return found;
        }
    }
    None
}

/// The first value of `values` (`num_envs` rows of `dim`) beyond `limit`, as an
/// [`Instability`] whose quantity `describe` names from the value's column.
fn scan(
    values: &[f32],
    dim: usize,
    limit: f32,
    num_envs: usize,
    describe: impl FnOnce(usize) -> String,
) -> Option<Instability> {
    let i = crate::parallel::first_beyond(values, limit)?;
    let envs_affected = values
        .chunks(dim)
        .filter(|row| crate::parallel::first_beyond(row, limit).is_some())
        .count();
    Some(Instability {
        quantity: describe(i % dim),
        env: i / dim,
        value: values[i],
        limit,
        envs_affected,
        num_envs,
    })
}
