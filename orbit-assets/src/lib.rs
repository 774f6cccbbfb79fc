//! orbit-assets: turns robot description files into [`orbit_core::scene::ArticulationModel`]s
//! and ships the assets of the Franka box-pushing task.
//!
//! - [`model_from_urdf_str`] / [`model_from_urdf_file`]: URDF import (revolute, continuous,
//!   prismatic and fixed joints; primitive collision shapes; full inertia tensors). Every
//!   problem in a file is reported as an [`AssetError`] naming the file and the element.
//! - [`bundled`] / [`bundled_names`]: files compiled into the crate: the Franka Panda with the
//!   Fancy Gym push rod (`franka_panda_rod.urdf`) and the box-pushing scene
//!   (`box_pushing_scene.ron`).
//! - [`box_pushing_scene_cfg`]: the bundled scene as an [`orbit_core::scene::SceneCfg`], with
//!   command-line style overrides.
//! - [`load_model`] / [`model_loader`]: resolve an [`orbit_core::scene::AssetSource`] against
//!   the file system and the bundled assets.

#![warn(missing_docs)]

mod bundled;
mod error;
mod urdf;

pub use bundled::{
    box_pushing_scene, box_pushing_scene_cfg, bundled, bundled_names, bundled_scene, load_model,
    load_scene, model_loader,
};
pub use error::AssetError;
pub use urdf::{model_from_urdf_file, model_from_urdf_str};
