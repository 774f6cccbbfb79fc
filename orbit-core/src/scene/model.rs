//! Physical models of assets: rigid links with inertials and collision shapes, joined into a
//! kinematic tree (an articulation), and free or static rigid bodies. These are what URDF import
//! produces and what physics backends build from.

use glam::{Mat3, Vec3};
use serde::{Deserialize, Serialize};

use crate::math::{Pose, rotate_inertia, skew};

/// Primitive collision geometry. Capsules and cylinders are aligned with their local z axis.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum Geometry {
    /// A sphere of the given radius.
    Sphere {
        /// Radius in metres.
        radius: f32,
    },
    /// A capsule: a z-aligned segment of half-length `half_length` swept by a sphere.
    Capsule {
        /// Radius in metres.
        radius: f32,
        /// Half of the segment length (without the caps).
        half_length: f32,
    },
    /// A box with the given half-extents.
    Box {
        /// Half-extents along x, y, z.
        half_extents: Vec3,
    },
    /// A z-aligned solid cylinder.
    Cylinder {
        /// Radius in metres.
        radius: f32,
        /// Half of the height.
        half_length: f32,
    },
    /// The half-space `z <= 0` of the shape frame (only on static objects).
    Plane,
}

impl Geometry {
    /// Volume in m³ (infinite for a plane).
    pub fn volume(&self) -> f32 {
        use std::f32::consts::PI;
        match *self {
            Geometry::Sphere { radius } => 4.0 / 3.0 * PI * radius.powi(3),
            Geometry::Capsule {
                radius,
                half_length,
            } => PI * radius * radius * (2.0 * half_length + 4.0 / 3.0 * radius),
            Geometry::Box { half_extents: h } => 8.0 * h.x * h.y * h.z,
            Geometry::Cylinder {
                radius,
                half_length,
            } => PI * radius * radius * 2.0 * half_length,
            Geometry::Plane => f32::INFINITY,
        }
    }

    /// Checks that all dimensions are finite and positive.
    pub fn validate(&self) -> Result<(), String> {
        let dims: &[f32] = match self {
            Geometry::Sphere { radius } => &[*radius],
            Geometry::Capsule {
                radius,
                half_length,
            }
            | Geometry::Cylinder {
                radius,
                half_length,
            } => &[*radius, *half_length],
            Geometry::Box { half_extents } => &[half_extents.x, half_extents.y, half_extents.z],
            Geometry::Plane => &[],
        };
        if dims.iter().all(|d| d.is_finite() && *d > 0.0) {
            Ok(())
        } else {
            Err(format!(
                "shape dimensions must be finite and > 0, got {self:?}"
            ))
        }
    }
}

/// Surface properties of a shape. A contact takes the friction of the shape with the higher
/// `priority`, or the larger friction when priorities are equal (MuJoCo's mixing rule).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Material {
    /// Coulomb sliding friction coefficient.
    pub friction: f32,
    /// Restitution coefficient (0 = perfectly inelastic).
    #[serde(default)]
    pub restitution: f32,
    /// Contact priority (MuJoCo geom `priority`).
    #[serde(default)]
    pub priority: i32,
}

impl Default for Material {
    fn default() -> Self {
        Self {
            friction: 1.0,
            restitution: 0.0,
            priority: 0,
        }
    }
}

impl Material {
    /// Friction of a contact between two materials (priority wins, else the maximum).
    pub fn combined_friction(&self, other: &Material) -> f32 {
        match self.priority.cmp(&other.priority) {
            std::cmp::Ordering::Greater => self.friction,
            std::cmp::Ordering::Less => other.friction,
            std::cmp::Ordering::Equal => self.friction.max(other.friction),
        }
    }
}

/// Bitmask collision filtering: two shapes touch when each one's `groups` intersects the
/// other's `mask`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CollisionFilter {
    /// Groups this shape belongs to.
    pub groups: u32,
    /// Groups this shape collides with.
    pub mask: u32,
}

impl Default for CollisionFilter {
    fn default() -> Self {
        Self {
            groups: 1,
            mask: u32::MAX,
        }
    }
}

impl CollisionFilter {
    /// Whether shapes with these two filters may collide.
    pub fn allows(&self, other: &CollisionFilter) -> bool {
        (self.groups & other.mask) != 0 && (other.groups & self.mask) != 0
    }
}

/// A collision shape attached to a body.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Shape {
    /// The geometry.
    pub geometry: Geometry,
    /// Pose of the shape in the body frame.
    #[serde(default)]
    pub pose: Pose,
    /// Surface material.
    #[serde(default)]
    pub material: Material,
    /// Collision filter.
    #[serde(default)]
    pub filter: CollisionFilter,
}

/// Mass properties of a body: mass, centre of mass and the full inertia tensor about the
/// centre of mass, expressed in the body frame axes.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Inertial {
    /// Mass in kg.
    pub mass: f32,
    /// Centre of mass in the body frame.
    #[serde(default = "Vec3::default")]
    pub com: Vec3,
    /// Inertia tensor about the centre of mass (body axes), kg·m².
    pub inertia: Mat3,
}

impl Inertial {
    /// A massless body.
    pub const ZERO: Inertial = Inertial {
        mass: 0.0,
        com: Vec3::ZERO,
        inertia: Mat3::ZERO,
    };

    /// Principal moments `diag` whose axes are rotated by `principal_rot` into the body frame.
    pub fn from_principal(mass: f32, com: Vec3, diag: Vec3, principal_rot: glam::Quat) -> Self {
        Self {
            mass,
            com,
            inertia: rotate_inertia(principal_rot, Mat3::from_diagonal(diag)),
        }
    }

    /// The inertial expressed in a parent frame in which this body's frame sits at `pose`.
    pub fn transformed(&self, pose: &Pose) -> Inertial {
        Inertial {
            mass: self.mass,
            com: pose.transform_point(self.com),
            inertia: rotate_inertia(pose.rot, self.inertia),
        }
    }

    /// Sum of two inertials given in the same frame (parallel-axis theorem).
    pub fn combine(&self, other: &Inertial) -> Inertial {
        let mass = self.mass + other.mass;
        if mass <= 0.0 {
            return Inertial::ZERO;
        }
        let com = (self.com * self.mass + other.com * other.mass) / mass;
        let shift = |i: &Inertial| {
            let d = i.com - com;
            // I_com + m (|d|² E − d dᵀ) = I_com − m [d]×[d]×
            i.inertia - skew(d) * skew(d) * i.mass
        };
        Inertial {
            mass,
            com,
            inertia: shift(self) + shift(other),
        }
    }

    /// Checks mass and inertia are finite and physically meaningful.
    pub fn validate(&self) -> Result<(), String> {
        let finite = self.mass.is_finite()
            && self.com.is_finite()
            && self.inertia.to_cols_array().iter().all(|v| v.is_finite());
        if !finite || self.mass < 0.0 {
            return Err(format!(
                "mass must be finite and >= 0 and inertia finite, got mass {} com {:?}",
                self.mass, self.com
            ));
        }
        let d = Vec3::new(
            self.inertia.x_axis.x,
            self.inertia.y_axis.y,
            self.inertia.z_axis.z,
        );
        if self.mass > 0.0 && d.min_element() < 0.0 {
            return Err(format!("inertia diagonal must be >= 0, got {d:?}"));
        }
        Ok(())
    }
}

/// The kind of a joint connecting a link to its parent.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum JointKind {
    /// One rotational degree of freedom about `axis`.
    Revolute,
    /// One translational degree of freedom along `axis`.
    Prismatic,
    /// No degree of freedom (a weld).
    Fixed,
}

/// The joint that attaches a link to its parent link.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Joint {
    /// Joint name (unique within the articulation).
    pub name: String,
    /// Joint kind.
    pub kind: JointKind,
    /// Pose of the child link frame in the parent link frame at joint position zero.
    pub origin: Pose,
    /// Unit axis of motion in the child link frame.
    pub axis: Vec3,
    /// Position limits `[lower, upper]` (rad or m), if limited.
    pub limits: Option<[f32; 2]>,
    /// Reflected rotor inertia added to the joint's diagonal mass (kg·m² or kg).
    #[serde(default)]
    pub armature: f32,
    /// Viscous joint damping (N·m·s/rad or N·s/m).
    #[serde(default)]
    pub damping: f32,
    /// Dry (Coulomb) joint friction (N·m or N).
    #[serde(default)]
    pub friction: f32,
    /// Stiffness of a passive joint spring (N·m/rad or N/m; MuJoCo's `stiffness`): an explicit
    /// effort `−spring_stiffness (q − spring_ref)` every step, apart from any drive.
    #[serde(default)]
    pub spring_stiffness: f32,
    /// Joint position at which the passive spring is relaxed (rad or m; MuJoCo's `springref`).
    #[serde(default)]
    pub spring_ref: f32,
    /// Effort limit declared by the asset (N·m or N), if any.
    #[serde(default)]
    pub effort_limit: Option<f32>,
    /// Velocity limit declared by the asset, if any.
    #[serde(default)]
    pub velocity_limit: Option<f32>,
}

impl Joint {
    /// A weld with the given origin.
    pub fn fixed(name: impl Into<String>, origin: Pose) -> Self {
        Self {
            name: name.into(),
            kind: JointKind::Fixed,
            origin,
            axis: Vec3::Z,
            limits: None,
            armature: 0.0,
            damping: 0.0,
            friction: 0.0,
            spring_stiffness: 0.0,
            spring_ref: 0.0,
            effort_limit: None,
            velocity_limit: None,
        }
    }

    /// A revolute joint about `axis` (child frame) with optional limits.
    pub fn revolute(
        name: impl Into<String>,
        origin: Pose,
        axis: Vec3,
        limits: Option<[f32; 2]>,
    ) -> Self {
        Self {
            kind: JointKind::Revolute,
            axis,
            limits,
            ..Self::fixed(name, origin)
        }
    }

    /// Pose of the child frame in the parent frame at joint position `q`.
    pub fn child_pose(&self, q: f32) -> Pose {
        match self.kind {
            JointKind::Fixed => self.origin,
            JointKind::Revolute => Pose::new(
                self.origin.pos,
                self.origin.rot * glam::Quat::from_axis_angle(self.axis, q),
            ),
            JointKind::Prismatic => Pose::new(
                self.origin.pos + self.origin.rot * (self.axis * q),
                self.origin.rot,
            ),
        }
    }
}

/// A named frame rigidly attached to a link (a MuJoCo site, a URDF link merged away, a tcp).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Frame {
    /// Frame name.
    pub name: String,
    /// Pose in the link frame.
    pub pose: Pose,
}

/// A rigid link of an articulation.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Link {
    /// Link name (unique within the articulation).
    pub name: String,
    /// Index of the parent link, `None` for the root.
    pub parent: Option<usize>,
    /// Joint to the parent (`None` only for the root).
    pub joint: Option<Joint>,
    /// Mass properties.
    pub inertial: Inertial,
    /// Collision shapes in the link frame.
    #[serde(default)]
    pub shapes: Vec<Shape>,
    /// Named frames attached to this link.
    #[serde(default)]
    pub frames: Vec<Frame>,
}

/// A tree of links joined by joints. Links are stored parent-before-child; link 0 is the root.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ArticulationModel {
    /// Model name.
    pub name: String,
    /// Links in topological order.
    pub links: Vec<Link>,
}

/// Errors in a model's structure.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum ModelError {
    /// The model has no links.
    #[error("articulation `{0}` has no links")]
    Empty(String),
    /// Root has a parent or a non-root has none, or a parent comes after its child.
    #[error("articulation `{model}`: link `{link}` {problem}")]
    Topology {
        /// Model name.
        model: String,
        /// Offending link.
        link: String,
        /// What is wrong.
        problem: String,
    },
    /// Two links, joints or frames share a name.
    #[error("articulation `{model}`: the name `{name}` is used twice")]
    DuplicateName {
        /// Model name.
        model: String,
        /// Repeated name.
        name: String,
    },
    /// Physically meaningless numbers.
    #[error("articulation `{model}`, link `{link}`: {problem}")]
    Invalid {
        /// Model name.
        model: String,
        /// Offending link.
        link: String,
        /// What is wrong.
        problem: String,
    },
}

impl ArticulationModel {
    /// Checks the tree structure, names and numbers.
    pub fn validate(&self) -> Result<(), ModelError> {
        if self.links.is_empty() {
            return Err(ModelError::Empty(self.name.clone()));
        }
        let topo = |link: &Link, problem: &str| ModelError::Topology {
            model: self.name.clone(),
            link: link.name.clone(),
            problem: problem.to_string(),
        };
        let mut names = std::collections::HashSet::new();
        for (i, link) in self.links.iter().enumerate() {
            match (i, link.parent, &link.joint) {
                (0, None, None) => {}
                (0, _, _) => return Err(topo(link, "is the root but has a parent joint")),
                (_, Some(p), Some(_)) if p < i => {}
                (_, Some(_), Some(_)) => {
                    return Err(topo(
                        link,
                        "comes before its parent (links must be topologically sorted)",
                    ));
                }
                _ => return Err(topo(link, "has no parent joint")),
            }
            let invalid = |problem: String| ModelError::Invalid {
                model: self.name.clone(),
                link: link.name.clone(),
                problem,
            };
            link.inertial.validate().map_err(invalid)?;
            for s in &link.shapes {
                s.geometry.validate().map_err(invalid)?;
            }
            if let Some(j) = &link.joint {
                if j.kind != JointKind::Fixed && !(j.axis.length() - 1.0).abs().lt(&1e-3) {
                    return Err(invalid(format!(
                        "joint `{}` axis {:?} is not a unit vector",
                        j.name, j.axis
                    )));
                }
                if let Some([lo, hi]) = j.limits
                    && !(lo.is_finite() && hi.is_finite() && lo <= hi)
                {
                    return Err(invalid(format!(
                        "joint `{}` limits [{lo}, {hi}] are not an interval",
                        j.name
                    )));
                }
                let numbers = [
                    ("armature", j.armature),
                    ("damping", j.damping),
                    ("friction", j.friction),
                    ("spring_stiffness", j.spring_stiffness),
                ];
                if let Some((field, v)) = numbers
                    .into_iter()
                    .find(|(_, v)| !(v.is_finite() && *v >= 0.0))
                {
                    return Err(invalid(format!(
                        "joint `{}` {field} {v} must be finite and >= 0",
                        j.name
                    )));
                }
                if !j.spring_ref.is_finite() {
                    return Err(invalid(format!(
                        "joint `{}` spring_ref {} must be finite",
                        j.name, j.spring_ref
                    )));
                }
            }
            let joint_name = link.joint.iter().map(|j| j.name.as_str());
            let frame_names = link.frames.iter().map(|f| f.name.as_str());
            for name in std::iter::once(link.name.as_str())
                .chain(joint_name)
                .chain(frame_names)
            {
                if !names.insert(name.to_string()) {
                    return Err(ModelError::DuplicateName {
                        model: self.name.clone(),
                        name: name.to_string(),
                    });
                }
            }
        }
        Ok(())
    }

    /// Indices of the links whose joint has a degree of freedom, in tree order. The position of a
    /// link in this list is its degree-of-freedom index.
    pub fn dof_links(&self) -> Vec<usize> {
        (0..self.links.len())
            .filter(|&i| {
                self.links[i]
                    .joint
                    .as_ref()
                    .is_some_and(|j| j.kind != JointKind::Fixed)
            })
            .collect()
    }

    /// Names of the movable joints in degree-of-freedom order.
    pub fn joint_names(&self) -> Vec<String> {
        self.dof_links()
            .into_iter()
            .filter_map(|i| self.links[i].joint.as_ref().map(|j| j.name.clone()))
            .collect()
    }

    /// The link whose contacts with `link` self-collision filtering drops (Isaac Lab's rule:
    /// a link does not collide with its parent): the parent, or, past parents that carry
    /// neither shapes nor mass, the first ancestor that does. Such links only compose the
    /// joints of one body (an MJCF body with several joints), so the body below them is
    /// attached to the body above.
    pub fn collision_parent(&self, link: usize) -> Option<usize> {
        let mut parent = self.links[link].parent?;
        while let Some(up) = self.links[parent].parent {
            let l = &self.links[parent];
            if !l.shapes.is_empty() || l.inertial.mass > 0.0 {
                break;
            }
            parent = up;
        }
        Some(parent)
    }

    /// Whether self-collision filtering drops contacts between links `a` and `b` (see
    /// [`ArticulationModel::collision_parent`]).
    pub fn collision_adjacent(&self, a: usize, b: usize) -> bool {
        self.collision_parent(a) == Some(b) || self.collision_parent(b) == Some(a)
    }

    /// Index of the link with the given name.
    pub fn link_index(&self, name: &str) -> Option<usize> {
        self.links.iter().position(|l| l.name == name)
    }

    /// Finds a named frame (or link) and returns `(link index, pose in that link)`.
    pub fn find_frame(&self, name: &str) -> Option<(usize, Pose)> {
        if let Some(i) = self.link_index(name) {
            return Some((i, Pose::IDENTITY));
        }
        self.links.iter().enumerate().find_map(|(i, l)| {
            l.frames
                .iter()
                .find(|f| f.name == name)
                .map(|f| (i, f.pose))
        })
    }

    /// Folds every link attached by a fixed joint into its parent: masses and inertias are
    /// combined, shapes and frames are moved into the parent frame, and the merged link itself
    /// stays available as a named frame. The result has only movable joints below the root.
    pub fn merge_fixed_joints(&self) -> ArticulationModel {
        // For every original link: (index in the merged model, pose in that merged link).
        let mut map: Vec<(usize, Pose)> = Vec::with_capacity(self.links.len());
        let mut links: Vec<Link> = Vec::new();
        for link in &self.links {
            let is_fixed_child = link
                .joint
                .as_ref()
                .is_some_and(|j| j.kind == JointKind::Fixed);
            match (link.parent, is_fixed_child) {
                (Some(p), true) => {
                    let (target, parent_pose) = map[p];
                    let pose = parent_pose.mul_pose(&link.joint.as_ref().expect("checked").origin);
                    let dst = &mut links[target];
                    dst.inertial = dst.inertial.combine(&link.inertial.transformed(&pose));
                    dst.shapes.extend(link.shapes.iter().map(|s| Shape {
                        pose: pose.mul_pose(&s.pose),
                        ..s.clone()
                    }));
                    dst.frames.push(Frame {
                        name: link.name.clone(),
                        pose,
                    });
                    dst.frames.extend(link.frames.iter().map(|f| Frame {
                        name: f.name.clone(),
                        pose: pose.mul_pose(&f.pose),
                    }));
                    map.push((target, pose));
                }
                _ => {
                    let mut new = link.clone();
                    if let (Some(p), Some(j)) = (link.parent, new.joint.as_mut()) {
                        let (target, parent_pose) = map[p];
                        new.parent = Some(target);
                        j.origin = parent_pose.mul_pose(&j.origin);
                    }
                    map.push((links.len(), Pose::IDENTITY));
                    links.push(new);
                }
            }
        }
        ArticulationModel {
            name: self.name.clone(),
            links,
        }
    }
}

/// A single rigid body (a free object or a static fixture): mass properties and shapes.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RigidBodyModel {
    /// Body name.
    pub name: String,
    /// Mass properties (ignored for static bodies).
    pub inertial: Inertial,
    /// Collision shapes in the body frame.
    pub shapes: Vec<Shape>,
}
