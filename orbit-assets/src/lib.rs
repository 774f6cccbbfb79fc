//! orbit-assets: turns robot description files into [`orbit_core::scene::ArticulationModel`]s
//! and ships the assets of the Franka box-pushing task.
//!
//! - [`model_from_urdf_str`] / [`model_from_urdf_file`]: URDF import (revolute, continuous,
//!   prismatic and fixed joints; primitive collision shapes; full inertia tensors). Every
//!   problem in a file is reported as an [`AssetError`] naming the file and the element.
//! - [`model_from_mjcf_str`] / [`model_from_mjcf_file`]: MJCF import for the subset the
//!   classic locomotion models use (hinge, slide and free joints, primitive geoms, default
//!   classes, motors), into an articulation with a fixed or floating base.
//! - [`asset_cfg`] / [`AssetCfgDef`]: asset configs registered by name (Isaac Lab's
//!   `FRANKA_PANDA_CFG`): `franka_panda_rod`, `cartpole`, `ant`, `humanoid`, `push_box`, `lab_table`,
//!   `franka_mount`, `ground_plane`; scenes compose them by name ([`compose_scene`]).
//! - [`bundled`] / [`bundled_names`]: files compiled into the crate: the Franka Panda with the
//!   Fancy Gym push rod (`franka_panda_rod.urdf`), the cart-pole (`cartpole.urdf`), MuJoCo's
//!   Ant (`ant.xml`, and `isaac_ant.xml` with Isaac Gym's joint settings), Isaac Gym's
//!   Humanoid (`isaac_humanoid.xml`) and Fancy Gym's
//!   box-pushing scene (`scenes/box_pushing.ron`).
//! - [`box_pushing_scene_cfg`]: that scene as an [`orbit_core::scene::SceneCfg`], with
//!   command-line style overrides.
//! - [`load_model`] / [`model_loader`]: resolve an [`orbit_core::scene::AssetSource`] against
//!   the file system and the bundled assets; [`anchor_asset_paths`] makes a config's file paths
//!   relative to the config file that names them, [`asset_record`] lists what it loads.

#![warn(missing_docs)]

mod asset_cfg;
mod asset_paths;
mod bundled;
mod compose;
mod error;
mod mjcf;
mod urdf;

pub use asset_cfg::{AssetCfgDef, AssetKind, asset_cfg, asset_cfgs};
pub use asset_paths::{anchor_asset_paths, asset_record, is_explicit_path};
pub use bundled::{
    box_pushing_scene, box_pushing_scene_cfg, bundled, bundled_names, load_model, load_scene,
    model_loader, resolve_scene,
};
pub use compose::{compose_env_scene, compose_scene};
pub use error::AssetError;
pub use inventory;
pub use mjcf::{MjcfActuator, MjcfModel, model_from_mjcf_file, model_from_mjcf_str};
pub use urdf::{
    UrdfOptions, model_from_urdf_file, model_from_urdf_file_with, model_from_urdf_str,
    model_from_urdf_str_with,
};
