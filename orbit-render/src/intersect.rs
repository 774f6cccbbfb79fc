//! Ray–primitive intersection in a shape's own frame (capsules and cylinders along local z,
//! planes the half-space `z ≤ 0`): the nearest entry point of a ray that starts outside.

use glam::Vec3;
use orbit_core::scene::Geometry;

/// A ray `origin + t · dir` with `dir` of unit length.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    /// Start point.
    pub origin: Vec3,
    /// Unit direction.
    pub dir: Vec3,
}

/// Where a ray enters a shape: the distance along the ray and the outward unit normal there.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Distance from the ray origin (`> 0`).
    pub t: f32,
    /// Outward surface normal (unit length, same frame as the ray).
    pub normal: Vec3,
}

/// The nearest entry of `ray` (in the shape frame) into `geometry` at a distance in
/// `(0, t_max)`, or `None`. A ray that starts inside a shape does not hit it.
pub fn intersect(geometry: &Geometry, ray: &Ray, t_max: f32) -> Option<Hit> {
    let hit = match *geometry {
        Geometry::Sphere { radius } => sphere(ray, Vec3::ZERO, radius),
        Geometry::Capsule {
            radius,
            half_length,
        } => capsule(ray, radius, half_length),
        Geometry::Box { half_extents } => aabb(ray, half_extents),
        Geometry::Cylinder {
            radius,
            half_length,
        } => cylinder(ray, radius, half_length),
        Geometry::Plane => plane(ray),
    }?;
    (hit.t > 0.0 && hit.t < t_max).then_some(hit)
}

/// The radius of a sphere about the shape origin that contains the shape (infinite for a
/// plane): a cheap rejection test before [`intersect`].
pub fn bounding_radius(geometry: &Geometry) -> f32 {
    match *geometry {
        Geometry::Sphere { radius } => radius,
        Geometry::Capsule {
            radius,
            half_length,
        } => radius + half_length,
        Geometry::Box { half_extents } => half_extents.length(),
        Geometry::Cylinder {
            radius,
            half_length,
        } => radius.hypot(half_length),
        Geometry::Plane => f32::INFINITY,
    }
}

/// Whether `ray` passes within `radius` of `center` ahead of its origin and before `t_max`
/// (conservative: may say yes for a sphere just behind `t_max`).
pub fn may_hit_sphere(ray: &Ray, center: Vec3, radius: f32, t_max: f32) -> bool {
    if !radius.is_finite() {
        return true;
    }
    let oc = center - ray.origin;
    let along = oc.dot(ray.dir);
    let dist2 = oc.length_squared() - along * along;
    along + radius > 0.0 && along - radius < t_max && dist2 <= radius * radius
}

/// Entry into a sphere of `radius` about `center`.
fn sphere(ray: &Ray, center: Vec3, radius: f32) -> Option<Hit> {
    let oc = ray.origin - center;
    let b = oc.dot(ray.dir);
    let c = oc.length_squared() - radius * radius;
    if c <= 0.0 {
        return None;
    }
    let disc = b * b - c;
    if disc < 0.0 {
        return None;
    }
    let t = -b - disc.sqrt();
    let p = ray.origin + t * ray.dir;
    Some(Hit {
        t,
        normal: (p - center) / radius,
    })
}

/// The interval `(entry, exit)` of the ray inside the infinite z cylinder of `radius`; `None`
/// if it misses. A ray parallel to the axis is inside for all `t` or for none.
fn infinite_cylinder(ray: &Ray, radius: f32) -> Option<(f32, f32)> {
    let (o, d) = (ray.origin, ray.dir);
    let a = d.x * d.x + d.y * d.y;
    let c = o.x * o.x + o.y * o.y - radius * radius;
    if a < 1e-12 {
        return (c <= 0.0).then_some((f32::NEG_INFINITY, f32::INFINITY));
    }
    let b = o.x * d.x + o.y * d.y;
    let disc = b * b - a * c;
    if disc < 0.0 {
        return None;
    }
    let s = disc.sqrt();
    Some(((-b - s) / a, (-b + s) / a))
}

/// The interval of the ray between the planes `coord = -half` and `coord = +half`.
fn slab(origin: f32, dir: f32, half: f32) -> Option<(f32, f32)> {
    if dir.abs() < 1e-12 {
        return (origin.abs() <= half).then_some((f32::NEG_INFINITY, f32::INFINITY));
    }
    let (t0, t1) = ((-half - origin) / dir, (half - origin) / dir);
    Some((t0.min(t1), t0.max(t1)))
}

/// A capsule is the union of a finite cylinder and two spheres; the ray enters the union at
/// the nearest of their entries (each piece is convex). An entry through the cylinder's flat
/// end lies inside a cap sphere, which the ray entered first, so the cylinder contributes
/// only side entries.
fn capsule(ray: &Ray, radius: f32, half_length: f32) -> Option<Hit> {
    let mut best: Option<Hit> = None;
    let mut keep = |h: Option<Hit>| {
        if let Some(h) = h.filter(|h| h.t > 0.0)
            && best.is_none_or(|b| h.t < b.t)
        {
            best = Some(h);
        }
    };
    for z in [-half_length, half_length] {
        keep(sphere(ray, Vec3::new(0.0, 0.0, z), radius));
    }
    if let Some((t0, _)) = infinite_cylinder(ray, radius) {
        let p = ray.origin + t0 * ray.dir;
        if t0.is_finite() && p.z.abs() <= half_length {
            keep(Some(Hit {
                t: t0,
                normal: Vec3::new(p.x, p.y, 0.0) / radius,
            }));
        }
    }
    best
}

/// Entry into the box `|x| ≤ h.x, |y| ≤ h.y, |z| ≤ h.z` (slab method); the normal is that of
/// the face crossed last on the way in.
fn aabb(ray: &Ray, h: Vec3) -> Option<Hit> {
    let (mut enter, mut exit, mut axis) = (f32::NEG_INFINITY, f32::INFINITY, 0);
    for k in 0..3 {
        let (t0, t1) = slab(ray.origin[k], ray.dir[k], h[k])?;
        if t0 > enter {
            (enter, axis) = (t0, k);
        }
        exit = exit.min(t1);
    }
    if enter > exit || enter <= 0.0 {
        return None;
    }
    let mut normal = Vec3::ZERO;
    normal[axis] = -ray.dir[axis].signum();
    Some(Hit { t: enter, normal })
}

/// Entry into the solid cylinder `x² + y² ≤ r², |z| ≤ h`.
fn cylinder(ray: &Ray, radius: f32, half_length: f32) -> Option<Hit> {
    let (c0, c1) = infinite_cylinder(ray, radius)?;
    let (s0, s1) = slab(ray.origin.z, ray.dir.z, half_length)?;
    let (enter, exit) = (c0.max(s0), c1.min(s1));
    if enter > exit || enter <= 0.0 {
        return None;
    }
    let p = ray.origin + enter * ray.dir;
    let normal = if c0 >= s0 {
        Vec3::new(p.x, p.y, 0.0) / radius
    } else {
        Vec3::new(0.0, 0.0, -ray.dir.z.signum())
    };
    Some(Hit { t: enter, normal })
}

/// Entry into the half-space `z ≤ 0` from above.
fn plane(ray: &Ray) -> Option<Hit> {
    if ray.origin.z <= 0.0 || ray.dir.z >= 0.0 {
        return None;
    }
    Some(Hit {
        t: -ray.origin.z / ray.dir.z,
        normal: Vec3::Z,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ray(origin: [f32; 3], dir: [f32; 3]) -> Ray {
        Ray {
            origin: Vec3::from(origin),
            dir: Vec3::from(dir).normalize(),
        }
    }

    fn hit(g: Geometry, r: Ray) -> Hit {
        intersect(&g, &r, f32::INFINITY).expect("the ray should hit")
    }

    const TOL: f32 = 1e-5;

    #[test]
    fn sphere_is_entered_at_distance_minus_radius() {
        let h = hit(
            Geometry::Sphere { radius: 0.5 },
            ray([0.0, 0.0, 3.0], [0.0, 0.0, -1.0]),
        );
        assert!((h.t - 2.5).abs() < TOL);
        assert!((h.normal - Vec3::Z).length() < TOL);
        // A ray passing 0.6 from the centre misses a sphere of radius 0.5.
        let miss = ray([0.6, 0.0, 3.0], [0.0, 0.0, -1.0]);
        assert!(intersect(&Geometry::Sphere { radius: 0.5 }, &miss, f32::INFINITY).is_none());
    }

    #[test]
    fn capsule_side_and_cap() {
        let g = Geometry::Capsule {
            radius: 0.1,
            half_length: 0.3,
        };
        // Side, at mid height: entry at x = 0.1.
        let h = hit(g, ray([1.0, 0.0, 0.2], [-1.0, 0.0, 0.0]));
        assert!((h.t - 0.9).abs() < TOL && (h.normal - Vec3::X).length() < TOL);
        // Along the axis from above: entry at the top of the cap, z = 0.4.
        let h = hit(g, ray([0.0, 0.0, 1.0], [0.0, 0.0, -1.0]));
        assert!((h.t - 0.6).abs() < TOL && (h.normal - Vec3::Z).length() < TOL);
        // Obliquely onto the cap: the normal points from the cap centre to the hit point.
        let h = hit(g, ray([0.05, 0.0, 2.0], [0.0, 0.0, -1.0]));
        let p = Vec3::new(0.05, 0.0, 2.0 - h.t);
        assert!(((p - Vec3::new(0.0, 0.0, 0.3)).length() - 0.1).abs() < TOL);
        assert!((h.normal - (p - Vec3::new(0.0, 0.0, 0.3)) / 0.1).length() < TOL);
        // Beside the end, past the caps' reach: a miss.
        let miss = ray([1.0, 0.0, 0.45], [-1.0, 0.0, 0.0]);
        assert!(intersect(&g, &miss, f32::INFINITY).is_none());
    }

    #[test]
    fn box_faces_have_axis_normals() {
        let g = Geometry::Box {
            half_extents: Vec3::new(0.1, 0.2, 0.3),
        };
        for (origin, dir, t, n) in [
            ([1.0, 0.0, 0.0], [-1.0, 0.0, 0.0], 0.9, Vec3::X),
            ([0.0, -1.0, 0.0], [0.0, 1.0, 0.0], 0.8, -Vec3::Y),
            ([0.0, 0.0, 1.0], [0.0, 0.0, -1.0], 0.7, Vec3::Z),
        ] {
            let h = hit(g, ray(origin, dir));
            assert!(
                (h.t - t).abs() < TOL && (h.normal - n).length() < TOL,
                "{h:?}"
            );
        }
        // A diagonal ray entering through the x face at (0.1, 0.1, 0): t = 0.9·√2.
        let h = hit(g, ray([1.0, 1.0, 0.0], [-1.0, -1.0, 0.0]));
        assert!((h.t - 0.9 * 2f32.sqrt()).abs() < TOL && (h.normal - Vec3::X).length() < TOL);
        // Starting inside: no entry.
        assert!(intersect(&g, &ray([0.0; 3], [1.0, 0.0, 0.0]), f32::INFINITY).is_none());
    }

    #[test]
    fn cylinder_side_and_flat_end() {
        let g = Geometry::Cylinder {
            radius: 0.2,
            half_length: 0.1,
        };
        let h = hit(g, ray([0.0, 1.0, 0.05], [0.0, -1.0, 0.0]));
        assert!((h.t - 0.8).abs() < TOL && (h.normal - Vec3::Y).length() < TOL);
        // Onto the flat end (a capsule would bulge here, a cylinder does not).
        let h = hit(g, ray([0.15, 0.0, 1.0], [0.0, 0.0, -1.0]));
        assert!((h.t - 0.9).abs() < TOL && (h.normal - Vec3::Z).length() < TOL);
    }

    #[test]
    fn plane_is_hit_from_above_only() {
        let h = hit(Geometry::Plane, ray([0.0, 0.0, 2.0], [1.0, 0.0, -1.0]));
        assert!((h.t - 2.0 * 2f32.sqrt()).abs() < TOL && (h.normal - Vec3::Z).length() < TOL);
        assert!(
            intersect(
                &Geometry::Plane,
                &ray([0.0, 0.0, 2.0], [0.0, 0.0, 1.0]),
                10.0
            )
            .is_none()
        );
        // Beyond t_max: no hit.
        assert!(
            intersect(
                &Geometry::Plane,
                &ray([0.0, 0.0, 2.0], [0.0, 0.0, -1.0]),
                1.5
            )
            .is_none()
        );
    }

    #[test]
    fn bounding_spheres_contain_their_shapes() {
        // Sample points on each shape's surface by casting rays at it from many directions,
        // and check every hit point lies within the bounding radius.
        let shapes = [
            Geometry::Sphere { radius: 0.3 },
            Geometry::Capsule {
                radius: 0.1,
                half_length: 0.4,
            },
            Geometry::Box {
                half_extents: Vec3::new(0.1, 0.5, 0.2),
            },
            Geometry::Cylinder {
                radius: 0.3,
                half_length: 0.2,
            },
        ];
        for g in shapes {
            let r = bounding_radius(&g);
            for k in 0..200 {
                let a = k as f32 * 0.731;
                let b = k as f32 * 0.377;
                let dir = Vec3::new(a.cos() * b.sin(), a.sin() * b.sin(), b.cos());
                let aim = Vec3::new(0.05 * a.sin(), 0.05 * b.cos(), 0.03);
                let ry = Ray {
                    origin: aim - 5.0 * dir,
                    dir,
                };
                if let Some(h) = intersect(&g, &ry, f32::INFINITY) {
                    let p = ry.origin + h.t * ry.dir;
                    assert!(p.length() <= r + TOL, "{g:?}: {p} outside radius {r}");
                    assert!(may_hit_sphere(&ry, Vec3::ZERO, r, f32::INFINITY));
                }
            }
        }
    }
}
