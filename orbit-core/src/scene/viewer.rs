//! Where the camera of rendered frames and videos looks from (Isaac Lab's `ViewerCfg`), and the
//! debug markers a task can ask to be drawn (its commands' targets).

use std::collections::BTreeMap;

use glam::Vec3;
use serde::{Deserialize, Serialize};

use super::Geometry;
use crate::math::Pose;

/// The camera of an env's rendered frames, in the env's own frame (Isaac Lab's `ViewerCfg` with
/// `origin_type = "env"`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ViewerCfg {
    /// Camera position (m, env frame).
    pub eye: (f32, f32, f32),
    /// Point the camera looks at (m, env frame); the image's up is world `+z`.
    pub lookat: (f32, f32, f32),
    /// Vertical field of view in degrees.
    pub fov_deg: f32,
    /// Image width and height in pixels.
    pub resolution: (u32, u32),
    /// The env whose scene is rendered.
    pub env_index: usize,
    /// Colours `(r, g, b)` in `[0, 1]` by asset name (articulation, rigid or static object);
    /// assets not listed get a default by kind.
    pub colors: BTreeMap<String, (f32, f32, f32)>,
}

impl Default for ViewerCfg {
    fn default() -> Self {
        Self {
            eye: (1.9, -1.5, 1.3),
            lookat: (0.35, 0.0, 0.15),
            fov_deg: 45.0,
            resolution: (320, 240),
            env_index: 0,
            colors: BTreeMap::new(),
        }
    }
}

impl ViewerCfg {
    /// The camera position as a vector.
    pub fn eye(&self) -> Vec3 {
        Vec3::from(self.eye)
    }

    /// The look-at point as a vector.
    pub fn lookat(&self) -> Vec3 {
        Vec3::from(self.lookat)
    }
}

/// What a [`Marker`] draws.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum MarkerShape {
    /// Every collision shape of the scene's rigid object with this index (a "ghost" of it).
    RigidObject(usize),
    /// One primitive.
    Geometry(Geometry),
}

/// A visual-only shape at a pose in an env's frame (e.g. a command's target), drawn
/// translucent over the scene; it takes no part in the physics.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Marker {
    /// What is drawn.
    pub shape: MarkerShape,
    /// Where (env frame).
    pub pose: Pose,
    /// Colour `(r, g, b)` in `[0, 1]`.
    pub color: [f32; 3],
    /// Opacity in `(0, 1]`.
    pub opacity: f32,
}
