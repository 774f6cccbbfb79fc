//! orbit-rs: massively parallel robot learning in Rust.
//!
//! This umbrella crate re-exports the workspace crates and hosts the examples
//! (`cargo run --release --example benchmark`). Linking it registers every built-in physics
//! backend.

use std::path::{Path, PathBuf};

pub use orbit_assets as assets;
pub use orbit_core as core;
pub use orbit_managers as managers;
pub use orbit_physics_rapier as physics_rapier;
pub use orbit_physics_wgpu as physics_wgpu;
pub use orbit_render as render;
pub use orbit_rl as rl;
pub use orbit_task_box_pushing as task_box_pushing;
pub use orbit_task_box_to_spot as task_box_to_spot;
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

/// A step-based or black-box env behind one type.
pub type BoxedVecEnv = Box<dyn rl::VecEnv>;

/// The config files of a run: a registered task's, with any of them replaced by a file.
#[derive(Clone, Debug)]
pub struct RunConfigs {
    /// The task id, or the env file's name for a task given only as a file.
    pub name: String,
    /// The env config (for a black-box task, the step-based env it wraps).
    pub env: PathBuf,
    /// The training config, if there is one.
    pub agent: Option<PathBuf>,
    /// The black-box wrapper config of an episodic task.
    pub black_box: Option<PathBuf>,
}

impl RunConfigs {
    /// The configs of `task` (a registered id; `None`: the task given by `task_config`, or
    /// else `default_task`), each replaced by the file given for it.
    pub fn resolve(
        task: Option<&str>,
        default_task: &str,
        task_config: Option<&Path>,
        agent_config: Option<&Path>,
        bb_config: Option<&Path>,
    ) -> Result<Self, managers::EnvError> {
        link_registrations();
        let registered = match (task, task_config) {
            (Some(id), _) => Some(managers::task(id)?),
            (None, Some(_)) => None,
            (None, None) => Some(managers::task(default_task)?),
        };
        let name = match (&registered, task_config) {
            (Some(t), _) => t.id.to_string(),
            (None, Some(file)) => file.display().to_string(),
            (None, None) => unreachable!("a task without a file is the default task"),
        };
        let file = |given: Option<&Path>, registered: Option<PathBuf>| {
            given.map(Path::to_path_buf).or(registered)
        };
        Ok(Self {
            name,
            env: file(task_config, registered.as_ref().map(|t| t.env.clone()))
                .expect("a registered task or a file"),
            agent: file(
                agent_config,
                registered.as_ref().and_then(|t| t.agent.clone()),
            ),
            black_box: file(bb_config, registered.and_then(|t| t.black_box)),
        })
    }
}

/// The step-based env of `task` (default: the torque box-pushing task) or of the env file
/// `task_config` with overrides, and its name, for the scripts that step an env without
/// learning.
pub fn make_env(
    task: Option<&str>,
    task_config: Option<&Path>,
    overrides: &[String],
) -> Result<(managers::ManagerBasedRlEnv, String), managers::EnvError> {
    let configs =
        RunConfigs::resolve(task, "BoxPushing-Torque-Franka-v0", task_config, None, None)?;
    Ok((
        managers::make_from_file(&configs.env, overrides)?,
        configs.name,
    ))
}

/// The task `train` and `play` use when none is named.
pub const DEFAULT_TASK: &str = "BoxPushing-JointPos-Franka-v0";

/// Builds a run's env as the learner sees it: a step-based env as an
/// [`RlVecEnv`](rl::RlVecEnv), or, when the run has a black-box config, a
/// [`BlackBoxEnv`](rl::BlackBoxEnv) around it (with `black_box_overrides`). `env_overrides`
/// apply to the step-based env. With `video`, a [`VideoRecorder`](render::VideoRecorder)
/// renders the env's viewer camera (a black-box env's every inner step), and its progress
/// handle is returned too.
pub fn make_vec_env(
    configs: &RunConfigs,
    env_overrides: &[String],
    black_box_overrides: &[String],
    video: Option<render::VideoCfg>,
) -> Result<(BoxedVecEnv, Option<render::VideoProgress>), Box<dyn std::error::Error>> {
    link_registrations();
    let mut env = managers::make_from_file(&configs.env, env_overrides)?;
    let progress = match video {
        Some(cfg) => {
            let recorder = render::VideoRecorder::new(&env, cfg)?;
            let progress = recorder.progress();
            env.set_step_observer(Some(Box::new(recorder)));
            Some(progress)
        }
        None => None,
    };
    let vec_env: BoxedVecEnv = match &configs.black_box {
        Some(path) => {
            let doc = managers::load_config(path, black_box_overrides)?;
            Box::new(rl::BlackBoxEnv::from_document(env, &doc)?)
        }
        None => Box::new(rl::RlVecEnv::new(env)?),
    };
    Ok((vec_env, progress))
}

/// The exit code of an example's `main`: success, or the error's message (not its debug
/// form) on standard error and failure.
pub fn exit_code<T>(result: Result<T, Box<dyn std::error::Error>>) -> std::process::ExitCode {
    match result {
        Ok(_) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            std::process::ExitCode::FAILURE
        }
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
    /// Physics backend (`rapier` on the CPU, `wgpu` on the GPU).
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
