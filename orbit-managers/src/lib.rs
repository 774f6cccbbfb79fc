//! orbit-managers: Isaac Lab's manager-based RL environment in Rust.
//!
//! An environment is a RON config: a scene, physics settings, and named terms for actions,
//! observations, rewards, terminations, events and commands. Terms are registered by name with
//! `inventory` (built-ins in [`mdp`], task crates add their own) and get typed parameters from
//! the config. [`ManagerBasedEnv`] steps a scene through actions, events and observations;
//! [`ManagerBasedRlEnv`] adds rewards, terminations, episodes and curricula, in Isaac Lab's order.

#![warn(missing_docs)]

mod base_env;
pub mod cfg;
pub mod diff_ik;
mod error;
mod failed_step;
pub mod managers;
pub mod mdp;
pub mod ranges;
mod rl_env;
mod scene;
pub mod task;
pub mod term;

pub use base_env::{EnvRngs, EnvView, ManagerBasedEnv, StepTimings};
pub use error::EnvError;
pub use failed_step::FailedStep;
pub use rl_env::{Extras, ManagerBasedRlEnv, StepObserver, StepResult};
pub use scene::Scene;
pub use task::{
    Task, TaskDef, TaskTable, bundled_configs, export_task_configs, load_config, load_env_config,
    make, make_from_file, task, tasks,
};
