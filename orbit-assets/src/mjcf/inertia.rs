//! Mass properties of MJCF geoms, as MuJoCo's compiler computes them from a geom's shape and
//! density (a capsule: a cylinder and two hemispheres).

use glam::Vec3;
use orbit_core::scene::{Geometry, Inertial};

/// The mass and principal moments (about the geom's centre, along its axes) of `geometry`
/// at `density`.
pub(crate) fn geom_mass_properties(geometry: &Geometry, density: f64) -> (f64, [f64; 3]) {
    use std::f64::consts::PI;
    match *geometry {
        Geometry::Sphere { radius } => {
            let r = f64::from(radius);
            let m = density * 4.0 / 3.0 * PI * r.powi(3);
            let i = 0.4 * m * r * r;
            (m, [i, i, i])
        }
        Geometry::Box { half_extents } => {
            let [a, b, c] = half_extents.to_array().map(f64::from);
            let m = density * 8.0 * a * b * c;
            (
                m,
                [
                    m / 3.0 * (b * b + c * c),
                    m / 3.0 * (a * a + c * c),
                    m / 3.0 * (a * a + b * b),
                ],
            )
        }
        Geometry::Cylinder {
            radius,
            half_length,
        } => {
            let (r, h) = (f64::from(radius), 2.0 * f64::from(half_length));
            let m = density * PI * r * r * h;
            let side = m * (3.0 * r * r + h * h) / 12.0;
            (m, [side, side, m * r * r / 2.0])
        }
        Geometry::Capsule {
            radius,
            half_length,
        } => {
            let (r, h) = (f64::from(radius), 2.0 * f64::from(half_length));
            let cylinder = density * PI * r * r * h;
            let spheres = density * 4.0 / 3.0 * PI * r.powi(3);
            // Each hemisphere's centre of mass lies 3r/8 beyond its end of the segment.
            let side = cylinder * (3.0 * r * r + h * h) / 12.0
                + spheres * (0.4 * r * r + h * h / 4.0 + 3.0 * h * r / 8.0);
            let axial = cylinder * r * r / 2.0 + spheres * 0.4 * r * r;
            (cylinder + spheres, [side, side, axial])
        }
        Geometry::Plane => (0.0, [0.0; 3]),
    }
}

/// The inertial of a geom of `geometry` at `pose` in its body: `mass` if given (the density
/// scaled to match), else from `density`.
pub(crate) fn geom_inertial(
    geometry: &Geometry,
    pose: &orbit_core::math::Pose,
    density: f64,
    mass: Option<f64>,
) -> Inertial {
    let (unit_mass, unit_moments) = geom_mass_properties(geometry, 1.0);
    let (m, moments) = match mass {
        Some(m) if unit_mass > 0.0 => (m, unit_moments.map(|i| i * m / unit_mass)),
        Some(_) => (0.0, [0.0; 3]),
        None => (unit_mass * density, unit_moments.map(|i| i * density)),
    };
    Inertial::from_principal(
        m as f32,
        pose.pos,
        Vec3::from_array(moments.map(|v| v as f32)),
        pose.rot,
    )
}
