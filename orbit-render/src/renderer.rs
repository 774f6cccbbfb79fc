//! The ray caster: one env's collision shapes and debug markers, Lambert-shaded under one
//! directional light with hard shadows, over a sky gradient.

use glam::Vec3;
use orbit_core::math::Pose;
use orbit_core::physics::PhysicsBackend;
use orbit_core::scene::{Geometry, Marker, MarkerShape, SceneDesc, Shape, ViewerCfg};
use rayon::prelude::*;

use crate::intersect::{Ray, bounding_radius, intersect, may_hit_sphere};
use crate::{Camera, Image, RenderError};

/// Direction towards the light (unit length): high, from the default camera's side.
const LIGHT_DIR: Vec3 = Vec3::new(0.3464, -0.2598, 0.9014);
/// Share of a surface's colour it shows without direct light.
const AMBIENT: f32 = 0.35;
/// Share of a surface's colour added by direct light falling straight onto it.
const DIFFUSE: f32 = 0.65;
/// Offset of shadow rays off the surface (m), so that a surface does not shadow itself.
const SHADOW_BIAS: f32 = 1e-3;
/// Edge of the checker squares drawn on planes (m).
const CHECKER: f32 = 0.25;
/// Default colours by asset kind.
const ARTICULATION_COLOR: [f32; 3] = [0.82, 0.83, 0.86];
const RIGID_OBJECT_COLOR: [f32; 3] = [0.8, 0.27, 0.2];
const STATIC_OBJECT_COLOR: [f32; 3] = [0.62, 0.5, 0.38];
/// Sky colours at the horizon and straight up.
const SKY_HORIZON: [f32; 3] = [0.82, 0.86, 0.9];
const SKY_ZENITH: [f32; 3] = [0.45, 0.58, 0.78];

/// What moves a shape.
#[derive(Clone, Copy, Debug)]
enum Attachment {
    /// Fixed in the env frame.
    Static(Pose),
    /// Carried by a link of an articulation.
    Link { articulation: usize, link: usize },
    /// Carried by a rigid object.
    Object(usize),
}

/// A collision shape of the scene with its colour.
#[derive(Clone, Copy, Debug)]
struct SceneShape {
    geometry: Geometry,
    local: Pose,
    attachment: Attachment,
    color: Vec3,
}

/// A shape placed in the env frame for one frame.
#[derive(Clone, Copy, Debug)]
struct Placed {
    geometry: Geometry,
    /// Shape frame in the env frame.
    pose: Pose,
    /// Env frame in the shape frame.
    inverse: Pose,
    center: Vec3,
    radius: f32,
    /// Pixels its image can cover.
    rect: [u32; 4],
    color: Vec3,
    opacity: f32,
}

impl Placed {
    fn new(geometry: Geometry, pose: Pose, color: Vec3, opacity: f32, camera: &Camera) -> Self {
        let radius = bounding_radius(&geometry);
        Self {
            geometry,
            pose,
            inverse: pose.inverse(),
            center: pose.pos,
            radius,
            rect: camera.sphere_rect(pose.pos, radius).unwrap_or([0; 4]),
            color,
            opacity,
        }
    }

    fn covers(&self, x: u32, y: u32) -> bool {
        let [x0, y0, x1, y1] = self.rect;
        (x0..x1).contains(&x) && (y0..y1).contains(&y)
    }

    /// The entry of `ray` (env frame) before `t_max`: distance and env-frame normal.
    fn hit(&self, ray: &Ray, t_max: f32) -> Option<(f32, Vec3)> {
        if !may_hit_sphere(ray, self.center, self.radius, t_max) {
            return None;
        }
        let local = Ray {
            origin: self.inverse.transform_point(ray.origin),
            dir: self.inverse.rot * ray.dir,
        };
        let h = intersect(&self.geometry, &local, t_max)?;
        Some((h.t, self.pose.rot * h.normal))
    }

    /// The surface colour at env-frame point `p` (checkered on planes).
    fn albedo(&self, p: Vec3) -> Vec3 {
        if self.geometry != Geometry::Plane {
            return self.color;
        }
        let q = self.inverse.transform_point(p);
        let parity = ((q.x / CHECKER).floor() + (q.y / CHECKER).floor()).rem_euclid(2.0);
        self.color * if parity < 0.5 { 1.0 } else { 0.82 }
    }
}

/// Renders one env of a scene from a [`ViewerCfg`]'s camera.
pub struct Renderer {
    camera: Camera,
    env: usize,
    shapes: Vec<SceneShape>,
    /// The rigid objects' shapes, for ghost markers.
    object_shapes: Vec<Vec<Shape>>,
    /// This frame's opaque shapes and translucent markers (kept to avoid reallocating).
    opaque: Vec<Placed>,
    translucent: Vec<Placed>,
}

impl Renderer {
    /// A renderer of env `viewer.env_index` of a scene of `num_envs` envs.
    pub fn new(desc: &SceneDesc, viewer: &ViewerCfg, num_envs: usize) -> Result<Self, RenderError> {
        let camera = Camera::new(viewer)?;
        if viewer.env_index >= num_envs {
            return Err(RenderError::InvalidViewer {
                field: "env_index".into(),
                message: format!(
                    "env {} does not exist (the scene has {num_envs} envs)",
                    viewer.env_index
                ),
            });
        }
        let names: Vec<&str> = (desc.articulations.iter().map(|a| a.name.as_str()))
            .chain(desc.rigid_objects.iter().map(|o| o.name.as_str()))
            .chain(desc.static_objects.iter().map(|o| o.name.as_str()))
            .collect();
        for (name, c) in &viewer.colors {
            if !names.contains(&name.as_str()) {
                return Err(RenderError::InvalidViewer {
                    field: format!("colors.{name}"),
                    message: format!("no asset named `{name}`; the scene has {names:?}"),
                });
            }
            if ![c.0, c.1, c.2].iter().all(|v| (0.0..=1.0).contains(v)) {
                return Err(RenderError::InvalidViewer {
                    field: format!("colors.{name}"),
                    message: format!("expected (r, g, b) in [0, 1], got {c:?}"),
                });
            }
        }
        let color = |name: &str, default: [f32; 3]| {
            viewer
                .colors
                .get(name)
                .map_or(Vec3::from(default), |&c| Vec3::from(c))
        };
        let mut shapes = Vec::new();
        for (a, art) in desc.articulations.iter().enumerate() {
            let c = color(&art.name, ARTICULATION_COLOR);
            for (link, l) in art.model.links.iter().enumerate() {
                let attachment = Attachment::Link {
                    articulation: a,
                    link,
                };
                shapes.extend(l.shapes.iter().map(|s| scene_shape(s, attachment, c)));
            }
        }
        for (o, obj) in desc.rigid_objects.iter().enumerate() {
            let c = color(&obj.name, RIGID_OBJECT_COLOR);
            let attachment = Attachment::Object(o);
            shapes.extend(
                obj.body
                    .shapes
                    .iter()
                    .map(|s| scene_shape(s, attachment, c)),
            );
        }
        for obj in &desc.static_objects {
            let c = color(&obj.name, STATIC_OBJECT_COLOR);
            let attachment = Attachment::Static(obj.pose);
            shapes.extend(
                obj.body
                    .shapes
                    .iter()
                    .map(|s| scene_shape(s, attachment, c)),
            );
        }
        Ok(Self {
            camera,
            env: viewer.env_index,
            object_shapes: desc
                .rigid_objects
                .iter()
                .map(|o| o.body.shapes.clone())
                .collect(),
            opaque: Vec::with_capacity(shapes.len()),
            translucent: Vec::new(),
            shapes,
        })
    }

    /// The camera.
    pub fn camera(&self) -> &Camera {
        &self.camera
    }

    /// The env rendered.
    pub fn env(&self) -> usize {
        self.env
    }

    /// A black image of the camera's size.
    pub fn new_image(&self) -> Image {
        Image::new(self.camera.width(), self.camera.height())
    }

    /// Renders the env's current state with `markers` into `image` (of the camera's size):
    /// [`place`](Self::place), then [`draw`](Self::draw).
    pub fn render(&mut self, backend: &dyn PhysicsBackend, markers: &[Marker], image: &mut Image) {
        self.place(backend, markers);
        self.draw(image);
    }

    /// Ray casts the shapes last placed into `image` (of the camera's size), rows in parallel.
    pub fn draw(&self, image: &mut Image) {
        assert_eq!(
            (image.width(), image.height()),
            (self.camera.width(), self.camera.height()),
            "the image must have the camera's size"
        );
        let (camera, opaque, translucent) = (&self.camera, &self.opaque, &self.translucent);
        let row_len = 3 * camera.width() as usize;
        image
            .rgb_mut()
            .par_chunks_mut(row_len)
            .enumerate()
            .for_each(|(y, row)| {
                for (x, px) in row.chunks_exact_mut(3).enumerate() {
                    let c = shade_pixel(camera, opaque, translucent, x as u32, y as u32);
                    for (byte, v) in px.iter_mut().zip(c.to_array()) {
                        *byte = (v.clamp(0.0, 1.0) * 255.0).round() as u8;
                    }
                }
            });
    }

    /// Places every shape of the env's current state and every marker in the env frame.
    pub fn place(&mut self, backend: &dyn PhysicsBackend, markers: &[Marker]) {
        let (e, camera) = (self.env, &self.camera);
        self.opaque.clear();
        self.translucent.clear();
        for s in &self.shapes {
            let body = match s.attachment {
                Attachment::Static(pose) => pose,
                Attachment::Link { articulation, link } => {
                    backend.articulation(articulation).link_pose(e, link)
                }
                Attachment::Object(o) => {
                    let view = backend.rigid_object(o);
                    Pose::new(view.pos[e], view.quat[e])
                }
            };
            let pose = body.mul_pose(&s.local);
            self.opaque
                .push(Placed::new(s.geometry, pose, s.color, 1.0, camera));
        }
        for m in markers {
            let list = if m.opacity >= 1.0 {
                &mut self.opaque
            } else {
                &mut self.translucent
            };
            let color = Vec3::from(m.color);
            match m.shape {
                MarkerShape::Geometry(g) => {
                    list.push(Placed::new(g, m.pose, color, m.opacity, camera))
                }
                MarkerShape::RigidObject(o) => {
                    for s in self.object_shapes.get(o).into_iter().flatten() {
                        let pose = m.pose.mul_pose(&s.pose);
                        list.push(Placed::new(s.geometry, pose, color, m.opacity, camera));
                    }
                }
            }
        }
    }
}

fn scene_shape(s: &Shape, attachment: Attachment, color: Vec3) -> SceneShape {
    SceneShape {
        geometry: s.geometry,
        local: s.pose,
        attachment,
        color,
    }
}

/// The nearest hit among `shapes` that cover the pixel: distance, normal, shape.
fn nearest<'a>(
    shapes: &'a [Placed],
    ray: &Ray,
    pixel: Option<(u32, u32)>,
    t_max: f32,
) -> Option<(f32, Vec3, &'a Placed)> {
    let mut best: Option<(f32, Vec3, &Placed)> = None;
    for s in shapes {
        if pixel.is_some_and(|(x, y)| !s.covers(x, y)) {
            continue;
        }
        let limit = best.map_or(t_max, |b| b.0);
        if let Some((t, n)) = s.hit(ray, limit) {
            best = Some((t, n, s));
        }
    }
    best
}

/// Lambert shading of a surface point with an optional shadow test against `occluders`.
fn shade(p: Vec3, normal: Vec3, albedo: Vec3, occluders: Option<&[Placed]>) -> Vec3 {
    let facing = normal.dot(LIGHT_DIR).max(0.0);
    let lit = facing > 0.0
        && occluders.is_none_or(|shapes| {
            let shadow = Ray {
                origin: p + SHADOW_BIAS * normal,
                dir: LIGHT_DIR,
            };
            nearest(shapes, &shadow, None, f32::INFINITY).is_none()
        });
    albedo * (AMBIENT + if lit { DIFFUSE * facing } else { 0.0 })
}

/// The colour of pixel `(x, y)`: the nearest opaque surface (or the sky), then the nearest
/// translucent marker in front of it blended over.
fn shade_pixel(camera: &Camera, opaque: &[Placed], translucent: &[Placed], x: u32, y: u32) -> Vec3 {
    let ray = camera.ray(x, y);
    let point = |t: f32| ray.origin + t * ray.dir;
    let (mut color, t_surface) = match nearest(opaque, &ray, Some((x, y)), f32::INFINITY) {
        Some((t, n, s)) => (shade(point(t), n, s.albedo(point(t)), Some(opaque)), t),
        None => {
            let up = ray.dir.z.clamp(0.0, 1.0);
            let sky = Vec3::from(SKY_HORIZON).lerp(Vec3::from(SKY_ZENITH), up);
            (sky, f32::INFINITY)
        }
    };
    if let Some((t, n, s)) = nearest(translucent, &ray, Some((x, y)), t_surface) {
        let marker = shade(point(t), n, s.albedo(point(t)), None);
        color = color.lerp(marker, s.opacity);
    }
    color
}
