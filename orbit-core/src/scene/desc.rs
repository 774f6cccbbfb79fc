//! The resolved scene: every regex matched, every model loaded and merged, every default filled.
//! This is what a physics backend builds from.

use glam::{Mat3, Vec3};
use regex::Regex;

use super::articulation::resolve_articulation;
use super::cfg::{AssetSource, RigidObjectCfg, SceneCfg};
use super::model::{ArticulationModel, Geometry, Inertial, RigidBodyModel, Shape};
use crate::math::Pose;

/// A pose plus linear and angular velocity of a body origin (world axes).
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct RootState {
    /// Pose relative to the env origin.
    pub pose: Pose,
    /// Linear velocity.
    pub lin_vel: Vec3,
    /// Angular velocity.
    pub ang_vel: Vec3,
}

/// Drive parameters of one degree of freedom.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct JointDrive {
    /// Position gain.
    pub stiffness: f32,
    /// Velocity gain.
    pub damping: f32,
    /// Maximum drive effort (`f32::INFINITY` if unlimited); also clips applied efforts.
    pub effort_limit: f32,
    /// Maximum joint speed (`f32::INFINITY` if unlimited).
    pub velocity_limit: f32,
}

impl Default for JointDrive {
    fn default() -> Self {
        Self {
            stiffness: 0.0,
            damping: 0.0,
            effort_limit: f32::INFINITY,
            velocity_limit: f32::INFINITY,
        }
    }
}

/// A resolved articulation.
#[derive(Clone, Debug, PartialEq)]
pub struct ArticulationDesc {
    /// Entity name.
    pub name: String,
    /// Model with fixed joints merged (only movable joints below the root).
    pub model: ArticulationModel,
    /// Root pose relative to the env origin (the default one, for a floating base).
    pub root_pose: Pose,
    /// Whether the root is welded to the world; otherwise it is a floating base.
    pub fixed_base: bool,
    /// Default root linear velocity of a floating base (world axes, of the root link's origin).
    pub root_lin_vel: Vec3,
    /// Default root angular velocity of a floating base (world axes).
    pub root_ang_vel: Vec3,
    /// Default joint positions (dof order).
    pub default_joint_pos: Vec<f32>,
    /// Default joint velocities (dof order).
    pub default_joint_vel: Vec<f32>,
    /// Drive of each dof.
    pub drives: Vec<JointDrive>,
    /// Whether non-adjacent links collide with each other.
    pub self_collisions: bool,
}

impl ArticulationDesc {
    /// Number of degrees of freedom.
    pub fn num_dofs(&self) -> usize {
        self.default_joint_pos.len()
    }

    /// The root state a floating base starts in (a fixed base's pose, at rest).
    pub fn default_root_state(&self) -> RootState {
        RootState {
            pose: self.root_pose,
            lin_vel: self.root_lin_vel,
            ang_vel: self.root_ang_vel,
        }
    }
}

/// A resolved free rigid object.
#[derive(Clone, Debug, PartialEq)]
pub struct RigidObjectDesc {
    /// Entity name.
    pub name: String,
    /// Body model (mass properties and shapes).
    pub body: RigidBodyModel,
    /// Initial root state.
    pub default_root_state: RootState,
}

/// A resolved static fixture.
#[derive(Clone, Debug, PartialEq)]
pub struct StaticObjectDesc {
    /// Entity name.
    pub name: String,
    /// Pose relative to the env origin.
    pub pose: Pose,
    /// Shapes (mass is ignored).
    pub body: RigidBodyModel,
}

/// A fully resolved scene.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct SceneDesc {
    /// Grid spacing of env origins.
    pub env_spacing: f32,
    /// Articulations.
    pub articulations: Vec<ArticulationDesc>,
    /// Free rigid objects.
    pub rigid_objects: Vec<RigidObjectDesc>,
    /// Static fixtures.
    pub static_objects: Vec<StaticObjectDesc>,
}

/// Errors while resolving a scene config.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    /// A joint-name regex does not compile.
    #[error("{field}: `{pattern}` is not a valid regex: {message}")]
    BadRegex {
        /// Config field path.
        field: String,
        /// The pattern.
        pattern: String,
        /// Regex error.
        message: String,
    },
    /// A joint- or body-name regex matches nothing.
    #[error("{field}: `{pattern}` matches no {kind} of `{entity}`; its {kind}s are {names:?}")]
    NoMatch {
        /// Config field path.
        field: String,
        /// The pattern.
        pattern: String,
        /// What was searched (`joint`, `body`).
        kind: &'static str,
        /// Entity name.
        entity: String,
        /// The names available.
        names: Vec<String>,
    },
    /// A joint is matched twice within one mapping.
    #[error("{field}: joint `{joint}` of `{entity}` is matched by more than one entry")]
    Ambiguous {
        /// Config field path.
        field: String,
        /// The joint.
        joint: String,
        /// Entity name.
        entity: String,
    },
    /// The model could not be loaded or is invalid.
    #[error("{field}: {message}")]
    Asset {
        /// Config field path.
        field: String,
        /// What went wrong.
        message: String,
    },
    /// Two entities share a name, or a value is out of range.
    #[error("{field}: {message}")]
    Invalid {
        /// Config field path.
        field: String,
        /// What is expected.
        message: String,
    },
}

impl SceneError {
    /// The config field path the error is about.
    pub fn field(&self) -> &str {
        match self {
            SceneError::BadRegex { field, .. }
            | SceneError::NoMatch { field, .. }
            | SceneError::Ambiguous { field, .. }
            | SceneError::Asset { field, .. }
            | SceneError::Invalid { field, .. } => field,
        }
    }
}

/// Loads an articulation model from its source (URDF import lives in `orbit-assets`).
pub type ModelLoader<'a> = dyn Fn(&AssetSource) -> Result<ArticulationModel, String> + 'a;

/// Compiles a full-match regex.
fn full_regex(field: &str, pattern: &str) -> Result<Regex, SceneError> {
    Regex::new(&format!("^(?:{pattern})$")).map_err(|e| SceneError::BadRegex {
        field: field.to_string(),
        pattern: pattern.to_string(),
        message: e.to_string(),
    })
}

/// Resolves joint-name patterns: indices of the joints each pattern selects, in joint order.
/// Every pattern must match at least one joint.
pub fn match_joints(
    field: &str,
    entity: &str,
    joints: &[String],
    patterns: &[String],
) -> Result<Vec<usize>, SceneError> {
    match_names(field, entity, "joint", joints, patterns)
}

/// Resolves name patterns (full-match regexes) against `names` of a `kind` (`joint`, `body`):
/// sorted, deduplicated indices. Every pattern must match at least one name.
pub fn match_names(
    field: &str,
    entity: &str,
    kind: &'static str,
    names: &[String],
    patterns: &[String],
) -> Result<Vec<usize>, SceneError> {
    let mut selected = Vec::new();
    for pattern in patterns {
        let re = full_regex(field, pattern)?;
        let hits: Vec<usize> = (0..names.len())
            .filter(|&i| re.is_match(&names[i]))
            .collect();
        if hits.is_empty() {
            return Err(SceneError::NoMatch {
                field: field.to_string(),
                pattern: pattern.clone(),
                kind,
                entity: entity.to_string(),
                names: names.to_vec(),
            });
        }
        selected.extend(hits);
    }
    selected.sort_unstable();
    selected.dedup();
    Ok(selected)
}

impl SceneCfg {
    /// Resolves the config: loads models, merges fixed joints, matches regexes, fills defaults.
    pub fn resolve(&self, load: &ModelLoader<'_>) -> Result<SceneDesc, SceneError> {
        if !(self.env_spacing.is_finite() && self.env_spacing >= 0.0) {
            return Err(SceneError::Invalid {
                field: "scene.env_spacing".into(),
                message: format!("expected a finite distance >= 0, got {}", self.env_spacing),
            });
        }
        let mut names = std::collections::HashSet::new();
        let all_names = self
            .articulations
            .iter()
            .map(|a| a.name.as_str())
            .chain(self.rigid_objects.iter().map(|o| o.name.as_str()))
            .chain(self.static_objects.iter().map(|s| s.name.as_str()));
        for name in all_names {
            if !names.insert(name) {
                return Err(SceneError::Invalid {
                    field: "scene".into(),
                    message: format!("two entities are named `{name}`; names must be unique"),
                });
            }
        }
        let articulations = self
            .articulations
            .iter()
            .enumerate()
            .map(|(i, a)| resolve_articulation(&format!("scene.articulations[{i}]"), a, load))
            .collect::<Result<_, _>>()?;
        let rigid_objects = self
            .rigid_objects
            .iter()
            .enumerate()
            .map(|(i, o)| resolve_rigid_object(&format!("scene.rigid_objects[{i}]"), o))
            .collect::<Result<_, _>>()?;
        let static_objects = self
            .static_objects
            .iter()
            .enumerate()
            .map(|(i, s)| {
                check_materials(&format!("scene.static_objects[{i}].shapes"), &s.shapes)?;
                for shape in &s.shapes {
                    shape
                        .geometry
                        .validate()
                        .map_err(|message| SceneError::Invalid {
                            field: format!("scene.static_objects[{i}].shapes"),
                            message,
                        })?;
                }
                Ok(StaticObjectDesc {
                    name: s.name.clone(),
                    pose: s.pose,
                    body: RigidBodyModel {
                        name: s.name.clone(),
                        inertial: Inertial::ZERO,
                        shapes: s.shapes.clone(),
                    },
                })
            })
            .collect::<Result<_, SceneError>>()?;
        Ok(SceneDesc {
            env_spacing: self.env_spacing,
            articulations,
            rigid_objects,
            static_objects,
        })
    }
}

fn resolve_rigid_object(field: &str, cfg: &RigidObjectCfg) -> Result<RigidObjectDesc, SceneError> {
    let invalid = |sub: &str, message: String| SceneError::Invalid {
        field: format!("{field}.{sub}"),
        message,
    };
    if cfg.shapes.is_empty() {
        return Err(invalid(
            "shapes",
            "a rigid object needs at least one shape".into(),
        ));
    }
    check_materials(&format!("{field}.shapes"), &cfg.shapes)?;
    if let Some((i, m)) = cfg
        .shape_masses
        .iter()
        .enumerate()
        .find(|(_, m)| !(m.is_finite() && **m > 0.0))
    {
        return Err(invalid(
            &format!("shape_masses[{i}]"),
            format!("must be a positive mass in kg, got {m}"),
        ));
    }
    for s in &cfg.shapes {
        s.geometry.validate().map_err(|m| invalid("shapes", m))?;
        if s.geometry == Geometry::Plane {
            return Err(invalid(
                "shapes",
                "planes are only allowed on static objects".into(),
            ));
        }
    }
    let inertial = match (&cfg.inertial, cfg.shape_masses.len()) {
        (Some(i), _) => *i,
        (None, n) if n == cfg.shapes.len() => cfg
            .shapes
            .iter()
            .zip(&cfg.shape_masses)
            .map(|(s, &m)| solid_inertial(&s.geometry, m).transformed(&s.pose))
            .fold(Inertial::ZERO, |acc, i| acc.combine(&i)),
        (None, n) => {
            return Err(invalid(
                "shape_masses",
                format!(
                    "give `inertial`, or one mass per shape ({} shapes, {n} masses)",
                    cfg.shapes.len()
                ),
            ));
        }
    };
    inertial.validate().map_err(|m| invalid("inertial", m))?;
    if inertial.mass <= 0.0 {
        return Err(invalid(
            "inertial",
            "a free rigid object needs a positive mass".into(),
        ));
    }
    Ok(RigidObjectDesc {
        name: cfg.name.clone(),
        body: RigidBodyModel {
            name: cfg.name.clone(),
            inertial,
            shapes: cfg.shapes.clone(),
        },
        default_root_state: RootState {
            pose: Pose::new(cfg.init_state.pos, cfg.init_state.rot),
            lin_vel: cfg.init_state.lin_vel,
            ang_vel: cfg.init_state.ang_vel,
        },
    })
}

/// Rejects a negative or non-finite friction coefficient, or a restitution outside [0, 1].
fn check_materials(field: &str, shapes: &[Shape]) -> Result<(), SceneError> {
    for (i, s) in shapes.iter().enumerate() {
        let m = &s.material;
        if !(m.friction.is_finite() && m.friction >= 0.0) {
            return Err(SceneError::Invalid {
                field: format!("{field}[{i}].material.friction"),
                message: format!("must be 0 or more, got {}", m.friction),
            });
        }
        if !(0.0..=1.0).contains(&m.restitution) {
            return Err(SceneError::Invalid {
                field: format!("{field}[{i}].material.restitution"),
                message: format!("must be in [0, 1], got {}", m.restitution),
            });
        }
    }
    Ok(())
}

/// Mass properties of a uniform solid of the given geometry and mass, in the shape frame.
pub fn solid_inertial(geometry: &Geometry, mass: f32) -> Inertial {
    let diag = match *geometry {
        Geometry::Sphere { radius } => Vec3::splat(0.4 * mass * radius * radius),
        Geometry::Box { half_extents: h } => {
            let s = h * h;
            Vec3::new(s.y + s.z, s.x + s.z, s.x + s.y) * (mass / 3.0)
        }
        Geometry::Cylinder {
            radius,
            half_length,
        } => {
            let ixx = mass * (3.0 * radius * radius + 4.0 * half_length * half_length) / 12.0;
            Vec3::new(ixx, ixx, 0.5 * mass * radius * radius)
        }
        Geometry::Capsule {
            radius,
            half_length,
        } => {
            // Cylinder plus two hemispheres, masses split by volume.
            let (r, h) = (radius, half_length);
            let v_cyl = std::f32::consts::PI * r * r * 2.0 * h;
            let v_sph = 4.0 / 3.0 * std::f32::consts::PI * r * r * r;
            let m_cyl = mass * v_cyl / (v_cyl + v_sph);
            let m_sph = mass - m_cyl;
            let izz = 0.5 * m_cyl * r * r + 0.4 * m_sph * r * r;
            let ixx = m_cyl * (3.0 * r * r + 4.0 * h * h) / 12.0
                + m_sph * (0.4 * r * r + h * h + 0.75 * h * r);
            Vec3::new(ixx, ixx, izz)
        }
        Geometry::Plane => Vec3::ZERO,
    };
    Inertial {
        mass,
        com: Vec3::ZERO,
        inertia: Mat3::from_diagonal(diag),
    }
}

/// Env origins on Isaac Lab's square clone grid (centred on the world origin).
pub fn grid_env_origins(num_envs: usize, spacing: f32) -> Vec<Vec3> {
    if num_envs == 0 {
        return Vec::new();
    }
    let per_side = (num_envs as f64).sqrt().floor().max(1.0);
    let rows = (num_envs as f64 / per_side).ceil() as usize;
    let cols = num_envs.div_ceil(rows);
    (0..num_envs)
        .map(|i| {
            let (r, c) = (i / cols, i % cols);
            Vec3::new(
                -(r as f32 - (rows as f32 - 1.0) / 2.0) * spacing,
                (c as f32 - (cols as f32 - 1.0) / 2.0) * spacing,
                0.0,
            )
        })
        .collect()
}
