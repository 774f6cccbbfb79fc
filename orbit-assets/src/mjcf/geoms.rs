//! MJCF geoms: collision shapes, their mass properties, and MuJoCo's contact classes turned
//! into collision filters.

use glam::{Quat, Vec3};
use orbit_core::math::Pose;
use orbit_core::scene::{CollisionFilter, Geometry, Inertial, Material, Shape};

use super::xml::Element;
use super::{ContactClass, Importer, inertia, vec3};
use crate::error::AssetError;

impl<'a> Importer<'a> {
    /// A geom's collision shape (none for a visual-only geom), its contact class, and its
    /// inertial (for `in_world`, none).
    pub(super) fn geom(
        &self,
        element: &'a Element,
        class: &str,
        in_world: bool,
    ) -> Result<(Option<Shape>, ContactClass, Inertial), AssetError> {
        let a = self.defaults.attrs(self.file, element, class)?;
        let kind = a.text("type").unwrap_or("sphere");
        let size = a.up_to("size", 3)?.unwrap_or_default();
        let dim = |i: usize| -> Result<f32, AssetError> {
            match size.get(i) {
                Some(&v) if v > 0.0 => Ok(v as f32),
                Some(&v) => Err(a.error(Some("size"), format!("{v} must be positive"))),
                None => Err(a.error(
                    Some("size"),
                    format!("a `{kind}` needs {} size values", i + 1),
                )),
            }
        };
        let fromto = a.numbers::<6>("fromto")?;
        let (geometry, pose) = match (kind, fromto) {
            ("capsule" | "cylinder", Some(ft)) => {
                let (from, to) = (vec3([ft[0], ft[1], ft[2]]), vec3([ft[3], ft[4], ft[5]]));
                let axis = (to - from).try_normalize().ok_or_else(|| {
                    a.error(Some("fromto"), "the two ends are the same point".into())
                })?;
                let (radius, half_length) = (dim(0)?, (to - from).length() / 2.0);
                let geometry = if kind == "capsule" {
                    Geometry::Capsule {
                        radius,
                        half_length,
                    }
                } else {
                    Geometry::Cylinder {
                        radius,
                        half_length,
                    }
                };
                // Either end may come first: the shapes are symmetric. The shorter turn keeps an
                // axis near −z (a leg) from losing half its digits in an almost half turn.
                let turn = Quat::from_rotation_arc_colinear(Vec3::Z, axis);
                let pose = Pose::new((from + to) / 2.0, turn);
                (geometry, pose)
            }
            (_, Some(_)) => {
                return Err(a.error(
                    Some("fromto"),
                    format!("only capsules and cylinders take `fromto`, not a `{kind}`"),
                ));
            }
            ("sphere", None) => (Geometry::Sphere { radius: dim(0)? }, self.pose(&a)?),
            ("capsule", None) => (
                Geometry::Capsule {
                    radius: dim(0)?,
                    half_length: dim(1)?,
                },
                self.pose(&a)?,
            ),
            ("cylinder", None) => (
                Geometry::Cylinder {
                    radius: dim(0)?,
                    half_length: dim(1)?,
                },
                self.pose(&a)?,
            ),
            ("box", None) => (
                Geometry::Box {
                    half_extents: Vec3::new(dim(0)?, dim(1)?, dim(2)?),
                },
                self.pose(&a)?,
            ),
            ("plane", None) if in_world => (Geometry::Plane, self.pose(&a)?),
            ("plane", None) => {
                return Err(a.error(
                    Some("type"),
                    "a plane belongs to the world body, not to a moving body".into(),
                ));
            }
            (other, None) => {
                return Err(a.error(
                    Some("type"),
                    format!(
                        "`{other}` is not supported; the importer takes sphere, capsule, box, \
                         cylinder and (in the world body) plane"
                    ),
                ));
            }
        };
        let class_bits = |name: &str, default: u32| -> Result<u32, AssetError> {
            match a.number(name)? {
                None => Ok(default),
                Some(v) if v >= 0.0 && v.fract() == 0.0 && v <= f64::from(u32::MAX) => Ok(v as u32),
                Some(v) => Err(a.error(Some(name), format!("{v} is not a bit mask"))),
            }
        };
        let class = (class_bits("contype", 1)?, class_bits("conaffinity", 1)?);
        let friction = match a.up_to("friction", 3)? {
            Some(f) if f[0] < 0.0 => {
                return Err(a.error(Some("friction"), format!("{} must be >= 0", f[0])));
            }
            Some(f) => f[0] as f32,
            None => 1.0,
        };
        let density = a.number("density")?.unwrap_or(1000.0);
        let mass = a.number("mass")?;
        if density < 0.0 || mass.is_some_and(|m| m < 0.0) {
            return Err(a.error(
                Some(if density < 0.0 { "density" } else { "mass" }),
                "must be >= 0".into(),
            ));
        }
        let inertial = if in_world {
            Inertial::ZERO
        } else {
            inertia::geom_inertial(&geometry, &pose, density, mass)
        };
        let shape = (class != (0, 0)).then(|| Shape {
            geometry,
            pose,
            material: Material {
                friction,
                ..Material::default()
            },
            filter: CollisionFilter::default(),
        });
        Ok((shape, class, inertial))
    }

    /// Gives every shape a collision filter that reproduces MuJoCo's rule (two geoms collide
    /// when either one's `contype` meets the other's `conaffinity`): one group bit per
    /// distinct contact class from bit 1 on, each class's mask the bits of the classes it
    /// collides with. Bit 0 is the scene's: shapes outside the model (a scene's ground, with the
    /// default filter) count as MuJoCo's default geoms (`contype = conaffinity = 1`), so a
    /// class's mask holds bit 0 when it collides with those.
    pub(super) fn assign_filters(&mut self, world: &mut [Shape]) -> Result<(), AssetError> {
        const SCENE: ContactClass = (1, 1);
        let mut distinct: Vec<ContactClass> = Vec::new();
        for &c in self
            .link_classes
            .iter()
            .flatten()
            .chain(&self.world_classes)
        {
            if !distinct.contains(&c) {
                distinct.push(c);
            }
        }
        if distinct.len() > 31 {
            return Err(AssetError::InvalidValue {
                file: self.file.to_string(),
                element: "geoms".into(),
                problem: format!(
                    "{} distinct contype/conaffinity pairs; at most 31 are supported",
                    distinct.len()
                ),
            });
        }
        let meets = |c: ContactClass, o: ContactClass| (c.0 & o.1) != 0 || (o.0 & c.1) != 0;
        let filter = |c: ContactClass| {
            let bit = |k: ContactClass| 2u32 << distinct.iter().position(|&d| d == k).unwrap_or(0);
            let mask = (distinct.iter())
                .filter(|&&o| meets(c, o))
                .fold(u32::from(meets(c, SCENE)), |m, &o| m | bit(o));
            CollisionFilter {
                groups: bit(c),
                mask,
            }
        };
        for (link, classes) in self.links.iter_mut().zip(&self.link_classes) {
            for (shape, &c) in link.shapes.iter_mut().zip(classes) {
                shape.filter = filter(c);
            }
        }
        for (shape, &c) in world.iter_mut().zip(&self.world_classes) {
            shape.filter = filter(c);
        }
        Ok(())
    }
}
