//! orbit-rs: massively parallel robot learning in Rust.
//!
//! This umbrella crate re-exports the workspace crates and hosts the examples
//! (`cargo run --release --example benchmark`). Linking it registers every built-in physics
//! backend.

pub use orbit_assets as assets;
pub use orbit_core as core;
pub use orbit_physics_rapier as physics_rapier;
