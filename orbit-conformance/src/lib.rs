//! The backend conformance suite: physical facts and agreement with MuJoCo that every physics
//! backend must reproduce. Each check builds its scene through the backend registry by name,
//! runs it, prints what it measured and panics with a clear message if a tolerance is missed.
//! A backend crate runs the suite from its integration tests:
//!
//! ```ignore
//! #[test]
//! fn free_fall() { orbit_conformance::free_fall("rapier"); }
//! ```

mod facts;
mod floating_base;
mod franka;
mod mujoco_rollout;
mod scenes;

pub use facts::*;
pub use floating_base::*;
pub use franka::*;
pub use mujoco_rollout::*;
pub use scenes::*;
