//! orbit-rs envs as learners see them (RSL-RL's `VecEnv`, Isaac Lab's `RslRlVecEnvWrapper`):
//!
//! - [`VecEnv`]: a batch of self-resetting envs with actor and critic observations;
//! - [`RlVecEnv`]: a [`ManagerBasedRlEnv`](orbit_managers::ManagerBasedRlEnv) behind it;
//! - [`BlackBoxEnv`]: Fancy Gym's black-box wrapper, one movement primitive per episode;
//! - [`RunConfigs`] / [`make_vec_env`]: a run's env from a registered task's config files, any
//!   of them replaced by a file.
//!
//! Learners (`orbit-rl`) depend on this crate, never the reverse.

#![warn(missing_docs)]

pub mod black_box;
mod error;
mod make;
pub mod vec_env;

pub use black_box::{BlackBoxCfg, BlackBoxEnv};
pub use error::VecEnvError;
pub use make::{BoxedVecEnv, DEFAULT_STEP_TASK, DEFAULT_TASK, RunConfigs, make_env, make_vec_env};
pub use vec_env::{RlVecEnv, VecEnv, VecEnvStep};
