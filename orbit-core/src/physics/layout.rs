//! Names and sizes of what a backend simulates, for looking entities up by name.

use super::PhysicsError;
use crate::scene::{ArticulationModel, SceneDesc};

/// Layout of one articulation.
#[derive(Clone, Debug, PartialEq)]
pub struct ArticulationLayout {
    /// Entity name.
    pub name: String,
    /// Movable joint names in dof order.
    pub joint_names: Vec<String>,
    /// Link names (after merging fixed joints).
    pub link_names: Vec<String>,
    /// The simulated model (fixed joints merged), for frames and kinematics.
    pub model: ArticulationModel,
    /// Whether the root link is welded to the world (else link 0 is a floating base).
    pub fixed_base: bool,
}

impl ArticulationLayout {
    /// Number of degrees of freedom.
    pub fn num_dofs(&self) -> usize {
        self.joint_names.len()
    }
    /// Number of links.
    pub fn num_links(&self) -> usize {
        self.link_names.len()
    }
    /// Index of a link by name.
    pub fn link(&self, name: &str) -> Result<usize, PhysicsError> {
        self.link_names
            .iter()
            .position(|n| n == name)
            .ok_or_else(|| PhysicsError::UnknownEntity {
                kind: "link",
                name: name.to_string(),
                available: self.link_names.clone(),
            })
    }
}

/// Layout of a whole scene.
#[derive(Clone, Debug, PartialEq)]
pub struct SceneLayout {
    /// Articulations in config order.
    pub articulations: Vec<ArticulationLayout>,
    /// Rigid-object names in config order.
    pub rigid_objects: Vec<String>,
}

impl SceneLayout {
    /// The layout of a resolved scene.
    pub fn from_desc(desc: &SceneDesc) -> Self {
        Self {
            articulations: desc
                .articulations
                .iter()
                .map(|a| ArticulationLayout {
                    name: a.name.clone(),
                    joint_names: a.model.joint_names(),
                    link_names: a.model.links.iter().map(|l| l.name.clone()).collect(),
                    model: a.model.clone(),
                    fixed_base: a.fixed_base,
                })
                .collect(),
            rigid_objects: desc.rigid_objects.iter().map(|o| o.name.clone()).collect(),
        }
    }

    /// Index of an articulation by name.
    pub fn articulation(&self, name: &str) -> Result<usize, PhysicsError> {
        self.articulations
            .iter()
            .position(|a| a.name == name)
            .ok_or_else(|| PhysicsError::UnknownEntity {
                kind: "articulation",
                name: name.to_string(),
                available: self.articulations.iter().map(|a| a.name.clone()).collect(),
            })
    }

    /// Index of a rigid object by name.
    pub fn rigid_object(&self, name: &str) -> Result<usize, PhysicsError> {
        self.rigid_objects
            .iter()
            .position(|o| o == name)
            .ok_or_else(|| PhysicsError::UnknownEntity {
                kind: "rigid object",
                name: name.to_string(),
                available: self.rigid_objects.clone(),
            })
    }
}
