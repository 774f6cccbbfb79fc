//! Small geometric helpers on top of glam: rigid poses and the `[w, x, y, z]` quaternion
//! convention used by every config file (Isaac Lab and MuJoCo both write quaternions scalar-first).

use glam::{Mat3, Quat, Vec3};
use serde::{Deserialize, Deserializer, Serialize, Serializer};

/// A rigid transform: rotation followed by translation (`x_parent = rot * x_child + pos`).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Pose {
    /// Translation in metres.
    #[serde(default = "zero_vec")]
    pub pos: Vec3,
    /// Rotation, written `(w, x, y, z)` in configs.
    #[serde(default = "identity_quat", with = "wxyz")]
    pub rot: Quat,
}

fn zero_vec() -> Vec3 {
    Vec3::ZERO
}
fn identity_quat() -> Quat {
    Quat::IDENTITY
}

impl Default for Pose {
    fn default() -> Self {
        Self::IDENTITY
    }
}

impl Pose {
    /// The identity transform.
    pub const IDENTITY: Pose = Pose {
        pos: Vec3::ZERO,
        rot: Quat::IDENTITY,
    };

    /// A pose from a translation and a rotation.
    pub fn new(pos: Vec3, rot: Quat) -> Self {
        Self { pos, rot }
    }

    /// A pure translation.
    pub fn from_pos(pos: Vec3) -> Self {
        Self {
            pos,
            rot: Quat::IDENTITY,
        }
    }

    /// Composition `self * rhs` (apply `rhs` first).
    pub fn mul_pose(&self, rhs: &Pose) -> Pose {
        Pose {
            pos: self.pos + self.rot * rhs.pos,
            rot: (self.rot * rhs.rot).normalize(),
        }
    }

    /// Maps a point from this pose's local frame into its parent frame.
    pub fn transform_point(&self, p: Vec3) -> Vec3 {
        self.pos + self.rot * p
    }

    /// The inverse transform.
    pub fn inverse(&self) -> Pose {
        let inv = self.rot.conjugate();
        Pose {
            pos: -(inv * self.pos),
            rot: inv,
        }
    }
}

/// Builds a quaternion from scalar-first components `[w, x, y, z]`, normalising it
/// (URDF/MuJoCo files often carry rounded values such as 0.707107).
pub fn quat_wxyz(q: [f32; 4]) -> Quat {
    Quat::from_xyzw(q[1], q[2], q[3], q[0]).normalize()
}

/// Scalar-first components `[w, x, y, z]` of a quaternion.
pub fn to_wxyz(q: Quat) -> [f32; 4] {
    [q.w, q.x, q.y, q.z]
}

/// Rotates a symmetric inertia tensor into another frame: `R I Rᵀ`.
pub fn rotate_inertia(rot: Quat, inertia: Mat3) -> Mat3 {
    let r = Mat3::from_quat(rot);
    r * inertia * r.transpose()
}

/// Skew-symmetric cross-product matrix `[v]×`.
pub fn skew(v: Vec3) -> Mat3 {
    Mat3::from_cols(
        Vec3::new(0.0, v.z, -v.y),
        Vec3::new(-v.z, 0.0, v.x),
        Vec3::new(v.y, -v.x, 0.0),
    )
}

/// Geodesic angle between two orientations in radians, in `[0, π]`: `2 acos(|⟨a, b⟩|)`
/// evaluated as `2 atan2(|v|, |w|)` of the relative rotation `a⁻¹ b = (v, w)`, which stays
/// accurate near 0 (in f32 the `acos` form cannot resolve angles below ~5e-4 rad: one ulp off
/// a unit norm already reads as 7e-4 rad) and does not care about the quaternions' norms.
pub fn rotation_distance(a: Quat, b: Quat) -> f32 {
    let d = a.conjugate() * b;
    2.0 * glam::Vec3::new(d.x, d.y, d.z).length().atan2(d.w.abs())
}

/// Serde adapter reading and writing a [`Quat`] as `(w, x, y, z)`.
pub mod wxyz {
    use super::*;

    /// Serialises as `(w, x, y, z)`.
    pub fn serialize<S: Serializer>(q: &Quat, s: S) -> Result<S::Ok, S::Error> {
        (q.w, q.x, q.y, q.z).serialize(s)
    }

    /// Deserialises `(w, x, y, z)` and normalises; a zero quaternion is an error.
    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Quat, D::Error> {
        let (w, x, y, z) = <(f32, f32, f32, f32)>::deserialize(d)?;
        let q = Quat::from_xyzw(x, y, z, w);
        let n = q.length();
        if !(n.is_finite() && n > 1e-6) {
            return Err(serde::de::Error::custom(
                "expected a non-zero quaternion (w, x, y, z)",
            ));
        }
        Ok(q / n)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The angle of a known rotation, also for tiny angles (where `2 acos` in f32 reads 0 or
    /// ~5e-4) and for quaternions off unit norm.
    #[test]
    fn rotation_distance_is_the_relative_angle() {
        let a = Quat::from_euler(glam::EulerRot::XYZ, 0.3, -1.2, 2.0);
        let axis = Vec3::new(1.0, 2.0, -0.5).normalize();
        for angle in [1e-5f32, 1e-3, 0.3, 2.0, 3.1] {
            let b = a * Quat::from_axis_angle(axis, angle);
            let d = rotation_distance(a, b);
            assert!((d - angle).abs() < 1e-6 + 1e-6 * angle, "{angle}: {d}");
            // q and −q are the same rotation; the norm does not matter.
            assert!((rotation_distance(a, -b * 1.0001) - angle).abs() < 1e-6 + 1e-6 * angle);
        }
        assert_eq!(rotation_distance(a, a), 0.0);
    }
}
