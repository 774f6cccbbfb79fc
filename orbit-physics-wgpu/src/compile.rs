//! Scene compilation: every env shares one topology, so the resolved scene becomes flat tables
//! (links of all articulations in one forest, dofs, free bodies, shapes, the shape pairs that
//! can touch) that are baked into the WGSL kernel as constants. Per-env parameters (mass scale,
//! friction) live in buffers.

use std::fmt::Write as _;

use glam::{Mat3, Quat, Vec3};
use orbit_core::math::Pose;
use orbit_core::physics::{PhysicsError, SimCfg};
use orbit_core::scene::{Geometry, Inertial, JointKind, SceneDesc, Shape};

use crate::BACKEND_NAME;

/// Largest number of degrees of freedom (all articulations of an env together): the kernel
/// keeps the dense `n × n` system matrix in registers and local memory.
pub const MAX_DOFS: usize = 16;
/// Largest number of links (all articulations of an env together).
pub const MAX_LINKS: usize = 32;
/// Contacts kept per env and substep; further candidates replace the shallowest.
pub const MAX_CONTACTS: usize = 12;
/// Contacts are generated up to this gap (m) and solved speculatively.
pub const CONTACT_MARGIN: f32 = 0.005;
/// Natural frequency (rad/s) of the soft contact and joint-limit constraints: a resting box
/// sinks about 0.4 mm (MuJoCo's soft contacts: about 0.8 mm in this scene).
pub const CONTACT_OMEGA: f32 = 200.0;
/// Damping ratio of the soft constraints (critically damped).
pub const CONTACT_ZETA: f32 = 1.0;

/// A link of the global link forest.
#[derive(Clone, Debug)]
pub struct LinkData {
    /// Parent link (global index), `None` for an articulation root.
    pub parent: Option<usize>,
    /// Dof of the joint to the parent (global index), `None` for a root.
    pub dof: Option<usize>,
    /// Joint kind (`Fixed` only for roots, which are welded to the env frame).
    pub kind: JointKind,
    /// Joint frame in the parent link (for a root: the root pose in the env frame).
    pub origin: Pose,
    /// Joint axis in the joint (= child link) frame.
    pub axis: Vec3,
    /// Mass properties in the link frame.
    pub inertial: Inertial,
}

/// A degree of freedom and its drive.
#[derive(Clone, Debug)]
pub struct DofData {
    /// The link this dof moves.
    pub link: usize,
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
    /// Position limits (`±inf` when unlimited).
    pub lower: f32,
    /// Upper position limit.
    pub upper: f32,
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
    fn code(self) -> u32 {
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

/// The compiled scene.
#[derive(Clone, Debug)]
pub struct CompiledScene {
    /// Links of all articulations, each articulation's links contiguous, parents first.
    pub links: Vec<LinkData>,
    /// Per articulation: `(first link, links, first dof, dofs)`.
    pub articulations: Vec<(usize, usize, usize, usize)>,
    /// All dofs.
    pub dofs: Vec<DofData>,
    /// Free rigid objects' mass properties.
    pub objects: Vec<Inertial>,
    /// All collision shapes.
    pub shapes: Vec<ShapeData>,
    /// Shape pairs that can touch.
    pub pairs: Vec<PairData>,
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
fn slots(a: ShapeKind, b: ShapeKind) -> usize {
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
        for (ai, art) in scene.articulations.iter().enumerate() {
            let (link0, dof0) = (links.len(), dofs.len());
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
                    let drive = &art.drives[d - dof0];
                    let [lower, upper] = j.limits.unwrap_or([f32::NEG_INFINITY, f32::INFINITY]);
                    if j.friction != 0.0 {
                        return Err(unsupported(format!(
                            "articulation `{}`: joint `{}` has dry friction {}; the GPU engine models joint damping but not Coulomb joint friction yet",
                            art.name, j.name, j.friction
                        )));
                    }
                    dofs.push(DofData {
                        link: global,
                        armature: j.armature,
                        damping: j.damping,
                        stiffness: drive.stiffness,
                        drive_damping: drive.damping,
                        effort_limit: drive.effort_limit,
                        velocity_limit: drive.velocity_limit,
                        lower,
                        upper,
                    });
                }
                links.push(LinkData {
                    parent,
                    dof,
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
            articulations.push((link0, links.len() - link0, dof0, dofs.len() - dof0));
        }
        let num_links = links.len();
        if num_links > MAX_LINKS || dofs.len() > MAX_DOFS {
            return Err(unsupported(format!(
                "{} links and {} dofs per env exceed the kernel's limits of {MAX_LINKS} links and {MAX_DOFS} dofs",
                num_links,
                dofs.len()
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
                if si.body.is_none() && sj.body.is_none() || si.body == sj.body {
                    continue;
                }
                let (fi, fj) = (shape_filters[i], shape_filters[j]);
                if fi.groups & fj.mask == 0 || fj.groups & fi.mask == 0 {
                    continue;
                }
                if let (Some(ai), Some(aj)) = (shape_art[i], shape_art[j])
                    && ai == aj
                {
                    let (li, lj) = (si.body.expect("link"), sj.body.expect("link"));
                    let adjacent = links[li].parent == Some(lj) || links[lj].parent == Some(li);
                    if !scene.articulations[ai].self_collisions || adjacent {
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

    /// The WGSL constants and tables of this scene (independent of the number of envs).
    pub fn wgsl_prelude(&self, sim: &SimCfg) -> String {
        let mut s = String::new();
        let nl = self.links.len();
        let nd = self.dofs.len();
        let no = self.objects.len();
        let ns = self.shapes.len();
        let np = self.pairs.len();
        let c = |s: &mut String, name: &str, v: String| {
            writeln!(s, "const {name} = {v};").expect("write to string");
        };
        c(&mut s, "NL", format!("{nl}u"));
        c(&mut s, "ND", format!("{nd}u"));
        c(&mut s, "NO", format!("{no}u"));
        c(&mut s, "NS", format!("{ns}u"));
        c(&mut s, "NP", format!("{np}u"));
        c(&mut s, "NB", format!("{}u", self.num_bodies()));
        // Array lengths must be at least 1.
        c(&mut s, "NL1", format!("{}u", nl.max(1)));
        c(&mut s, "ND1", format!("{}u", nd.max(1)));
        c(&mut s, "NO1", format!("{}u", no.max(1)));
        c(&mut s, "NS1", format!("{}u", ns.max(1)));
        c(&mut s, "NP1", format!("{}u", np.max(1)));
        c(&mut s, "NDD", format!("{}u", (nd * nd).max(1)));
        c(&mut s, "MAX_C", format!("{MAX_CONTACTS}u"));
        c(&mut s, "DT", f(sim.dt));
        c(&mut s, "GRAVITY", v3(sim.gravity));
        c(&mut s, "ITERATIONS", format!("{}u", sim.solver_iterations));
        c(&mut s, "MARGIN", f(CONTACT_MARGIN));
        c(&mut s, "OMEGA", f(CONTACT_OMEGA));
        c(&mut s, "ZETA", f(CONTACT_ZETA));
        let arr = |s: &mut String, name: &str, ty: &str, len: &str, items: Vec<String>| {
            let items = if items.is_empty() {
                vec![zero(ty)]
            } else {
                items
            };
            writeln!(
                s,
                "var<private> {name}: array<{ty}, {len}> = array<{ty}, {len}>({});",
                items.join(", ")
            )
            .expect("write to string");
        };
        let links = &self.links;
        arr(
            &mut s,
            "L_PARENT",
            "i32",
            "NL1",
            links
                .iter()
                .map(|l| format!("{}", l.parent.map_or(-1, |p| p as i64)))
                .collect(),
        );
        arr(
            &mut s,
            "L_DOF",
            "i32",
            "NL1",
            links
                .iter()
                .map(|l| format!("{}", l.dof.map_or(-1, |d| d as i64)))
                .collect(),
        );
        let kind = |k: JointKind| match k {
            JointKind::Fixed => 0u32,
            JointKind::Revolute => 1,
            JointKind::Prismatic => 2,
        };
        arr(
            &mut s,
            "L_KIND",
            "u32",
            "NL1",
            links.iter().map(|l| format!("{}u", kind(l.kind))).collect(),
        );
        arr(
            &mut s,
            "L_OPOS",
            "vec3<f32>",
            "NL1",
            links.iter().map(|l| v3(l.origin.pos)).collect(),
        );
        arr(
            &mut s,
            "L_OROT",
            "vec4<f32>",
            "NL1",
            links.iter().map(|l| q4(l.origin.rot)).collect(),
        );
        arr(
            &mut s,
            "L_AXIS",
            "vec3<f32>",
            "NL1",
            links.iter().map(|l| v3(l.axis)).collect(),
        );
        arr(
            &mut s,
            "L_MASS",
            "f32",
            "NL1",
            links.iter().map(|l| f(l.inertial.mass)).collect(),
        );
        arr(
            &mut s,
            "L_COM",
            "vec3<f32>",
            "NL1",
            links.iter().map(|l| v3(l.inertial.com)).collect(),
        );
        arr(
            &mut s,
            "L_INERTIA",
            "mat3x3<f32>",
            "NL1",
            links.iter().map(|l| m3(l.inertial.inertia)).collect(),
        );
        let dofs = &self.dofs;
        arr(
            &mut s,
            "D_LINK",
            "u32",
            "ND1",
            dofs.iter().map(|d| format!("{}u", d.link)).collect(),
        );
        arr(
            &mut s,
            "D_ARMATURE",
            "f32",
            "ND1",
            dofs.iter().map(|d| f(d.armature)).collect(),
        );
        arr(
            &mut s,
            "D_DAMPING",
            "f32",
            "ND1",
            dofs.iter().map(|d| f(d.damping)).collect(),
        );
        arr(
            &mut s,
            "D_K",
            "f32",
            "ND1",
            dofs.iter().map(|d| f(d.stiffness)).collect(),
        );
        arr(
            &mut s,
            "D_D",
            "f32",
            "ND1",
            dofs.iter().map(|d| f(d.drive_damping)).collect(),
        );
        arr(
            &mut s,
            "D_EFFORT",
            "f32",
            "ND1",
            dofs.iter().map(|d| f(d.effort_limit)).collect(),
        );
        arr(
            &mut s,
            "D_VMAX",
            "f32",
            "ND1",
            dofs.iter().map(|d| f(d.velocity_limit)).collect(),
        );
        arr(
            &mut s,
            "D_LOWER",
            "f32",
            "ND1",
            dofs.iter().map(|d| f(d.lower)).collect(),
        );
        arr(
            &mut s,
            "D_UPPER",
            "f32",
            "ND1",
            dofs.iter().map(|d| f(d.upper)).collect(),
        );
        let objs = &self.objects;
        arr(
            &mut s,
            "O_MASS",
            "f32",
            "NO1",
            objs.iter().map(|o| f(o.mass)).collect(),
        );
        arr(
            &mut s,
            "O_COM",
            "vec3<f32>",
            "NO1",
            objs.iter().map(|o| v3(o.com)).collect(),
        );
        arr(
            &mut s,
            "O_INERTIA",
            "mat3x3<f32>",
            "NO1",
            objs.iter().map(|o| m3(o.inertia)).collect(),
        );
        let shapes = &self.shapes;
        arr(
            &mut s,
            "S_BODY",
            "i32",
            "NS1",
            shapes
                .iter()
                .map(|x| format!("{}", x.body.map_or(-1, |b| b as i64)))
                .collect(),
        );
        arr(
            &mut s,
            "S_KIND",
            "u32",
            "NS1",
            shapes
                .iter()
                .map(|x| format!("{}u", x.kind.code()))
                .collect(),
        );
        arr(
            &mut s,
            "S_POS",
            "vec3<f32>",
            "NS1",
            shapes.iter().map(|x| v3(x.pose.pos)).collect(),
        );
        arr(
            &mut s,
            "S_ROT",
            "vec4<f32>",
            "NS1",
            shapes.iter().map(|x| q4(x.pose.rot)).collect(),
        );
        arr(
            &mut s,
            "S_SIZE",
            "vec3<f32>",
            "NS1",
            shapes.iter().map(|x| v3(x.size)).collect(),
        );
        // Bounding-sphere radius about the shape origin (planes: unbounded), for pair culling.
        let radius = |x: &ShapeData| match x.kind {
            ShapeKind::Sphere => x.size.x,
            ShapeKind::Capsule => x.size.x + x.size.y,
            ShapeKind::Box => x.size.length(),
            ShapeKind::Plane => f32::INFINITY,
        };
        arr(
            &mut s,
            "S_RADIUS",
            "f32",
            "NS1",
            shapes.iter().map(|x| f(radius(x))).collect(),
        );
        arr(
            &mut s,
            "S_PRIORITY",
            "i32",
            "NS1",
            shapes.iter().map(|x| format!("{}", x.priority)).collect(),
        );
        let pairs = &self.pairs;
        arr(
            &mut s,
            "P_A",
            "u32",
            "NP1",
            pairs.iter().map(|p| format!("{}u", p.a)).collect(),
        );
        arr(
            &mut s,
            "P_B",
            "u32",
            "NP1",
            pairs.iter().map(|p| format!("{}u", p.b)).collect(),
        );
        arr(
            &mut s,
            "P_SLOT",
            "u32",
            "NP1",
            pairs.iter().map(|p| format!("{}u", p.slot0)).collect(),
        );
        s
    }
}

fn f(x: f32) -> String {
    if x.is_infinite() {
        // WGSL has no infinity literal; 3.4e38 behaves the same in every comparison we make.
        return if x > 0.0 {
            "3.4e38".into()
        } else {
            "-3.4e38".into()
        };
    }
    format!("{x:?}")
}

fn v3(v: Vec3) -> String {
    format!("vec3<f32>({}, {}, {})", f(v.x), f(v.y), f(v.z))
}

fn q4(q: Quat) -> String {
    format!("vec4<f32>({}, {}, {}, {})", f(q.x), f(q.y), f(q.z), f(q.w))
}

fn m3(m: Mat3) -> String {
    format!(
        "mat3x3<f32>({}, {}, {})",
        v3(m.x_axis),
        v3(m.y_axis),
        v3(m.z_axis)
    )
}

fn zero(ty: &str) -> String {
    match ty {
        "f32" => "0.0".into(),
        "i32" => "0".into(),
        "u32" => "0u".into(),
        other => format!("{other}()"),
    }
}
