//! orbit-managers: Isaac Lab's manager-based RL environment in Rust.
//!
//! An environment is a RON config: a scene, physics settings, and named terms for actions,
//! observations, rewards, terminations, events and commands. Terms are registered by name with
//! `inventory` (built-ins in [`mdp`], task crates add their own) and get typed parameters from
//! the config. [`ManagerBasedRlEnv`] steps all envs in Isaac Lab's order.

#![warn(missing_docs)]

pub mod cfg;
pub mod diff_ik;
mod env;
mod error;
pub mod managers;
pub mod mdp;
mod scene;
pub mod task;
pub mod term;

pub use env::{EnvRngs, EnvView, Extras, ManagerBasedRlEnv, StepResult};
pub use error::EnvError;
pub use scene::Scene;
pub use task::{TaskDef, make, tasks};
