//! Scene compilation: every env shares one topology, so the resolved scene becomes flat tables
//! (links of all articulations in one forest, dofs, free bodies, shapes, the shape pairs that
//! can touch) that are baked into the WGSL kernel as constants. Per-env parameters (mass scale,
//! friction) live in buffers.

use glam::Vec3;
use orbit_core::math::Pose;
use orbit_core::physics::{ContactModel, PhysicsError};
use orbit_core::scene::{Geometry, Inertial, JointKind, SceneDesc, Shape};

use crate::BACKEND_NAME;

/// Largest number of degrees of freedom (all articulations of an env together, six for each
/// floating base): the kernel keeps the dense `n × n` system matrix in registers and local
/// memory.
pub const MAX_DOFS: usize = 32;
/// Largest number of links (all articulations of an env together).
pub const MAX_LINKS: usize = 32;
/// Largest number of free rigid objects (a constraint row packs its objects in 8 bits each).
pub const MAX_OBJECTS: usize = 254;
/// Contacts kept per env and substep; further candidates replace the shallowest.
pub const MAX_CONTACTS: usize = 12;
/// Contacts are generated up to this gap (m) and solved speculatively.
pub const CONTACT_MARGIN: f32 = 0.005;
/// Over-relaxation factor of the Gauss–Seidel sweeps. Any factor in (0, 2) converges to the
/// same solution of MuJoCo's convex problem; 1.5 gets there in fewer sweeps
/// (docs/fidelity.md).
pub const SOLVER_RELAXATION: f32 = 1.5;
/// Solver iterations per substep when `sim.solver_iterations` is 0 (the default): 12
/// Gauss–Seidel sweeps for MuJoCo's model, 4 iterations of a sweep before and one after the
/// position update for the soft step.
pub fn default_solver_iterations(model: &ContactModel) -> usize {
    match model {
        ContactModel::MuJoCo => 12,
        ContactModel::SoftStep { .. } => 4,
    }
}

/// A link of the global link forest.
#[derive(Clone, Debug)]
pub struct LinkData {
    /// Parent link (global index), `None` for an articulation root.
    pub parent: Option<usize>,
    /// Dof of the joint to the parent (global index), `None` for a root.
    pub dof: Option<usize>,
    /// For the root of a floating base: its index among the scene's floating roots and its
    /// first dof (the six root dofs, see [`DofData::root_axis`]); `None` for every other link.
    pub free_root: Option<FreeRoot>,
    /// Joint kind (`Fixed` for roots).
    pub kind: JointKind,
    /// Joint frame in the parent link (for a root: the root pose in the env frame, the initial
    /// one for a floating base).
    pub origin: Pose,
    /// Joint axis in the joint (= child link) frame.
    pub axis: Vec3,
    /// Mass properties in the link frame.
    pub inertial: Inertial,
}

/// The root link of a floating base.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FreeRoot {
    /// Index among the scene's floating roots (the kernel's root state arrays).
    pub index: usize,
    /// First of its six dofs.
    pub dof0: usize,
}

/// One articulation's block of the link forest and of the dofs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ArticulationBlock {
    /// First link (global index).
    pub link0: usize,
    /// Links.
    pub links: usize,
    /// First dof (global index): the six root dofs of a floating base come first.
    pub dof0: usize,
    /// Dofs, root dofs included: the block of the system matrix.
    pub dofs: usize,
    /// Whether the base floats (six root dofs before the joints').
    pub floating: bool,
}

impl ArticulationBlock {
    /// First joint dof (global index).
    pub fn joint_dof0(&self) -> usize {
        self.dof0 + self.root_dofs()
    }

    /// Joint dofs: what the state buffer and the batched views hold per env.
    pub fn joint_dofs(&self) -> usize {
        self.dofs - self.root_dofs()
    }

    fn root_dofs(&self) -> usize {
        if self.floating { 6 } else { 0 }
    }
}

/// A degree of freedom and its drive.
#[derive(Clone, Debug)]
pub struct DofData {
    /// `None` for a joint; for a floating base's root, its axis: 0–2 the velocity of the root
    /// link's centre of mass along env x, y, z, 3–5 the root's angular velocity about them.
    pub root_axis: Option<usize>,
    /// Rotor inertia added to the mass-matrix diagonal.
    pub armature: f32,
    /// Viscous joint damping.
    pub damping: f32,
    /// Drive stiffness.
    pub stiffness: f32,
    /// Drive damping.
    pub drive_damping: f32,
    /// Effort limit of drive plus feed-forward effort.
    pub effort_limit: f32,
    /// Joint speed limit.
    pub velocity_limit: f32,
    /// Passive spring stiffness (an explicit effort `−spring (q − spring_ref)`).
    pub spring: f32,
    /// Rest position of the passive spring.
    pub spring_ref: f32,
    /// Position limits (`±inf` when unlimited).
    pub lower: f32,
    /// Upper position limit.
    pub upper: f32,
}

impl DofData {
    /// Root dof `axis` of a floating base: no drive, no damping, no limits.
    fn root(axis: usize) -> Self {
        Self {
            root_axis: Some(axis),
            armature: 0.0,
            damping: 0.0,
            stiffness: 0.0,
            drive_damping: 0.0,
            effort_limit: f32::INFINITY,
            velocity_limit: f32::INFINITY,
            spring: 0.0,
            spring_ref: 0.0,
            lower: f32::NEG_INFINITY,
            upper: f32::INFINITY,
        }
    }
}

/// What a shape is to the narrow phase.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ShapeKind {
    /// Sphere of radius `size.x`.
    Sphere,
    /// z-aligned capsule, radius `size.x`, half segment length `size.y`.
    Capsule,
    /// Box with half-extents `size`.
    Box,
    /// Half-space `z <= 0` of the shape frame.
    Plane,
}

impl ShapeKind {
    /// The kernel's code of this kind: 0 sphere, 1 capsule, 2 box, 3 plane (a pair's first
    /// shape has the lower code).
    pub fn code(self) -> u32 {
        match self {
            Self::Sphere => 0,
            Self::Capsule => 1,
            Self::Box => 2,
            Self::Plane => 3,
        }
    }
}

/// A collision shape.
#[derive(Clone, Debug)]
pub struct ShapeData {
    /// Body: a link (global index), a free object (`num_links + o`) or `None` if static.
    pub body: Option<usize>,
    /// Geometry kind.
    pub kind: ShapeKind,
    /// Pose in the body frame (static shapes: in the env frame).
    pub pose: Pose,
    /// Size parameters (see [`ShapeKind`]).
    pub size: Vec3,
    /// Default friction coefficient.
    pub friction: f32,
    /// MuJoCo contact priority: the higher one's friction wins.
    pub priority: i32,
}

impl ShapeData {
    /// Radius of a sphere about the shape's origin that holds it (planes: unbounded).
    pub fn bounding_radius(&self) -> f32 {
        match self.kind {
            ShapeKind::Sphere => self.size.x,
            ShapeKind::Capsule => self.size.x + self.size.y,
            ShapeKind::Box => self.size.length(),
            ShapeKind::Plane => f32::INFINITY,
        }
    }
}

/// Two shapes that can touch: `a` is the one whose points are tested (sphere, capsule or box),
/// `b` the one they are tested against.
#[derive(Clone, Debug)]
pub struct PairData {
    /// Shape whose points are tested.
    pub a: usize,
    /// Shape they are tested against.
    pub b: usize,
    /// First contact slot (a slot is a stable id for warm starting).
    pub slot0: usize,
}

/// The scene's geometry as the narrow phase reads it: one `vec4<f32>` array (a uniform buffer)
/// holding, from the given offsets, 4 entries per shape, one bounding sphere per body, one entry
/// per group of pairs and one per pair.
///
/// - shape: `(position, body code)`, `rotation`, `(size, bounding radius)`,
///   `(kind, priority, pose body, 0)`; shapes that never move have their env-frame pose, body
///   code −1 and pose body −1, the others their pose in the body frame;
/// - body: `(centre in the body frame, radius)` of a sphere holding all its shapes;
/// - group: `(side a, side b, first pair, pairs)`, a side being a moving body `b` or a fixed
///   shape `s` as `−1 − s`: the pairs between two bodies are culled together first;
/// - pair: `(shape a, shape b, first contact slot, 0)`.
#[derive(Clone, Debug)]
pub struct GeometryTable {
    /// The entries.
    pub data: Vec<[f32; 4]>,
    /// First shape entry.
    pub shapes: usize,
    /// First body entry.
    pub bodies: usize,
    /// First group entry.
    pub groups: usize,
    /// First pair entry.
    pub pairs: usize,
    /// Number of groups.
    pub num_groups: usize,
}

/// The compiled scene.
#[derive(Clone, Debug)]
pub struct CompiledScene {
    /// Links of all articulations, each articulation's links contiguous, parents first.
    pub links: Vec<LinkData>,
    /// Per articulation: its links and dofs.
    pub articulations: Vec<ArticulationBlock>,
    /// All dofs.
    pub dofs: Vec<DofData>,
    /// Free rigid objects' mass properties.
    pub objects: Vec<Inertial>,
    /// All collision shapes.
    pub shapes: Vec<ShapeData>,
    /// Shape pairs that can touch.
    pub pairs: Vec<PairData>,
}

/// Whether body `b` is the root link of a fixed base (welded to the env frame).
fn is_fixed_root(links: &[LinkData], b: usize) -> bool {
    links
        .get(b)
        .is_some_and(|l| l.parent.is_none() && l.free_root.is_none())
}

/// Whether a shape never moves: static, or on the root link of a fixed base.
fn never_moves(links: &[LinkData], shape: &ShapeData) -> bool {
    shape.body.is_none_or(|b| is_fixed_root(links, b))
}

fn unsupported(reason: String) -> PhysicsError {
    PhysicsError::Unsupported {
        backend: BACKEND_NAME.into(),
        reason,
    }
}

/// Converts a model shape: cylinders become capsules of the same radius and overall length
/// (rounded instead of flat ends; MuJoCo approximates several cylinder pairs the same way).
fn shape_data(shape: &Shape, body: Option<usize>, what: &str) -> Result<ShapeData, PhysicsError> {
    let (kind, size) = match shape.geometry {
        Geometry::Sphere { radius } => (ShapeKind::Sphere, Vec3::new(radius, 0.0, 0.0)),
        Geometry::Capsule {
            radius,
            half_length,
        } => (ShapeKind::Capsule, Vec3::new(radius, half_length, 0.0)),
        Geometry::Cylinder {
            radius,
            half_length,
        } => (
            ShapeKind::Capsule,
            Vec3::new(radius, (half_length - radius).max(0.0), 0.0),
        ),
        Geometry::Box { half_extents } => (ShapeKind::Box, half_extents),
        Geometry::Plane => {
            if body.is_some() {
                return Err(unsupported(format!(
                    "{what}: a plane must be static (it is an infinite half-space)"
                )));
            }
            (ShapeKind::Plane, Vec3::ZERO)
        }
    };
    Ok(ShapeData {
        body,
        kind,
        pose: shape.pose,
        size,
        friction: shape.material.friction,
        priority: shape.material.priority,
    })
}

/// Contact slots of a pair: one per candidate point.
pub(crate) fn slots(a: ShapeKind, b: ShapeKind) -> usize {
    match (a, b) {
        (ShapeKind::Sphere, _) => 1,
        (ShapeKind::Capsule, ShapeKind::Box) => 3,
        (ShapeKind::Capsule, ShapeKind::Plane) => 2,
        (ShapeKind::Capsule, _) => 1,
        (ShapeKind::Box, ShapeKind::Plane) => 8,
        (ShapeKind::Box, ShapeKind::Box) => 16,
        _ => 0,
    }
}

impl CompiledScene {
    /// Compiles a resolved scene, or says what this engine cannot represent.
    pub fn new(scene: &SceneDesc) -> Result<Self, PhysicsError> {
        let mut links = Vec::new();
        let mut dofs = Vec::new();
        let mut articulations = Vec::new();
        let mut shapes = Vec::new();
        // (articulation, shape filter) per shape, for pair filtering.
        let mut shape_filters = Vec::new();
        let mut shape_art: Vec<Option<usize>> = Vec::new();
        let mut free_roots = 0;
        for (ai, art) in scene.articulations.iter().enumerate() {
            let (link0, dof0) = (links.len(), dofs.len());
            let free_root = (!art.fixed_base).then(|| {
                free_roots += 1;
                dofs.extend((0..6).map(DofData::root));
                FreeRoot {
                    index: free_roots - 1,
                    dof0,
                }
            });
            let joint0 = dofs.len();
            for (li, link) in art.model.links.iter().enumerate() {
                let global = link0 + li;
                let (parent, dof, kind, origin, axis) = match (&link.joint, link.parent) {
                    (Some(j), Some(p)) => {
                        let dof = match j.kind {
                            JointKind::Fixed => {
                                return Err(unsupported(format!(
                                    "articulation `{}`: link `{}` has a fixed joint left after merging",
                                    art.name, link.name
                                )));
                            }
                            _ => Some(dofs.len()),
                        };
                        (Some(link0 + p), dof, j.kind, j.origin, j.axis.normalize())
                    }
                    _ => (None, None, JointKind::Fixed, art.root_pose, Vec3::Z),
                };
                if let (Some(d), Some(j)) = (dof, &link.joint) {
                    let drive = &art.drives[d - joint0];
                    let [lower, upper] = j.limits.unwrap_or([f32::NEG_INFINITY, f32::INFINITY]);
                    if j.friction != 0.0 {
                        return Err(unsupported(format!(
                            "articulation `{}`: joint `{}` has dry friction {}; the GPU engine models joint damping but not Coulomb joint friction yet",
                            art.name, j.name, j.friction
                        )));
                    }
                    dofs.push(DofData {
                        root_axis: None,
                        armature: j.armature,
                        damping: j.damping,
                        stiffness: drive.stiffness,
                        drive_damping: drive.damping,
                        effort_limit: drive.effort_limit,
                        velocity_limit: drive.velocity_limit,
                        spring: j.spring_stiffness,
                        spring_ref: j.spring_ref,
                        lower,
                        upper,
                    });
                }
                links.push(LinkData {
                    parent,
                    dof,
                    free_root: free_root.filter(|_| li == 0),
                    kind,
                    origin,
                    axis,
                    inertial: link.inertial,
                });
                for (si, s) in link.shapes.iter().enumerate() {
                    let what = format!(
                        "articulation `{}` link `{}` shape {si}",
                        art.name, link.name
                    );
                    shapes.push(shape_data(s, Some(global), &what)?);
                    shape_filters.push(s.filter);
                    shape_art.push(Some(ai));
                }
            }
            articulations.push(ArticulationBlock {
                link0,
                links: links.len() - link0,
                dof0,
                dofs: dofs.len() - dof0,
                floating: !art.fixed_base,
            });
        }
        let num_links = links.len();
        if num_links > MAX_LINKS || dofs.len() > MAX_DOFS {
            return Err(unsupported(format!(
                "{} links and {} dofs per env (six for each floating base) exceed the kernel's \
                 limits of {MAX_LINKS} links and {MAX_DOFS} dofs; use `sim.backend: \"rapier\"` \
                 (or `--backend rapier`)",
                num_links,
                dofs.len()
            )));
        }
        if scene.rigid_objects.len() > MAX_OBJECTS {
            return Err(unsupported(format!(
                "{} free rigid objects per env exceed the kernel's limit of {MAX_OBJECTS}",
                scene.rigid_objects.len()
            )));
        }
        let mut objects = Vec::new();
        for (oi, obj) in scene.rigid_objects.iter().enumerate() {
            objects.push(obj.body.inertial);
            for (si, s) in obj.body.shapes.iter().enumerate() {
                let what = format!("rigid object `{}` shape {si}", obj.name);
                shapes.push(shape_data(s, Some(num_links + oi), &what)?);
                shape_filters.push(s.filter);
                shape_art.push(None);
            }
        }
        for st in &scene.static_objects {
            for (si, s) in st.body.shapes.iter().enumerate() {
                let what = format!("static object `{}` shape {si}", st.name);
                let mut data = shape_data(s, None, &what)?;
                data.pose = st.pose.mul_pose(&s.pose);
                shapes.push(data);
                shape_filters.push(s.filter);
                shape_art.push(None);
            }
        }
        let mut pairs = Vec::new();
        let mut next_slot = 0;
        for i in 0..shapes.len() {
            for j in i + 1..shapes.len() {
                let (si, sj) = (&shapes[i], &shapes[j]);
                // Shapes that never move cannot make a contact that changes anything.
                if never_moves(&links, si) && never_moves(&links, sj) || si.body == sj.body {
                    continue;
                }
                let (fi, fj) = (shape_filters[i], shape_filters[j]);
                if fi.groups & fj.mask == 0 || fj.groups & fi.mask == 0 {
                    continue;
                }
                if let (Some(ai), Some(aj)) = (shape_art[i], shape_art[j])
                    && ai == aj
                {
                    let link0 = articulations[ai].link0;
                    let (li, lj) = (si.body.expect("link"), sj.body.expect("link"));
                    let art = &scene.articulations[ai];
                    if !art.self_collisions || art.model.collision_adjacent(li - link0, lj - link0)
                    {
                        continue;
                    }
                }
                let (a, b) = if si.kind.code() <= sj.kind.code() {
                    (i, j)
                } else {
                    (j, i)
                };
                let n = slots(shapes[a].kind, shapes[b].kind);
                pairs.push(PairData {
                    a,
                    b,
                    slot0: next_slot,
                });
                next_slot += n;
            }
        }
        Ok(Self {
            links,
            articulations,
            dofs,
            objects,
            shapes,
            pairs,
        })
    }

    /// Bodies with a mass scale: links, then free objects.
    pub fn num_bodies(&self) -> usize {
        self.links.len() + self.objects.len()
    }

    /// Whether body `b` (a link, or `num_links + o` for a free object) never moves: the root
    /// link of a fixed base, welded to the env frame.
    pub fn is_fixed_body(&self, b: usize) -> bool {
        is_fixed_root(&self.links, b)
    }

    /// The floating roots' links, in the order of their [`FreeRoot::index`].
    pub fn free_roots(&self) -> impl Iterator<Item = (usize, FreeRoot)> + '_ {
        self.links
            .iter()
            .enumerate()
            .filter_map(|(l, link)| Some((l, link.free_root?)))
    }

    /// A sphere in body `b`'s frame that holds all of its shapes: `(centre, radius)`.
    pub fn body_sphere(&self, b: usize) -> (Vec3, f32) {
        let spheres: Vec<(Vec3, f32)> = self
            .shapes
            .iter()
            .filter(|s| s.body == Some(b))
            .map(|s| (s.pose.pos, s.bounding_radius()))
            .collect();
        let center = spheres.iter().map(|(c, _)| *c).sum::<Vec3>() / spheres.len().max(1) as f32;
        let radius = spheres
            .iter()
            .map(|(c, r)| c.distance(center) + r)
            .fold(0.0, f32::max);
        (center, radius)
    }

    /// Where shape `s` is in the env frame while its body is at its initial pose (for shapes
    /// that never move, where they always are).
    pub fn shape_world_pose(&self, s: usize) -> Pose {
        let shape = &self.shapes[s];
        match shape.body {
            Some(b) if b < self.links.len() => self.links[b].origin.mul_pose(&shape.pose),
            _ => shape.pose,
        }
    }

    /// The geometry table the narrow phase loops over (see [`GeometryTable`]).
    pub fn geometry_table(&self) -> GeometryTable {
        let fixed = |s: &ShapeData| never_moves(&self.links, s);
        let mut data = Vec::new();
        for (i, shape) in self.shapes.iter().enumerate() {
            let (pose, code, pose_body) = if fixed(shape) {
                (self.shape_world_pose(i), -1.0, -1.0)
            } else {
                let b = shape.body.expect("moving shapes have a body") as f32;
                (shape.pose, b, b)
            };
            let p = pose.pos;
            let q = pose.rot;
            data.push([p.x, p.y, p.z, code]);
            data.push([q.x, q.y, q.z, q.w]);
            let r = shape.bounding_radius().min(3.4e38);
            data.push([shape.size.x, shape.size.y, shape.size.z, r]);
            data.push([
                shape.kind.code() as f32,
                shape.priority as f32,
                pose_body,
                0.0,
            ]);
        }
        let bodies = data.len();
        for b in 0..self.num_bodies() {
            let (c, r) = self.body_sphere(b);
            data.push([c.x, c.y, c.z, r]);
        }
        // Group the pairs by the moving bodies (or fixed shapes) they join, in order of first
        // appearance.
        let side = |s: usize| match self.shapes[s].body {
            Some(b) if !fixed(&self.shapes[s]) => b as i64,
            _ => -1 - s as i64,
        };
        let mut grouped: Vec<((i64, i64), Vec<&PairData>)> = Vec::new();
        for p in &self.pairs {
            let key = (side(p.a), side(p.b));
            match grouped.iter_mut().find(|(k, _)| *k == key) {
                Some((_, v)) => v.push(p),
                None => grouped.push((key, vec![p])),
            }
        }
        let groups = data.len();
        let mut first = 0;
        for ((a, b), pairs) in &grouped {
            data.push([*a as f32, *b as f32, first as f32, pairs.len() as f32]);
            first += pairs.len();
        }
        let pairs = data.len();
        for p in grouped.iter().flat_map(|(_, v)| v) {
            data.push([p.a as f32, p.b as f32, p.slot0 as f32, 0.0]);
        }
        GeometryTable {
            data,
            shapes: 0,
            bodies,
            groups,
            pairs,
            num_groups: grouped.len(),
        }
    }
}
