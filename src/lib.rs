//! orbit-rs: massively parallel robot learning in Rust.
//!
//! This umbrella crate re-exports the workspace crates and hosts the examples
//! (`cargo run --release --example benchmark`). Linking it registers every built-in physics
//! backend.

use std::path::PathBuf;

pub use orbit_assets as assets;
pub use orbit_core as core;
pub use orbit_envs as envs;
pub use orbit_envs::{BoxedVecEnv, DEFAULT_TASK, RunConfigs, make_env, make_vec_env};
pub use orbit_managers as managers;
pub use orbit_physics_rapier as physics_rapier;
pub use orbit_physics_wgpu as physics_wgpu;
pub use orbit_render as render;
pub use orbit_rl as rl;
pub use orbit_task_ant as task_ant;
pub use orbit_task_box_pushing as task_box_pushing;
pub use orbit_task_box_to_spot as task_box_to_spot;
pub use orbit_task_cartpole as task_cartpole;
pub use orbit_task_humanoid as task_humanoid;
pub use orbit_task_reach as task_reach;

/// Builds a registered task (`BoxPushing-Torque-Franka-v0`, …) with config overrides; linking
/// this crate registers every built-in backend and task.
pub fn make(
    task: &str,
    overrides: &[String],
) -> Result<managers::ManagerBasedRlEnv, managers::EnvError> {
    link_registrations();
    managers::make(task, overrides)
}

/// Logs to standard error: warnings and errors by default (a dropped collision shape, a
/// skipped run directory), more with `RUST_LOG` (e.g. `RUST_LOG=info`).
pub fn init_logging() {
    let filter = tracing_subscriber::EnvFilter::try_from_default_env()
        .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new("warn"));
    let _ = tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_writer(std::io::stderr)
        .try_init();
}

/// The exit code of an example's `main`: success, or the error's message (not its debug
/// form) on standard error and failure.
pub fn exit_code<T>(result: Result<T, Box<dyn std::error::Error>>) -> std::process::ExitCode {
    match result {
        Ok(_) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            std::process::ExitCode::from(failure_status(e.as_ref()))
        }
    }
}

/// The exit status of a failed command: 130 for a run stopped by a signal (as shells report
/// 128 + SIGINT), else 1.
pub fn failure_status(error: &(dyn std::error::Error + 'static)) -> u8 {
    match error.downcast_ref::<orbit_rl::RlError>() {
        Some(orbit_rl::RlError::Interrupted { .. }) => 130,
        _ => 1,
    }
}

/// References the backend and task crates so their `inventory` registrations are linked in.
pub fn link_registrations() {
    let _ = (
        physics_rapier::BACKEND_NAME,
        physics_wgpu::BACKEND_NAME,
        task_box_pushing::SUCCESS_DISTANCE,
        std::mem::size_of::<task_box_to_spot::ObjectPointParams>(),
        task_reach::TASK_ID,
        task_cartpole::TASK_ID,
        task_ant::TASK_ID,
        task_humanoid::TASK_ID,
    );
}

/// The env flags every example shares (Isaac Lab's names).
#[derive(clap::Args, Debug, Clone, Default)]
pub struct EnvArgs {
    /// Env config file used instead of the task's (RON; `#include`s resolve relative to it,
    /// `<bundled>/…` names a bundled file; `list_tasks --export` writes a task's files).
    /// Without `--task`, the file is the whole task.
    #[arg(long)]
    pub task_config: Option<PathBuf>,
    /// Number of envs (default: the config's).
    #[arg(long)]
    pub num_envs: Option<usize>,
    /// Seed (default: the config's).
    #[arg(long)]
    pub seed: Option<u64>,
    /// Physics backend: `auto` (the tasks' default: a GPU adapter, else Mesa's lavapipe, else
    /// rapier), `wgpu` (Vulkan: a GPU or lavapipe) or `rapier` (CPU).
    #[arg(long)]
    pub backend: Option<String>,
}

/// Video flags of `train` and `play` (Isaac Lab's `--video`, `--video_length`).
#[derive(clap::Args, Debug, Clone, Default)]
pub struct VideoArgs {
    /// Record videos (animated GIFs of the env config's `viewer` camera) into
    /// `<run>/videos/<train|play>/`.
    #[arg(long)]
    pub video: bool,
    /// Env steps per video.
    #[arg(long, default_value_t = 200)]
    pub video_length: usize,
}

/// An env override as the env config takes it: `train`'s `env.` prefix, which every command
/// accepts, removed (`env.sim.dt=0.001` and `sim.dt=0.001` are the same override).
pub fn env_override(text: &str) -> String {
    text.strip_prefix("env.").unwrap_or(text).to_string()
}

/// Chooses the physics backend that the env config `env` with `overrides` runs on here (its
/// `sim.backend`, or for `"auto"` the backend chosen for this machine, which is then said on
/// standard output with the reason and how to get a faster device when one is missing) and
/// appends the override that pins it, so the env and its `params/` use that backend.
pub fn choose_run_backend(
    env: &std::path::Path,
    overrides: &mut Vec<String>,
) -> Result<core::physics::BackendChoice, managers::EnvError> {
    let choice = pick_run_backend(env, overrides)?;
    if let Some(line) = backend_choice_line(&choice) {
        println!("{line}");
    }
    Ok(choice)
}

/// [`choose_run_backend`] without printing (a library's caller says it its own way).
pub fn pick_run_backend(
    env: &std::path::Path,
    overrides: &mut Vec<String>,
) -> Result<core::physics::BackendChoice, managers::EnvError> {
    let doc = managers::load_env_config(env, overrides)?;
    let name: String = match core::config::node_at(&doc, "sim.backend") {
        Some(node) => core::config::from_node(node)?,
        None => core::physics::AUTO_BACKEND.to_string(),
    };
    let choice = core::physics::choose_backend(&name)?;
    overrides.extend(run_overrides(None, None, Some(&choice.name), &[]));
    Ok(choice)
}

/// What `sim.backend = "auto"` chose and why, if it chose.
pub fn backend_choice_line(choice: &core::physics::BackendChoice) -> Option<String> {
    (choice.reason.as_ref()).map(|reason| {
        format!(
            "physics: `{}` (sim.backend \"auto\" chose it, {reason})",
            choice.name
        )
    })
}

/// Common command-line flags of the examples (Isaac Lab's names), turned into overrides.
pub fn run_overrides(
    num_envs: Option<usize>,
    seed: Option<u64>,
    backend: Option<&str>,
    extra: &[String],
) -> Vec<String> {
    let mut o = Vec::new();
    if let Some(n) = num_envs {
        o.push(format!("num_envs={n}"));
    }
    if let Some(s) = seed {
        o.push(format!("seed={s}"));
    }
    if let Some(b) = backend {
        o.push(format!("sim.backend=\"{b}\""));
    }
    o.extend(extra.iter().cloned());
    o
}

pub mod agent;
pub mod distributed;
pub mod learner;
pub mod npy;
pub mod play;
pub mod run_params;
pub mod signals;
pub mod train;

#[cfg(test)]
mod tests {
    /// `env.x=…` and `x=…` are one override; other prefixes are left alone.
    #[test]
    fn env_overrides_take_the_env_prefix_or_none() {
        assert_eq!(super::env_override("env.sim.dt=0.001"), "sim.dt=0.001");
        assert_eq!(super::env_override("sim.dt=0.001"), "sim.dt=0.001");
        assert_eq!(super::env_override("environment=1"), "environment=1");
    }
}
