//! MJCF import (MuJoCo's XML format) for the subset the classic locomotion models use:
//! bodies with positions and orientations (`quat`, `euler` in the `xyz` sequence, `axisangle`,
//! `zaxis`), `<inertial>` or inertia from the geoms (`<compiler inertiafromgeom>`, density or
//! `mass`), `hinge` and `slide` joints (range, limits, armature, damping, frictionloss, passive
//! springs `stiffness` with `springref`; several in one body become a chain of massless links,
//! composed in file order as MuJoCo does) or a `free` joint on the top-level body (a floating
//! base), geoms (`sphere`, `capsule`, `box`, `cylinder`, with `fromto`; `plane` in the world
//! body), `<default>` classes with `class`/`childclass`, `contype`/`conaffinity`, sites,
//! `<motor>` actuators (and plain `<general>` ones) and `<contact><exclude>`. Angles are in degrees unless `<compiler angle="radian">`.
//!
//! A body's joint may sit away from the body's origin (`<joint pos>`); the importer puts the
//! link frame at the joint, with the body's orientation, and expresses the body's geoms, mass
//! and children from there. A body without a joint is welded to its parent (a fixed joint).
//! Anything outside the subset is an error naming the element, the attribute and the line;
//! visual attributes are ignored, and MuJoCo's contact and solver settings are accepted with a
//! warning that they are not simulated (`schema`).

mod actuators;
mod defaults;
mod geoms;
mod inertia;
mod schema;
mod xml;

use std::collections::HashSet;
use std::path::Path;

use glam::{Mat3, Quat, Vec3};
use orbit_core::math::Pose;
use orbit_core::scene::{ArticulationModel, Frame, Inertial, Joint, JointKind, Link, Shape};

use crate::error::AssetError;
use defaults::{Defaults, MAIN};
use xml::{Attrs, Element, mjcf_error};

/// An imported MJCF model: one articulation and what MuJoCo attaches to it.
#[derive(Clone, Debug, PartialEq)]
pub struct MjcfModel {
    /// The top-level body and its subtree (links parent-before-child).
    pub articulation: ArticulationModel,
    /// Whether the top-level body has a free joint (a floating base).
    pub floating_base: bool,
    /// The root link's pose in the world at the model's reference configuration.
    pub root_pose: Pose,
    /// Motors, in file order.
    pub actuators: Vec<MjcfActuator>,
    /// Body pairs whose contacts `<contact><exclude>` removes.
    pub contact_excludes: Vec<[String; 2]>,
    /// Shapes of the world body (a ground plane), in the world frame.
    pub world_shapes: Vec<Shape>,
    /// `<option timestep>`, if set.
    pub timestep: Option<f32>,
}

/// A `<motor>`: force (or torque) `gear · ctrl` on a joint.
#[derive(Clone, Debug, PartialEq)]
pub struct MjcfActuator {
    /// Actuator name.
    pub name: String,
    /// The joint it drives.
    pub joint: String,
    /// Gear ratio.
    pub gear: f32,
    /// Control range, if limited.
    pub ctrl_range: Option<[f32; 2]>,
}

/// Reads an MJCF file and imports it (see [`model_from_mjcf_str`]).
pub fn model_from_mjcf_file(path: &Path) -> Result<MjcfModel, AssetError> {
    let file = path.display().to_string();
    let text = std::fs::read_to_string(path).map_err(|source| AssetError::Io {
        file: file.clone(),
        source,
    })?;
    model_from_mjcf_str(&text, &file)
}

/// Imports an MJCF document; `source_name` names it in errors and is the model name when
/// `<mujoco model>` is absent.
pub fn model_from_mjcf_str(text: &str, source_name: &str) -> Result<MjcfModel, AssetError> {
    let root = xml::parse(text, source_name)?;
    if root.name != "mujoco" {
        return Err(mjcf_error(
            source_name,
            root.line,
            &root.name,
            None,
            "the root element of an MJCF file is `<mujoco>`".into(),
        ));
    }
    let unsimulated = schema::check_document(&root, source_name)?;
    let model = Importer::new(&root, source_name)?.import(&root)?;
    unsimulated.warn(source_name);
    Ok(model)
}

/// A geom's collision class: MuJoCo's `contype` and `conaffinity`.
type ContactClass = (u32, u32);

/// The import of one document.
struct Importer<'a> {
    file: &'a str,
    defaults: Defaults,
    degrees: bool,
    inertia_from_geom: Option<bool>,
    links: Vec<Link>,
    /// The contact class of each link's shapes, and of the world's.
    link_classes: Vec<Vec<ContactClass>>,
    world_classes: Vec<ContactClass>,
    joints: HashSet<String>,
    floating_base: bool,
    root_pose: Pose,
}

impl<'a> Importer<'a> {
    fn new(root: &'a Element, file: &'a str) -> Result<Self, AssetError> {
        let defaults = Defaults::read(root, file)?;
        let mut importer = Importer {
            file,
            defaults,
            degrees: true,
            inertia_from_geom: None,
            links: Vec::new(),
            link_classes: Vec::new(),
            world_classes: Vec::new(),
            joints: HashSet::new(),
            floating_base: false,
            root_pose: Pose::default(),
        };
        for compiler in root.children.iter().filter(|c| c.name == "compiler") {
            let a = importer.plain(compiler);
            importer.degrees = match a.text("angle") {
                None | Some("degree") => true,
                Some("radian") => false,
                Some(other) => {
                    return Err(a.error(
                        Some("angle"),
                        format!("`{other}` is not `degree` or `radian`"),
                    ));
                }
            };
            importer.inertia_from_geom = a.flag("inertiafromgeom")?;
            if let Some(seq) = a.text("eulerseq").filter(|s| *s != "xyz") {
                return Err(a.error(
                    Some("eulerseq"),
                    format!("`{seq}` is not supported; only `xyz` (MuJoCo's default) is"),
                ));
            }
            if let Some(c) = a.text("coordinate").filter(|c| *c != "local") {
                return Err(a.error(
                    Some("coordinate"),
                    format!("`{c}` is not supported; only `local` is"),
                ));
            }
        }
        Ok(importer)
    }

    /// An element's own attributes, without defaults.
    fn plain(&self, element: &'a Element) -> Attrs<'a> {
        Attrs {
            file: self.file,
            element,
            values: element.attrs.iter().cloned().collect(),
        }
    }

    fn import(mut self, root: &'a Element) -> Result<MjcfModel, AssetError> {
        let mut timestep = None;
        let mut world_shapes = Vec::new();
        let mut top_body = None;
        for child in &root.children {
            match child.name.as_str() {
                "compiler" | "default" | "asset" | "visual" | "statistic" | "size" | "sensor"
                | "keyframe" | "actuator" | "contact" | "extension" | "custom" => {}
                "option" => timestep = self.plain(child).number("timestep")?.map(|t| t as f32),
                "worldbody" => {
                    for item in &child.children {
                        match item.name.as_str() {
                            "geom" => {
                                let (shape, class, _) = self.geom(item, MAIN, true)?;
                                if let Some(shape) = shape {
                                    world_shapes.push(shape);
                                    self.world_classes.push(class);
                                }
                            }
                            "body" if top_body.is_some() => {
                                return Err(self.unsupported(
                                    item,
                                    "a second top-level body: one articulation per file is \
                                     supported; put the other bodies in files of their own",
                                ));
                            }
                            "body" => top_body = Some(item),
                            "light" | "camera" | "site" => {}
                            _ => return Err(self.unknown_child(item, "worldbody")),
                        }
                    }
                }
                _ => {
                    return Err(
                        self.unsupported(child, "this section is not supported by the importer")
                    );
                }
            }
        }
        let body = top_body.ok_or_else(|| {
            mjcf_error(
                self.file,
                root.line,
                "mujoco",
                None,
                "the `<worldbody>` has no `<body>`: nothing to import".into(),
            )
        })?;
        self.body(body, None, Vec3::ZERO, MAIN)?;
        let actuators = self.actuators(root)?;
        let contact_excludes = self.excludes(root)?;
        self.assign_filters(&mut world_shapes)?;
        let name = root
            .attrs
            .iter()
            .find(|(k, _)| k == "model")
            .map_or_else(|| self.file.to_string(), |(_, v)| v.clone());
        let articulation = ArticulationModel {
            name,
            links: std::mem::take(&mut self.links),
        };
        articulation
            .validate()
            .map_err(|source| AssetError::Model {
                file: self.file.to_string(),
                source,
            })?;
        Ok(MjcfModel {
            articulation,
            floating_base: self.floating_base,
            root_pose: self.root_pose,
            actuators,
            contact_excludes,
            world_shapes,
            timestep,
        })
    }

    fn unsupported(&self, element: &Element, why: &str) -> AssetError {
        mjcf_error(
            self.file,
            element.line,
            &element.name,
            None,
            why.to_string(),
        )
    }

    fn unknown_child(&self, element: &Element, parent: &str) -> AssetError {
        self.unsupported(
            element,
            &format!("not supported inside `<{parent}>` by the importer"),
        )
    }

    /// The pose an element's `pos` and orientation attributes give.
    fn pose(&self, a: &Attrs) -> Result<Pose, AssetError> {
        let pos = a.numbers::<3>("pos")?.map_or(Vec3::ZERO, vec3);
        Ok(Pose::new(pos, self.orientation(a)?))
    }

    /// The orientation of `quat`, `euler`, `axisangle` or `zaxis` (at most one).
    fn orientation(&self, a: &Attrs) -> Result<Quat, AssetError> {
        let given: Vec<&str> = ["quat", "euler", "axisangle", "zaxis", "xyaxes"]
            .into_iter()
            .filter(|k| a.text(k).is_some())
            .collect();
        if given.len() > 1 {
            return Err(a.error(
                Some(given[1]),
                format!(
                    "the orientation is given twice (`{}` too); keep one",
                    given[0]
                ),
            ));
        }
        let angle = |v: f64| if self.degrees { v.to_radians() } else { v };
        let unit = |name: &str, v: Vec3| {
            v.try_normalize()
                .ok_or_else(|| a.error(Some(name), "the axis has zero length".into()))
        };
        Ok(match given.first().copied() {
            None => Quat::IDENTITY,
            Some("quat") => {
                let [w, x, y, z] = a.numbers::<4>("quat")?.expect("present");
                let q = Quat::from_xyzw(x as f32, y as f32, z as f32, w as f32);
                if q.length() == 0.0 {
                    return Err(a.error(Some("quat"), "the quaternion is zero".into()));
                }
                q.normalize()
            }
            Some("euler") => {
                let [x, y, z] = a.numbers::<3>("euler")?.expect("present").map(angle);
                // `xyz`: rotations about the moving frame's x, then y, then z axes.
                Quat::from_rotation_x(x as f32)
                    * Quat::from_rotation_y(y as f32)
                    * Quat::from_rotation_z(z as f32)
            }
            Some("axisangle") => {
                let [x, y, z, t] = a.numbers::<4>("axisangle")?.expect("present");
                let axis = unit("axisangle", vec3([x, y, z]))?;
                Quat::from_axis_angle(axis, angle(t) as f32)
            }
            Some("zaxis") => {
                let z = unit("zaxis", vec3(a.numbers::<3>("zaxis")?.expect("present")))?;
                Quat::from_rotation_arc(Vec3::Z, z)
            }
            Some(other) => {
                return Err(a.error(Some(other), "not supported; use `quat` or `euler`".into()));
            }
        })
    }

    /// Imports `element` and its subtree as links below `parent` (a link whose frame sits at
    /// `parent_offset` in its body's frame); `childclass` is the enclosing default class.
    fn body(
        &mut self,
        element: &'a Element,
        parent: Option<usize>,
        parent_offset: Vec3,
        childclass: &str,
    ) -> Result<(), AssetError> {
        let a = self.defaults.attrs(self.file, element, childclass)?;
        let class = a.text("childclass").unwrap_or(childclass).to_string();
        let mut body_pose = self.pose(&a)?;
        let name = a
            .text("name")
            .map_or_else(|| format!("body{}", self.links.len()), str::to_string);
        let joint_elements: Vec<&Element> = (element.children.iter())
            .filter(|c| c.name == "joint" || c.name == "freejoint")
            .collect();
        let mut joints = Vec::new();
        for j in &joint_elements {
            if joint_elements.len() > 1 && j.name == "freejoint" {
                return Err(self.unsupported(
                    j,
                    &format!("body `{name}`: a free joint must be the body's only joint"),
                ));
            }
            if let (Some(joint), pos) = self.joint(j, &class, parent.is_none(), &name)? {
                joints.push((joint, pos));
            }
        }
        let (mut parent, mut to_parent) = (parent, Pose::from_pos(-parent_offset));
        if parent.is_none() {
            self.root_pose = body_pose;
        }
        // MuJoCo composes a body's joints in file order: every joint but the last moves a
        // massless link of its own, each link frame at its joint with the body's orientation.
        let last = joints.pop();
        for (mut joint, pos) in joints {
            joint.origin = to_parent
                .mul_pose(&body_pose)
                .mul_pose(&Pose::from_pos(pos));
            self.links.push(Link {
                name: format!("{name}_{}", joint.name),
                parent,
                joint: Some(joint),
                inertial: Inertial::ZERO,
                shapes: Vec::new(),
                frames: Vec::new(),
            });
            self.link_classes.push(Vec::new());
            parent = Some(self.links.len() - 1);
            (to_parent, body_pose) = (Pose::from_pos(-pos), Pose::default());
        }
        let offset = last.as_ref().map_or(Vec3::ZERO, |(_, pos)| *pos);
        // The link frame: the body frame moved to the (last) joint.
        let to_link = Pose::from_pos(-offset);
        let origin = to_parent
            .mul_pose(&body_pose)
            .mul_pose(&Pose::from_pos(offset));
        let joint = parent.map(|_| match last {
            Some((mut j, _)) => {
                j.origin = origin;
                j
            }
            None => Joint::fixed(format!("{name}_weld"), origin),
        });
        let mut shapes = Vec::new();
        let mut classes = Vec::new();
        let mut from_geoms = Inertial::ZERO;
        let mut declared = None;
        let mut frames = Vec::new();
        for child in &element.children {
            match child.name.as_str() {
                "geom" => {
                    let (shape, contact, inertial) = self.geom(child, &class, false)?;
                    from_geoms = from_geoms.combine(&inertial.transformed(&to_link));
                    if let Some(mut shape) = shape {
                        shape.pose = to_link.mul_pose(&shape.pose);
                        shapes.push(shape);
                        classes.push(contact);
                    }
                }
                "inertial" => declared = Some(self.inertial(child)?.transformed(&to_link)),
                "site" => {
                    let s = self.defaults.attrs(self.file, child, &class)?;
                    if let Some(site) = s.text("name") {
                        frames.push(Frame {
                            name: site.to_string(),
                            pose: to_link.mul_pose(&self.pose(&s)?),
                        });
                    }
                }
                "joint" | "freejoint" | "body" | "camera" | "light" => {}
                _ => return Err(self.unknown_child(child, "body")),
            }
        }
        let inertial = match (self.inertia_from_geom, declared) {
            (Some(true), _) | (None, None) => from_geoms,
            (_, Some(declared)) => declared,
            (Some(false), None) => Inertial::ZERO,
        };
        let index = self.links.len();
        self.links.push(Link {
            name,
            parent,
            joint,
            inertial,
            shapes,
            frames,
        });
        self.link_classes.push(classes);
        for child in element.children.iter().filter(|c| c.name == "body") {
            self.body(child, Some(index), offset, &class)?;
        }
        Ok(())
    }

    /// A body's joint and its position in the body frame; `root`: the top-level body, the
    /// only one that may be free.
    fn joint(
        &mut self,
        element: &'a Element,
        class: &str,
        root: bool,
        body: &str,
    ) -> Result<(Option<Joint>, Vec3), AssetError> {
        let a = self.defaults.attrs(self.file, element, class)?;
        let kind = if element.name == "freejoint" {
            "free"
        } else {
            a.text("type").unwrap_or("hinge")
        };
        let name = a
            .text("name")
            .map_or_else(|| format!("{body}_joint"), str::to_string);
        if kind == "free" {
            if !root {
                return Err(a.error(
                    None,
                    format!("body `{body}`: only the top-level body may have a free joint"),
                ));
            }
            self.floating_base = true;
            return Ok((None, Vec3::ZERO));
        }
        if root {
            return Err(a.error(
                None,
                format!(
                    "body `{body}` is a top-level body: a `{kind}` joint would attach it to the \
                     world; give it a free joint (a floating base) or none (a fixed base)"
                ),
            ));
        }
        let (joint_kind, angular) = match kind {
            "hinge" => (JointKind::Revolute, true),
            "slide" => (JointKind::Prismatic, false),
            other => {
                return Err(a.error(
                    Some("type"),
                    format!("`{other}` joints are not supported; use hinge, slide or free"),
                ));
            }
        };
        let axis = vec3(a.numbers::<3>("axis")?.unwrap_or([0.0, 0.0, 1.0]))
            .try_normalize()
            .ok_or_else(|| a.error(Some("axis"), "the axis has zero length".into()))?;
        let scale = |v: f64| {
            if angular && self.degrees {
                v.to_radians()
            } else {
                v
            }
        };
        let limits = (a.limited_range("limited", "range", "joint")?)
            .map(|[lo, hi]| [scale(lo) as f32, scale(hi) as f32]);
        let non_negative = |field: &str| -> Result<f32, AssetError> {
            match a.number(field)? {
                Some(v) if v < 0.0 => Err(a.error(Some(field), format!("{v} must be >= 0"))),
                v => Ok(v.unwrap_or(0.0) as f32),
            }
        };
        let joint = Joint {
            name: name.clone(),
            kind: joint_kind,
            origin: Pose::default(),
            axis,
            limits,
            armature: non_negative("armature")?,
            damping: non_negative("damping")?,
            friction: non_negative("frictionloss")?,
            spring_stiffness: non_negative("stiffness")?,
            spring_ref: a.number("springref")?.map_or(0.0, |v| scale(v) as f32),
            effort_limit: None,
            velocity_limit: None,
        };
        if !self.joints.insert(name.clone()) {
            return Err(a.error(Some("name"), format!("two joints are named `{name}`")));
        }
        Ok((Some(joint), a.numbers::<3>("pos")?.map_or(Vec3::ZERO, vec3)))
    }

    /// An `<inertial>` in its body's frame.
    fn inertial(&self, element: &'a Element) -> Result<Inertial, AssetError> {
        let a = self.plain(element);
        let mass = a
            .number("mass")?
            .ok_or_else(|| a.error(Some("mass"), "an `<inertial>` needs a `mass`".into()))?;
        if mass < 0.0 {
            return Err(a.error(Some("mass"), format!("{mass} must be >= 0")));
        }
        let pose = self.pose(&a)?;
        let inertia = match (
            a.numbers::<3>("diaginertia")?,
            a.numbers::<6>("fullinertia")?,
        ) {
            (Some(d), None) => Mat3::from_diagonal(vec3(d)),
            (None, Some([xx, yy, zz, xy, xz, yz])) => {
                let [xx, yy, zz, xy, xz, yz] = [xx, yy, zz, xy, xz, yz].map(|v| v as f32);
                Mat3::from_cols(
                    Vec3::new(xx, xy, xz),
                    Vec3::new(xy, yy, yz),
                    Vec3::new(xz, yz, zz),
                )
            }
            _ => {
                return Err(a.error(
                    Some("diaginertia"),
                    "give exactly one of `diaginertia` and `fullinertia`".into(),
                ));
            }
        };
        Ok(Inertial {
            mass: mass as f32,
            com: pose.pos,
            inertia: orbit_core::math::rotate_inertia(pose.rot, inertia),
        })
    }
}

/// `[x, y, z]` as a vector.
pub(super) fn vec3(v: [f64; 3]) -> Vec3 {
    Vec3::new(v[0] as f32, v[1] as f32, v[2] as f32)
}
