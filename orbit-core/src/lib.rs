//! orbit-core: what every layer of orbit-rs shares — scene and asset descriptions, the
//! physics-backend trait and registry, RON config loading, kinematics, and per-env RNG.

#![warn(missing_docs)]

pub mod config;
pub mod kinematics;
pub mod math;
pub mod parallel;
pub mod physics;
pub mod rng;
pub mod scene;

pub use glam;
pub use inventory;
