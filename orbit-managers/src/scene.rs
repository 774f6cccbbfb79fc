//! The simulated scene as terms see it: the physics backend plus the resolved scene (names,
//! defaults), with name lookups that fail with clear errors.

use glam::Vec3;
use orbit_core::physics::PhysicsBackend;
use orbit_core::scene::{SceneDesc, grid_env_origins, match_names};

use crate::error::EnvError;

/// The backend and the resolved scene it was built from.
pub struct Scene {
    /// The physics backend (batched state of all envs).
    pub backend: Box<dyn PhysicsBackend>,
    /// The resolved scene (defaults, models, drives).
    pub desc: SceneDesc,
    /// Env origins on Isaac Lab's clone grid (the backend works in env-local frames).
    pub env_origins: Vec<Vec3>,
}

impl Scene {
    /// Wraps a backend built from `desc`.
    pub fn new(backend: Box<dyn PhysicsBackend>, desc: SceneDesc) -> Self {
        let env_origins = grid_env_origins(backend.num_envs(), desc.env_spacing);
        Self {
            backend,
            desc,
            env_origins,
        }
    }

    /// Number of envs.
    pub fn num_envs(&self) -> usize {
        self.backend.num_envs()
    }

    /// Index of an articulation by name, as a term error.
    pub fn articulation(&self, field: &str, name: &str) -> Result<usize, EnvError> {
        self.backend
            .layout()
            .articulation(name)
            .map_err(|e| EnvError::InvalidTerm {
                field: field.to_string(),
                message: e.to_string(),
            })
    }

    /// Index of a rigid object by name, as a term error.
    pub fn rigid_object(&self, field: &str, name: &str) -> Result<usize, EnvError> {
        self.backend
            .layout()
            .rigid_object(name)
            .map_err(|e| EnvError::InvalidTerm {
                field: field.to_string(),
                message: e.to_string(),
            })
    }

    /// Dof indices of an articulation's joints selected by regexes (full match, asset order);
    /// every pattern must match.
    pub fn joints(
        &self,
        field: &str,
        articulation: usize,
        patterns: &[String],
    ) -> Result<Vec<usize>, EnvError> {
        let layout = &self.backend.layout().articulations[articulation];
        select(field, &layout.name, "joint", &layout.joint_names, patterns)
    }

    /// Link indices of an articulation selected by regexes (full match, link order); every
    /// pattern must match.
    pub fn bodies(
        &self,
        field: &str,
        articulation: usize,
        patterns: &[String],
    ) -> Result<Vec<usize>, EnvError> {
        let layout = &self.backend.layout().articulations[articulation];
        select(field, &layout.name, "body", &layout.link_names, patterns)
    }

    /// `(link, offset)` of a named frame or link of an articulation.
    pub fn frame(
        &self,
        field: &str,
        articulation: usize,
        name: &str,
    ) -> Result<(usize, orbit_core::math::Pose), EnvError> {
        let layout = &self.backend.layout().articulations[articulation];
        layout
            .model
            .find_frame(name)
            .ok_or_else(|| EnvError::InvalidTerm {
                field: field.to_string(),
                message: format!(
                    "`{}` has no link or frame named `{name}`; links: {:?}",
                    layout.name, layout.link_names
                ),
            })
    }
}

/// [`match_names`] as a term error.
fn select(
    field: &str,
    entity: &str,
    kind: &'static str,
    names: &[String],
    patterns: &[String],
) -> Result<Vec<usize>, EnvError> {
    match_names(field, entity, kind, names, patterns).map_err(|e| EnvError::InvalidTerm {
        field: field.to_string(),
        message: e.to_string(),
    })
}
