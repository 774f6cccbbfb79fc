//! Errors of the learners and the runner.

use std::path::PathBuf;

/// Everything that can go wrong while training or replaying a policy.
#[derive(Debug, thiserror::Error)]
pub enum RlError {
    /// A runner config could not be parsed (the message names file, line and field).
    #[error(transparent)]
    Config(#[from] orbit_core::config::ConfigError),
    /// The environment failed (bad env config, invalid actions, backend errors).
    #[error(transparent)]
    Env(#[from] orbit_managers::EnvError),
    /// The vectorised env failed (its wrapper's config, an env that does not fit it).
    #[error(transparent)]
    VecEnv(#[from] orbit_envs::VecEnvError),
    /// A runner config parsed but holds a value the learner cannot use.
    #[error("{file}: field `{field}`: {message}")]
    InvalidConfig {
        /// Config file name.
        file: String,
        /// Field path.
        field: String,
        /// What is wrong and what is expected.
        message: String,
    },
    /// The env does not fit the learner (missing observation group, sizes that disagree).
    #[error("environment: {0}")]
    EnvMismatch(String),
    /// The training (agent) config cannot be loaded or is missing.
    #[error("agent config: {0}")]
    AgentConfig(String),
    /// Reading or writing a run directory failed.
    #[error("{path}: {source}")]
    Io {
        /// The file or directory.
        path: PathBuf,
        /// The underlying error.
        source: std::io::Error,
    },
    /// The task named on the command line is not registered.
    #[error("unknown task `{task}`; the tasks `train` can train: {trainable:?}")]
    UnknownTask {
        /// The name given.
        task: String,
        /// The registered tasks with a training config.
        trainable: Vec<String>,
    },
    /// A checkpoint is missing, unreadable or does not match the network.
    #[error("checkpoint {path}: {message}")]
    Checkpoint {
        /// The checkpoint file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// Drawing the training curves failed.
    #[error("{path}: plotting failed: {message}")]
    Plot {
        /// The image file.
        path: PathBuf,
        /// What went wrong.
        message: String,
    },
    /// A rank of a data-parallel run failed; the others stopped with it.
    #[error("rank {rank}: {message}")]
    RankFailed {
        /// The rank that failed.
        rank: usize,
        /// What went wrong there.
        message: String,
    },
    /// This rank of a data-parallel run stopped because rank `by` failed.
    #[error("stopped: rank {by} failed")]
    RankStopped {
        /// The rank that failed.
        by: usize,
    },
    /// The learner's device could not be opened.
    #[error("learner device: {0}")]
    Device(String),
    /// Training was asked to stop (Ctrl-C, SIGTERM) and stopped at an env step, after saving
    /// a checkpoint of the last finished iteration.
    #[error("{}", interrupted_message(*iterations, checkpoint.as_deref()))]
    Interrupted {
        /// Iterations finished (those of a resumed run included).
        iterations: usize,
        /// The checkpoint written or already there (none before the first iteration ends).
        checkpoint: Option<PathBuf>,
    },
    /// A non-finite number: from the env (an observation, a reward), or from the learner (the
    /// loss, the policy's output); the message says which and what to change.
    #[error("{0}")]
    NonFinite(String),
}

/// What [`RlError::Interrupted`] tells the user: where the checkpoint is and how to go on.
fn interrupted_message(iterations: usize, checkpoint: Option<&std::path::Path>) -> String {
    match checkpoint {
        Some(base) => {
            let run = base
                .parent()
                .and_then(|d| d.file_name())
                .map_or_else(String::new, |n| n.to_string_lossy().into_owned());
            format!(
                "interrupted after {iterations} iterations; checkpoint saved: {} (continue \
                 with `train --resume --load-run {run}` and the run's other flags)",
                base.display()
            )
        }
        None if iterations == 0 => {
            "interrupted before the first iteration finished: nothing to save".to_string()
        }
        None => format!(
            "interrupted after {iterations} iterations; this process writes no checkpoints (in \
             a data-parallel run, rank 0 saves them)"
        ),
    }
}

impl RlError {
    /// Wraps an I/O error with the path it concerns.
    pub fn io(path: impl Into<PathBuf>) -> impl FnOnce(std::io::Error) -> Self {
        let path = path.into();
        move |source| RlError::Io { path, source }
    }

    /// A [`RlError::Checkpoint`] for `path` saying `message` (e.g. a burn record error).
    pub fn checkpoint(path: impl Into<PathBuf>, message: impl ToString) -> Self {
        RlError::Checkpoint {
            path: path.into(),
            message: message.to_string(),
        }
    }
}
