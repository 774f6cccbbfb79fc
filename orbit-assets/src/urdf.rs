//! URDF import: parses with urdf-rs, checks the document and converts it into an
//! [`ArticulationModel`].
//!
//! Conventions (from the URDF specification):
//! - `<origin xyz rpy>`: rpy are fixed-axis roll, pitch, yaw:
//!   `R = Rz(yaw) · Ry(pitch) · Rx(roll)`.
//! - `<inertial>`: mass, the inertial frame's origin (its `xyz` is the centre of mass) and the
//!   inertia tensor about the centre of mass in the inertial frame's axes. The importer rotates
//!   the tensor into the link frame (`R I Rᵀ`).
//! - Joint types: `revolute` and `prismatic` (limited), `continuous` (a revolute joint without
//!   position limits), `fixed`. `floating`, `planar` and `spherical` are rejected.
//! - Collision geometry: `box`, `sphere`, `cylinder` and `capsule` become primitive shapes with
//!   the default [`Material`] (URDF has no standard friction). A `mesh` collision is an error,
//!   never silently approximated or dropped; with [`UrdfOptions::skip_mesh_collisions`] (an
//!   asset config's `skip_mesh_collisions: true`) it is left out with a warning.
//!
//! Extension: URDF cannot express collision filtering, so the importer also reads
//! `<orbit_collision_filter link="NAME" groups="G" mask="M"/>` elements (children of `<robot>`,
//! numbers decimal or `0x` hexadecimal) and gives every collision shape of that link the
//! [`CollisionFilter`] `{groups: G, mask: M}`. Other URDF readers ignore the element.

use std::collections::{HashMap, HashSet};
use std::path::Path;

use glam::{DMat3, DQuat, DVec3};
use orbit_core::math::Pose;
use orbit_core::scene::{
    ArticulationModel, CollisionFilter, Geometry, Inertial, Joint, JointKind, Link, Material, Shape,
};

use crate::error::AssetError;

mod collision_filter;

use collision_filter::read_collision_filters;

/// Choices of the URDF import.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct UrdfOptions {
    /// Leave `mesh` collision shapes out (with a warning) instead of refusing the file: the
    /// link then has no collision there.
    pub skip_mesh_collisions: bool,
}

/// Reads a URDF file and imports it (see [`model_from_urdf_str`]). Errors name the file path.
pub fn model_from_urdf_file(path: &Path) -> Result<ArticulationModel, AssetError> {
    model_from_urdf_file_with(path, UrdfOptions::default())
}

/// [`model_from_urdf_file`] with import options.
pub fn model_from_urdf_file_with(
    path: &Path,
    options: UrdfOptions,
) -> Result<ArticulationModel, AssetError> {
    let file = path.display().to_string();
    let text = std::fs::read_to_string(path).map_err(|source| AssetError::Io {
        file: file.clone(),
        source,
    })?;
    model_from_urdf_str_with(&text, &file, options)
}

/// Imports a URDF document. `source_name` (a path or an asset name) is used in error messages
/// and as the model name when the `<robot>` has none.
///
/// Links are returned parent-before-child (depth-first from the single root link, children in
/// file order). Links attached by fixed joints stay ordinary links; use
/// [`ArticulationModel::merge_fixed_joints`] to fold them into named frames. The result passes
/// [`ArticulationModel::validate`].
pub fn model_from_urdf_str(text: &str, source_name: &str) -> Result<ArticulationModel, AssetError> {
    model_from_urdf_str_with(text, source_name, UrdfOptions::default())
}

/// [`model_from_urdf_str`] with import options.
pub fn model_from_urdf_str_with(
    text: &str,
    source_name: &str,
    options: UrdfOptions,
) -> Result<ArticulationModel, AssetError> {
    let robot = urdf_rs::read_from_string(text).map_err(|e| AssetError::Parse {
        file: source_name.to_string(),
        message: e.to_string(),
    })?;
    let filters = read_collision_filters(text, source_name)?;
    Importer {
        file: source_name,
        robot: &robot,
        options,
    }
    .build(&filters)
}

/// Rotation of URDF fixed-axis roll-pitch-yaw angles: `Rz(yaw) · Ry(pitch) · Rx(roll)`.
pub(crate) fn rpy_to_quat(rpy: [f64; 3]) -> DQuat {
    DQuat::from_rotation_z(rpy[2]) * DQuat::from_rotation_y(rpy[1]) * DQuat::from_rotation_x(rpy[0])
}

struct Importer<'a> {
    file: &'a str,
    robot: &'a urdf_rs::Robot,
    options: UrdfOptions,
}

impl Importer<'_> {
    fn invalid(&self, element: impl Into<String>, problem: impl Into<String>) -> AssetError {
        AssetError::InvalidValue {
            file: self.file.to_string(),
            element: element.into(),
            problem: problem.into(),
        }
    }

    fn build(
        &self,
        filters: &HashMap<String, CollisionFilter>,
    ) -> Result<ArticulationModel, AssetError> {
        let file = self.file.to_string();
        let robot = self.robot;
        let (order, parent_joint) = self.topology()?;

        for name in filters.keys() {
            if !robot.links.iter().any(|l| &l.name == name) {
                return Err(self.invalid(
                    "<orbit_collision_filter>",
                    format!("link `{name}` is not defined"),
                ));
            }
        }

        // Old link index → index in the sorted model.
        let mut new_index = vec![usize::MAX; robot.links.len()];
        for (new, &old) in order.iter().enumerate() {
            new_index[old] = new;
        }
        let link_index: HashMap<&str, usize> = robot
            .links
            .iter()
            .enumerate()
            .map(|(i, l)| (l.name.as_str(), i))
            .collect();

        let mut links = Vec::with_capacity(order.len());
        for &old in &order {
            let ul = &robot.links[old];
            let filter = filters.get(&ul.name).copied().unwrap_or_default();
            let (parent, joint) = match parent_joint[old] {
                Some(j) => {
                    let uj = &robot.joints[j];
                    let parent = new_index[link_index[uj.parent.link.as_str()]];
                    (Some(parent), Some(self.joint(uj)?))
                }
                None => (None, None),
            };
            links.push(Link {
                name: ul.name.clone(),
                parent,
                joint,
                inertial: self.inertial(ul)?,
                shapes: self.shapes(ul, filter)?,
                frames: Vec::new(),
            });
        }
        let model = ArticulationModel {
            name: if robot.name.is_empty() {
                file.clone()
            } else {
                robot.name.clone()
            },
            links,
        };
        model
            .validate()
            .map_err(|source| AssetError::Model { file, source })?;
        Ok(model)
    }

    /// Checks names and the tree; returns the link order (old indices, parent before child) and
    /// the parent joint of each link.
    #[allow(clippy::type_complexity)]
    fn topology(&self) -> Result<(Vec<usize>, Vec<Option<usize>>), AssetError> {
        let file = || self.file.to_string();
        let robot = self.robot;
        let n = robot.links.len();
        if n == 0 {
            return Err(AssetError::NoLinks { file: file() });
        }
        let mut link_index: HashMap<&str, usize> = HashMap::new();
        for (i, l) in robot.links.iter().enumerate() {
            if link_index.insert(l.name.as_str(), i).is_some() {
                return Err(AssetError::DuplicateName {
                    file: file(),
                    kind: "link",
                    name: l.name.clone(),
                });
            }
        }
        let mut joint_names = HashSet::new();
        for j in &robot.joints {
            if !joint_names.insert(j.name.as_str()) {
                return Err(AssetError::DuplicateName {
                    file: file(),
                    kind: "joint",
                    name: j.name.clone(),
                });
            }
        }
        let mut parent_joint: Vec<Option<usize>> = vec![None; n];
        let mut child_joints: Vec<Vec<usize>> = vec![Vec::new(); n];
        for (ji, j) in robot.joints.iter().enumerate() {
            let lookup = |role: &'static str, name: &str| {
                link_index
                    .get(name)
                    .copied()
                    .ok_or_else(|| AssetError::MissingLink {
                        file: file(),
                        joint: j.name.clone(),
                        role,
                        link: name.to_string(),
                    })
            };
            let p = lookup("parent", &j.parent.link)?;
            let c = lookup("child", &j.child.link)?;
            if let Some(prev) = parent_joint[c] {
                return Err(AssetError::TwoParents {
                    file: file(),
                    link: j.child.link.clone(),
                    first: robot.joints[prev].name.clone(),
                    second: j.name.clone(),
                });
            }
            parent_joint[c] = Some(ji);
            child_joints[p].push(ji);
        }
        let parent_link =
            |l: usize| parent_joint[l].map(|j| link_index[robot.joints[j].parent.link.as_str()]);
        // Follows parents from `start` until a link repeats; returns that cycle.
        let cycle_from = |start: usize| {
            let mut path = vec![start];
            let mut cur = start;
            while let Some(p) = parent_link(cur) {
                if let Some(pos) = path.iter().position(|&l| l == p) {
                    let mut cycle: Vec<String> = path[pos..]
                        .iter()
                        .map(|&l| robot.links[l].name.clone())
                        .collect();
                    cycle.reverse();
                    return cycle;
                }
                path.push(p);
                cur = p;
            }
            Vec::new()
        };
        let roots: Vec<usize> = (0..n).filter(|&l| parent_joint[l].is_none()).collect();
        let root = match roots.as_slice() {
            [] => {
                return Err(AssetError::Cycle {
                    file: file(),
                    links: cycle_from(0),
                });
            }
            [root] => *root,
            _ => {
                return Err(AssetError::SeveralRoots {
                    file: file(),
                    roots: roots.iter().map(|&l| robot.links[l].name.clone()).collect(),
                });
            }
        };
        // Depth-first from the root, children in file order.
        let mut order = Vec::with_capacity(n);
        let mut visited = vec![false; n];
        let mut stack = vec![root];
        while let Some(l) = stack.pop() {
            visited[l] = true;
            order.push(l);
            for &j in child_joints[l].iter().rev() {
                stack.push(link_index[robot.joints[j].child.link.as_str()]);
            }
        }
        if let Some(unreached) = (0..n).find(|&l| !visited[l]) {
            // Every link has one parent and only `root` has none, so an unreachable link hangs
            // below a cycle.
            return Err(AssetError::Cycle {
                file: file(),
                links: cycle_from(unreached),
            });
        }
        Ok((order, parent_joint))
    }

    fn pose(&self, origin: &urdf_rs::Pose, element: &str) -> Result<Pose, AssetError> {
        let (xyz, rpy) = (origin.xyz.0, origin.rpy.0);
        if !xyz.iter().chain(rpy.iter()).all(|v| v.is_finite()) {
            return Err(self.invalid(
                element,
                format!("origin xyz {xyz:?} rpy {rpy:?} must be finite numbers"),
            ));
        }
        Ok(Pose::new(
            DVec3::from(xyz).as_vec3(),
            rpy_to_quat(rpy).normalize().as_quat(),
        ))
    }

    fn joint(&self, uj: &urdf_rs::Joint) -> Result<Joint, AssetError> {
        use urdf_rs::JointType;
        let element = format!("joint `{}`", uj.name);
        let origin = self.pose(&uj.origin, &element)?;
        let (kind, limited) = match uj.joint_type {
            JointType::Revolute => (JointKind::Revolute, true),
            JointType::Continuous => (JointKind::Revolute, false),
            JointType::Prismatic => (JointKind::Prismatic, true),
            JointType::Fixed => (JointKind::Fixed, false),
            JointType::Floating | JointType::Planar | JointType::Spherical => {
                return Err(AssetError::UnsupportedJoint {
                    file: self.file.to_string(),
                    joint: uj.name.clone(),
                    kind: format!("{:?}", uj.joint_type).to_lowercase(),
                });
            }
        };
        let mut joint = Joint::fixed(uj.name.clone(), origin);
        if kind == JointKind::Fixed {
            return Ok(joint);
        }
        joint.kind = kind;
        let axis = DVec3::from(uj.axis.xyz.0);
        let length = axis.length();
        if !(length.is_finite() && length > 1e-9) {
            return Err(AssetError::ZeroAxis {
                file: self.file.to_string(),
                joint: uj.name.clone(),
                axis: uj.axis.xyz.0,
            });
        }
        joint.axis = (axis / length).as_vec3();

        let limit = &uj.limit;
        if limited {
            if *limit == urdf_rs::JointLimit::default() {
                return Err(self.invalid(
                    element,
                    "a revolute or prismatic joint needs `<limit lower=... upper=... effort=... \
                     velocity=...>`; use type `continuous` for an unlimited revolute joint",
                ));
            }
            let (lo, hi) = (limit.lower, limit.upper);
            if lo.is_nan() || hi.is_nan() {
                return Err(self.invalid(element, format!("limits [{lo}, {hi}] must be numbers")));
            }
            if lo > hi {
                return Err(AssetError::InvalidLimits {
                    file: self.file.to_string(),
                    joint: uj.name.clone(),
                    lower: lo,
                    upper: hi,
                });
            }
            // URDF 1.2 writes an omitted bound as ±inf: keep it as the largest f32.
            let clamp = |v: f64| v.clamp(f32::MIN as f64, f32::MAX as f64) as f32;
            joint.limits = (lo.is_finite() || hi.is_finite()).then(|| [clamp(lo), clamp(hi)]);
        }
        for (name, value) in [("effort", limit.effort), ("velocity", limit.velocity)] {
            if value.is_nan() || value < 0.0 {
                return Err(self.invalid(element, format!("limit {name} {value} must be >= 0")));
            }
        }
        let positive = |v: f64| (v.is_finite() && v > 0.0).then_some(v as f32);
        joint.effort_limit = positive(limit.effort);
        joint.velocity_limit = positive(limit.velocity);
        if let Some(d) = &uj.dynamics {
            for (name, value) in [("damping", d.damping), ("friction", d.friction)] {
                if !(value.is_finite() && value >= 0.0) {
                    return Err(self.invalid(
                        element,
                        format!("dynamics {name} {value} must be finite and >= 0"),
                    ));
                }
            }
            joint.damping = d.damping as f32;
            joint.friction = d.friction as f32;
        }
        if let Some(m) = &uj.mimic {
            tracing::warn!(
                "{}: joint `{}` mimics `{}`; mimic constraints are not supported and are ignored \
                 (the joint moves independently)",
                self.file,
                uj.name,
                m.joint
            );
        }
        Ok(joint)
    }

    fn inertial(&self, ul: &urdf_rs::Link) -> Result<Inertial, AssetError> {
        let bad = |problem: String| AssetError::InvalidInertial {
            file: self.file.to_string(),
            link: ul.name.clone(),
            problem,
        };
        let u = &ul.inertial;
        let mass = u.mass.value;
        if !(mass.is_finite() && mass >= 0.0) {
            return Err(bad(format!(
                "mass {mass} must be finite and >= 0 (`<mass value=...>`)"
            )));
        }
        let i = &u.inertia;
        let entries = [
            ("ixx", i.ixx),
            ("ixy", i.ixy),
            ("ixz", i.ixz),
            ("iyy", i.iyy),
            ("iyz", i.iyz),
            ("izz", i.izz),
        ];
        for (name, v) in entries {
            if !v.is_finite() {
                return Err(bad(format!(
                    "inertia `{name}` is {v}; inertia entries must be finite"
                )));
            }
        }
        if i.ixx < 0.0 || i.iyy < 0.0 || i.izz < 0.0 {
            return Err(bad(format!(
                "inertia diagonal (ixx, iyy, izz) = ({}, {}, {}) must be >= 0",
                i.ixx, i.iyy, i.izz
            )));
        }
        let (xyz, rpy) = (u.origin.xyz.0, u.origin.rpy.0);
        if !xyz.iter().chain(rpy.iter()).all(|v| v.is_finite()) {
            return Err(bad(format!(
                "inertial origin xyz {xyz:?} rpy {rpy:?} must be finite numbers"
            )));
        }
        if mass > 0.0
            && (i.ixx + i.iyy < i.izz * (1.0 - 1e-6)
                || i.iyy + i.izz < i.ixx * (1.0 - 1e-6)
                || i.ixx + i.izz < i.iyy * (1.0 - 1e-6))
        {
            tracing::warn!(
                "{}: link `{}`: inertia diagonal ({}, {}, {}) violates the triangle inequality; \
                 no rigid body has this inertia",
                self.file,
                ul.name,
                i.ixx,
                i.iyy,
                i.izz
            );
        }
        let tensor = DMat3::from_cols_array(&[
            i.ixx, i.ixy, i.ixz, i.ixy, i.iyy, i.iyz, i.ixz, i.iyz, i.izz,
        ]);
        let r = DMat3::from_quat(rpy_to_quat(rpy));
        Ok(Inertial {
            mass: mass as f32,
            com: DVec3::from(xyz).as_vec3(),
            inertia: (r * tensor * r.transpose()).as_mat3(),
        })
    }

    fn shapes(
        &self,
        ul: &urdf_rs::Link,
        filter: CollisionFilter,
    ) -> Result<Vec<Shape>, AssetError> {
        let mut shapes = Vec::with_capacity(ul.collision.len());
        for (k, c) in ul.collision.iter().enumerate() {
            let element = match &c.name {
                Some(name) => format!("link `{}`, collision `{name}`", ul.name),
                None => format!("link `{}`, collision {k}", ul.name),
            };
            let check = |dims: &[(&str, f64)]| {
                for (name, v) in dims {
                    if !(v.is_finite() && *v > 0.0) {
                        return Err(self.invalid(
                            element.as_str(),
                            format!("{name} {v} must be finite and > 0"),
                        ));
                    }
                }
                Ok(())
            };
            let geometry = match &c.geometry {
                urdf_rs::Geometry::Box { size } => {
                    check(&[
                        ("box size x", size[0]),
                        ("box size y", size[1]),
                        ("box size z", size[2]),
                    ])?;
                    Geometry::Box {
                        half_extents: DVec3::from(size.0).as_vec3() * 0.5,
                    }
                }
                urdf_rs::Geometry::Sphere { radius } => {
                    check(&[("sphere radius", *radius)])?;
                    Geometry::Sphere {
                        radius: *radius as f32,
                    }
                }
                urdf_rs::Geometry::Cylinder { radius, length } => {
                    check(&[("cylinder radius", *radius), ("cylinder length", *length)])?;
                    Geometry::Cylinder {
                        radius: *radius as f32,
                        half_length: (*length * 0.5) as f32,
                    }
                }
                urdf_rs::Geometry::Capsule { radius, length } => {
                    check(&[("capsule radius", *radius), ("capsule length", *length)])?;
                    Geometry::Capsule {
                        radius: *radius as f32,
                        half_length: (*length * 0.5) as f32,
                    }
                }
                urdf_rs::Geometry::Mesh { filename, .. } if self.options.skip_mesh_collisions => {
                    tracing::warn!(
                        "{}: {element}: mesh `{filename}` skipped (`skip_mesh_collisions`); this \
                         collision is absent",
                        self.file
                    );
                    continue;
                }
                urdf_rs::Geometry::Mesh { filename, .. } => {
                    return Err(self.invalid(
                        element,
                        format!(
                            "mesh `{filename}`: orbit-rs collides primitives only; replace it \
                             with boxes, spheres, cylinders or capsules, or set \
                             `skip_mesh_collisions: true` in the asset's `spawn: Urdf(…)` to \
                             leave it out"
                        ),
                    ));
                }
            };
            shapes.push(Shape {
                geometry,
                pose: self.pose(&c.origin, &element)?,
                material: Material::default(),
                filter,
            });
        }
        Ok(shapes)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rpy_matches_fixed_axis_composition() {
        // Roll 90° about x, then yaw 90° about the fixed z axis.
        let q = rpy_to_quat([
            std::f64::consts::FRAC_PI_2,
            0.0,
            std::f64::consts::FRAC_PI_2,
        ]);
        let r = DMat3::from_quat(q);
        // Rz(90)·Rx(90)·e_y = Rz(90)·e_z = e_z;  Rz(90)·Rx(90)·e_z = Rz(90)·(−e_y) = e_x.
        assert!((r * DVec3::Y - DVec3::Z).length() < 1e-12);
        assert!((r * DVec3::Z - DVec3::X).length() < 1e-12);
    }
}
