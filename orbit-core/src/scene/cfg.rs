//! Declarative scene configuration, mirroring Isaac Lab's `InteractiveSceneCfg`,
//! `ArticulationCfg` (+ `ImplicitActuatorCfg`), `RigidObjectCfg` and `AssetBaseCfg`.
//! Deserialised from RON; resolved into a [`SceneDesc`](super::SceneDesc) by [`SceneCfg::resolve`].

use std::collections::BTreeMap;

use glam::{Quat, Vec3};
use serde::{Deserialize, Serialize};

use super::model::{ArticulationModel, Inertial, Shape};

/// A scene: the entities cloned into every environment.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SceneCfg {
    /// Distance between neighbouring env origins on the clone grid (metres).
    #[serde(default = "default_spacing")]
    pub env_spacing: f32,
    /// Articulated assets (robots).
    #[serde(default)]
    pub articulations: Vec<ArticulationCfg>,
    /// Free rigid objects.
    #[serde(default)]
    pub rigid_objects: Vec<RigidObjectCfg>,
    /// Static fixtures (tables, ground planes, mounts).
    #[serde(default)]
    pub static_objects: Vec<StaticObjectCfg>,
}

fn default_spacing() -> f32 {
    2.5
}

/// Where an articulation's model comes from.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum AssetSource {
    /// A URDF file: a bundled asset name or a path relative to the config file.
    Urdf {
        /// File name or path.
        path: String,
        /// Leave `mesh` collision shapes out (with a warning) instead of refusing the file:
        /// orbit-rs collides primitives only.
        #[serde(default)]
        skip_mesh_collisions: bool,
    },
    /// An MJCF file (MuJoCo's XML): a bundled asset name or a path relative to the config
    /// file. Its top-level body is the root link, placed by `init_state` (the body's own
    /// position in the file is not used); the world body's shapes (a ground plane) are left
    /// out: a scene adds its ground as a static object.
    Mjcf {
        /// File name or path.
        path: String,
    },
    /// A model written out in the config itself.
    Model(ArticulationModel),
}

/// An articulated asset (Isaac Lab `ArticulationCfg`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ArticulationCfg {
    /// Entity name used by terms (`"robot"`).
    pub name: String,
    /// Model source.
    pub spawn: AssetSource,
    /// Initial root pose and joint state.
    #[serde(default)]
    pub init_state: ArticulationInitState,
    /// Actuator groups by name; each selects joints by regex.
    #[serde(default)]
    pub actuators: BTreeMap<String, ActuatorCfg>,
    /// Whether links of this articulation collide with each other (parent–child pairs never do).
    #[serde(default)]
    pub self_collisions: bool,
    /// Whether the root link is welded to the world (Isaac Lab `fix_root_link`); `false` gives
    /// the root six free degrees of freedom (a floating base: legged robots, the Ant).
    #[serde(default = "yes")]
    pub fixed_base: bool,
}

fn yes() -> bool {
    true
}

/// Initial state of an articulation; joint values are given per joint-name regex.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ArticulationInitState {
    /// Root position relative to the env origin.
    #[serde(default)]
    pub pos: Vec3,
    /// Root orientation `(w, x, y, z)`.
    #[serde(default = "identity", with = "crate::math::wxyz")]
    pub rot: Quat,
    /// Joint positions by regex (unmatched joints start at 0).
    #[serde(default)]
    pub joint_pos: BTreeMap<String, f32>,
    /// Joint velocities by regex (unmatched joints start at 0).
    #[serde(default)]
    pub joint_vel: BTreeMap<String, f32>,
    /// Root linear velocity (world axes) of a floating base.
    #[serde(default)]
    pub lin_vel: Vec3,
    /// Root angular velocity (world axes) of a floating base.
    #[serde(default)]
    pub ang_vel: Vec3,
}

impl Default for ArticulationInitState {
    fn default() -> Self {
        Self {
            pos: Vec3::ZERO,
            rot: Quat::IDENTITY,
            joint_pos: BTreeMap::new(),
            joint_vel: BTreeMap::new(),
            lin_vel: Vec3::ZERO,
            ang_vel: Vec3::ZERO,
        }
    }
}

fn identity() -> Quat {
    Quat::IDENTITY
}

/// A value for all selected joints or per joint-name regex.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum PerJoint {
    /// The same value for every selected joint.
    All(f32),
    /// Values by joint-name regex.
    ByName(BTreeMap<String, f32>),
}

/// An implicit actuator group (Isaac Lab `ImplicitActuatorCfg`): the physics engine applies
/// `τ = k (q* − q) + d (q̇* − q̇) + τ_ff`, integrated implicitly, clipped to the effort limit.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ActuatorCfg {
    /// Regexes selecting the joints (full match).
    pub joint_names_expr: Vec<String>,
    /// Position gain `k` (N·m/rad).
    pub stiffness: PerJoint,
    /// Velocity gain `d` (N·m·s/rad).
    pub damping: PerJoint,
    /// Maximum drive effort; defaults to the asset's limit, else unlimited.
    #[serde(default)]
    pub effort_limit: Option<PerJoint>,
    /// Maximum joint speed enforced by the engine; unlimited unless given (the asset's declared
    /// velocity limit is informational, as in Isaac Lab 1.0's implicit actuators).
    #[serde(default)]
    pub velocity_limit: Option<PerJoint>,
    /// Armature override.
    #[serde(default)]
    pub armature: Option<PerJoint>,
    /// Joint friction override.
    #[serde(default)]
    pub friction: Option<PerJoint>,
}

/// A free rigid object (Isaac Lab `RigidObjectCfg`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RigidObjectCfg {
    /// Entity name (`"object"`, `"box"`).
    pub name: String,
    /// Collision shapes in the body frame.
    pub shapes: Vec<Shape>,
    /// Mass properties; if absent, computed from `shape_masses`.
    #[serde(default)]
    pub inertial: Option<Inertial>,
    /// Per-shape masses (same order as `shapes`) used when `inertial` is absent; each shape is
    /// treated as a uniform solid.
    #[serde(default)]
    pub shape_masses: Vec<f32>,
    /// Initial root state relative to the env origin.
    #[serde(default)]
    pub init_state: RootStateCfg,
}

/// A root state: pose and velocities (Isaac Lab's 13-value `default_root_state`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RootStateCfg {
    /// Position relative to the env origin.
    #[serde(default)]
    pub pos: Vec3,
    /// Orientation `(w, x, y, z)`.
    #[serde(default = "identity", with = "crate::math::wxyz")]
    pub rot: Quat,
    /// Linear velocity of the body origin (world axes).
    #[serde(default)]
    pub lin_vel: Vec3,
    /// Angular velocity (world axes).
    #[serde(default)]
    pub ang_vel: Vec3,
}

impl Default for RootStateCfg {
    fn default() -> Self {
        Self {
            pos: Vec3::ZERO,
            rot: Quat::IDENTITY,
            lin_vel: Vec3::ZERO,
            ang_vel: Vec3::ZERO,
        }
    }
}

/// A static fixture (Isaac Lab `AssetBaseCfg` with a collision spawner).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StaticObjectCfg {
    /// Entity name.
    pub name: String,
    /// Pose relative to the env origin.
    #[serde(default)]
    pub pose: crate::math::Pose,
    /// Collision shapes in the object frame.
    pub shapes: Vec<Shape>,
}
