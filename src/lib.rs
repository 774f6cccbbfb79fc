//! orbit-rs: massively parallel robot learning in Rust.
//!
//! This umbrella crate re-exports the workspace crates and hosts the examples
//! (`cargo run --release --example benchmark`). Linking it registers every built-in physics
//! backend.

pub use orbit_assets as assets;
pub use orbit_core as core;
pub use orbit_managers as managers;
pub use orbit_physics_rapier as physics_rapier;
pub use orbit_physics_wgpu as physics_wgpu;
pub use orbit_rl as rl;
pub use orbit_task_box_pushing as task_box_pushing;
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

/// Builds a registered task as the learner sees it: a step-based task as an
/// [`RlVecEnv`](rl::RlVecEnv), a black-box task as a [`BlackBoxEnv`](rl::BlackBoxEnv) (its
/// registered config with `black_box_overrides`). `env_overrides` apply to the step-based env.
pub fn make_vec_env(
    task: &str,
    env_overrides: &[String],
    black_box_overrides: &[String],
) -> Result<Box<dyn rl::VecEnv>, rl::RlError> {
    let env = make(task, env_overrides)?;
    Ok(match managers::black_box_task(task) {
        Some(bb) => Box::new(rl::BlackBoxEnv::from_ron(
            env,
            bb.config,
            bb.file_name,
            &bb.overrides_with(black_box_overrides),
        )?),
        None => Box::new(rl::RlVecEnv::new(env)?),
    })
}

/// References the backend and task crates so their `inventory` registrations are linked in.
pub fn link_registrations() {
    let _ = (
        physics_rapier::BACKEND_NAME,
        physics_wgpu::BACKEND_NAME,
        task_box_pushing::SUCCESS_DISTANCE,
        task_reach::TASK_ID,
    );
}

/// The env flags every example shares (Isaac Lab's names).
#[derive(clap::Args, Debug, Clone, Default)]
pub struct EnvArgs {
    /// Number of envs (default: the config's).
    #[arg(long)]
    pub num_envs: Option<usize>,
    /// Seed (default: the config's).
    #[arg(long)]
    pub seed: Option<u64>,
    /// Physics backend (`rapier` on the CPU, `wgpu` on the GPU).
    #[arg(long)]
    pub backend: Option<String>,
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
pub mod learner;
pub mod train;
