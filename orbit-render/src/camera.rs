//! A pinhole camera looking from `eye` at `lookat` with world `+z` up.

use glam::Vec3;
use orbit_core::scene::ViewerCfg;

use crate::RenderError;
use crate::intersect::Ray;

/// A pinhole camera: rays through pixel centres, and the projection of points to pixels.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    eye: Vec3,
    forward: Vec3,
    right: Vec3,
    up: Vec3,
    /// Focal length in pixels.
    focal: f32,
    width: u32,
    height: u32,
}

impl Camera {
    /// The camera of a viewer config; errors name the offending field.
    pub fn new(cfg: &ViewerCfg) -> Result<Self, RenderError> {
        let (width, height) = cfg.resolution;
        let invalid = |field: &str, message: String| RenderError::InvalidViewer {
            field: field.to_string(),
            message,
        };
        // GIF frames are at most 65 535 pixels wide and high.
        if !(1..=u32::from(u16::MAX)).contains(&width)
            || !(1..=u32::from(u16::MAX)).contains(&height)
        {
            return Err(invalid(
                "resolution",
                format!("expected 1 to 65535 pixels each way, got ({width}, {height})"),
            ));
        }
        if !(cfg.fov_deg.is_finite() && cfg.fov_deg > 0.0 && cfg.fov_deg < 180.0) {
            return Err(invalid(
                "fov_deg",
                format!("expected an angle in (0, 180) degrees, got {}", cfg.fov_deg),
            ));
        }
        let (eye, lookat) = (cfg.eye(), cfg.lookat());
        if !(eye.is_finite() && lookat.is_finite()) || (lookat - eye).length() < 1e-6 {
            return Err(invalid(
                "eye",
                format!("expected finite eye and lookat points apart, got {eye} and {lookat}"),
            ));
        }
        let forward = (lookat - eye).normalize();
        // Looking straight up or down, world +y stands in for +z as the image's up.
        let world_up = if forward.cross(Vec3::Z).length() < 1e-4 {
            Vec3::Y
        } else {
            Vec3::Z
        };
        let right = forward.cross(world_up).normalize();
        let up = right.cross(forward);
        let focal = 0.5 * height as f32 / (0.5 * cfg.fov_deg.to_radians()).tan();
        Ok(Self {
            eye,
            forward,
            right,
            up,
            focal,
            width,
            height,
        })
    }

    /// Image width in pixels.
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Image height in pixels.
    pub fn height(&self) -> u32 {
        self.height
    }

    /// The camera position.
    pub fn eye(&self) -> Vec3 {
        self.eye
    }

    /// Focal length in pixels.
    pub fn focal(&self) -> f32 {
        self.focal
    }

    /// The ray through the centre of pixel `(x, y)` (`y` down from the top row).
    pub fn ray(&self, x: u32, y: u32) -> Ray {
        let u = x as f32 + 0.5 - 0.5 * self.width as f32;
        let v = 0.5 * self.height as f32 - (y as f32 + 0.5);
        Ray {
            origin: self.eye,
            dir: (self.focal * self.forward + u * self.right + v * self.up).normalize(),
        }
    }

    /// Where `p` appears in the image, in pixel coordinates (`(0, 0)` the top-left corner of
    /// the image, pixel `(x, y)` covering `[x, x + 1) × [y, y + 1)`), and its depth along the
    /// view direction; `None` for points behind the camera.
    pub fn project(&self, p: Vec3) -> Option<(f32, f32, f32)> {
        let d = p - self.eye;
        let depth = d.dot(self.forward);
        if depth <= 1e-6 {
            return None;
        }
        let s = self.focal / depth;
        Some((
            0.5 * self.width as f32 + s * d.dot(self.right),
            0.5 * self.height as f32 - s * d.dot(self.up),
            depth,
        ))
    }

    /// The pixel rectangle `[x0, x1) × [y0, y1)` (clamped to the image) that contains the
    /// image of a sphere, or `None` if the sphere is wholly behind the camera; a sphere that
    /// reaches behind the image plane gets the whole image.
    pub fn sphere_rect(&self, center: Vec3, radius: f32) -> Option<[u32; 4]> {
        let full = [0, 0, self.width, self.height];
        if !radius.is_finite() {
            return Some(full);
        }
        let depth = (center - self.eye).dot(self.forward);
        if depth + radius <= 0.0 {
            return None;
        }
        if depth - radius <= 1e-3 {
            return Some(full);
        }
        // The sphere lies in the box |x − cx| ≤ r, |y − cy| ≤ r, |z − depth| ≤ r (camera axes),
        // all in front of the camera; x/z is monotone in x and in z there, so the image of the
        // box spans the extremes over its corners.
        let d = center - self.eye;
        let span = |c: f32| {
            let q = [
                (c - radius) / (depth - radius),
                (c - radius) / (depth + radius),
                (c + radius) / (depth - radius),
                (c + radius) / (depth + radius),
            ];
            let lo = q.iter().copied().fold(f32::INFINITY, f32::min);
            let hi = q.iter().copied().fold(f32::NEG_INFINITY, f32::max);
            (self.focal * lo, self.focal * hi)
        };
        let (x_lo, x_hi) = span(d.dot(self.right));
        let (y_lo, y_hi) = span(d.dot(self.up));
        let (w, h) = (self.width as f32, self.height as f32);
        let clamp = |v: f32, hi: u32| v.clamp(0.0, hi as f32) as u32;
        let rect = [
            clamp((0.5 * w + x_lo).floor(), self.width),
            clamp((0.5 * h - y_hi).floor(), self.height),
            clamp((0.5 * w + x_hi).ceil() + 1.0, self.width),
            clamp((0.5 * h - y_lo).ceil() + 1.0, self.height),
        ];
        (rect[0] < rect[2] && rect[1] < rect[3]).then_some(rect)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cfg(eye: (f32, f32, f32), lookat: (f32, f32, f32)) -> ViewerCfg {
        ViewerCfg {
            eye,
            lookat,
            fov_deg: 60.0,
            resolution: (64, 48),
            ..ViewerCfg::default()
        }
    }

    #[test]
    fn lookat_projects_to_the_image_centre_and_rays_go_back_through_pixels() {
        let cam = Camera::new(&cfg((2.0, -1.0, 1.5), (0.3, 0.2, 0.1))).unwrap();
        let (x, y, _) = cam.project(Vec3::new(0.3, 0.2, 0.1)).unwrap();
        assert!((x - 32.0).abs() < 1e-4 && (y - 24.0).abs() < 1e-4);
        // A point on the ray through a pixel's centre projects to that centre.
        for (px, py) in [(0, 0), (63, 47), (10, 30)] {
            let r = cam.ray(px, py);
            let (x, y, _) = cam.project(r.origin + 3.0 * r.dir).unwrap();
            assert!((x - (px as f32 + 0.5)).abs() < 1e-3 && (y - (py as f32 + 0.5)).abs() < 1e-3);
        }
        // World up is image up: a point above the look-at point has a smaller row.
        let (_, y_above, _) = cam.project(Vec3::new(0.3, 0.2, 0.5)).unwrap();
        assert!(y_above < 24.0);
        // The image's top edge is half the field of view above the axis: the top row's centre
        // (23.5 of 24 half-rows up, half a column right) is at atan(√(23.5² + 0.5²)/24 ·
        // tan 30°) from the axis.
        let top = cam.ray(32, 0).dir;
        let axis = (Vec3::new(0.3, 0.2, 0.1) - Vec3::new(2.0, -1.0, 1.5)).normalize();
        let angle = top.dot(axis).acos();
        let expected = ((23.5f32.hypot(0.5) / 24.0) * 30f32.to_radians().tan()).atan();
        assert!((angle - expected).abs() < 1e-4, "{angle} vs {expected}");
    }

    #[test]
    fn looking_straight_down_works_and_bad_configs_name_their_field() {
        let cam = Camera::new(&cfg((0.0, 0.0, 2.0), (0.0, 0.0, 0.0))).unwrap();
        assert!(cam.ray(32, 24).dir.z < -0.99);
        let err = Camera::new(&cfg((1.0, 1.0, 1.0), (1.0, 1.0, 1.0))).unwrap_err();
        assert!(err.to_string().contains("eye"), "{err}");
        let mut bad = cfg((1.0, 0.0, 1.0), (0.0, 0.0, 0.0));
        bad.resolution = (0, 10);
        assert!(
            Camera::new(&bad)
                .unwrap_err()
                .to_string()
                .contains("resolution")
        );
        bad.resolution = (10, 10);
        bad.fov_deg = 180.0;
        assert!(
            Camera::new(&bad)
                .unwrap_err()
                .to_string()
                .contains("fov_deg")
        );
    }
}
