//! A run's env from its config files: a registered task's files, any of them replaced by a
//! file of the user's, built as the learner sees it (step-based or black-box).
//!
//! The task crates and physics backends must be linked into the binary (their `inventory`
//! registrations): the umbrella crate `orbit` does that.

use std::path::{Path, PathBuf};

use crate::VecEnvError;

/// A step-based or black-box env behind one type.
pub type BoxedVecEnv = Box<dyn crate::VecEnv>;

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
    /// The training config for physics on the CPU (none when a training config was given).
    pub cpu_agent: Option<PathBuf>,
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
    ) -> Result<Self, orbit_managers::EnvError> {
        let registered = match (task, task_config) {
            (None, Some(file)) => Self {
                name: file.display().to_string(),
                env: file.to_path_buf(),
                agent: None,
                black_box: None,
                cpu_agent: None,
            },
            (id, _) => {
                let t = orbit_managers::task(id.unwrap_or(default_task))?;
                Self {
                    name: t.id.to_string(),
                    env: t.env,
                    agent: t.agent,
                    black_box: t.black_box,
                    cpu_agent: t.cpu_agent,
                }
            }
        };
        let file = |given: Option<&Path>, registered: Option<PathBuf>| {
            given.map(Path::to_path_buf).or(registered)
        };
        Ok(Self {
            env: file(task_config, Some(registered.env)).expect("given or registered"),
            agent: file(agent_config, registered.agent),
            black_box: file(bb_config, registered.black_box),
            cpu_agent: registered.cpu_agent.filter(|_| agent_config.is_none()),
            name: registered.name,
        })
    }
}

/// The task of the scripts that step an env without learning when none is named.
pub const DEFAULT_STEP_TASK: &str = "BoxPushing-Torque-Franka-v0";

/// The step-based env of `task` (default: the torque box-pushing task) or of the env file
/// `task_config` with overrides, and its name, for the scripts that step an env without
/// learning.
pub fn make_env(
    task: Option<&str>,
    task_config: Option<&Path>,
    overrides: &[String],
) -> Result<(orbit_managers::ManagerBasedRlEnv, String), orbit_managers::EnvError> {
    let configs = RunConfigs::resolve(task, DEFAULT_STEP_TASK, task_config, None, None)?;
    Ok((
        orbit_managers::make_from_file(&configs.env, overrides)?,
        configs.name,
    ))
}

/// The task `train` and `play` use when none is named.
pub const DEFAULT_TASK: &str = "BoxPushing-JointPos-Franka-v0";

/// Builds a run's env as the learner sees it: a step-based env as an
/// [`RlVecEnv`](crate::RlVecEnv), or, when the run has a black-box config, a
/// [`BlackBoxEnv`](crate::BlackBoxEnv) around it (with `black_box_overrides`). `env_overrides`
/// apply to the step-based env. With `video`, a [`VideoRecorder`](orbit_render::VideoRecorder)
/// renders the env's viewer camera (a black-box env's every inner step), and its progress
/// handle is returned too.
pub fn make_vec_env(
    configs: &RunConfigs,
    env_overrides: &[String],
    black_box_overrides: &[String],
    video: Option<orbit_render::VideoCfg>,
) -> Result<(BoxedVecEnv, Option<orbit_render::VideoProgress>), VecEnvError> {
    let mut env = orbit_managers::make_from_file(&configs.env, env_overrides)?;
    let progress = match video {
        Some(cfg) => {
            let recorder = orbit_render::VideoRecorder::new(&env, cfg)?;
            let progress = recorder.progress();
            env.set_step_observer(Some(Box::new(recorder)));
            Some(progress)
        }
        None => None,
    };
    let vec_env: BoxedVecEnv = match &configs.black_box {
        Some(path) => {
            let doc = orbit_managers::load_config(path, black_box_overrides)?;
            Box::new(crate::BlackBoxEnv::from_document(env, &doc)?)
        }
        None => Box::new(crate::RlVecEnv::new(env)?),
    };
    Ok((vec_env, progress))
}
