//! Errors of the vectorised envs: their configs, and envs that do not fit the wrapper.

/// Why a vectorised env could not be built or stepped.
#[derive(Debug, thiserror::Error)]
pub enum VecEnvError {
    /// A config file could not be read or parsed (the message names file, line and field).
    #[error(transparent)]
    Config(#[from] orbit_core::config::ConfigError),
    /// The environment failed (bad env config, invalid actions, backend errors).
    #[error(transparent)]
    Env(#[from] orbit_managers::EnvError),
    /// A wrapper config parsed but holds a value the env cannot use.
    #[error("{file}: field `{field}`: {message}")]
    InvalidConfig {
        /// Config file name.
        file: String,
        /// Field path.
        field: String,
        /// What is wrong and what is expected.
        message: String,
    },
    /// The env does not fit (missing observation group, unsupported terms, sizes that disagree).
    #[error("environment: {0}")]
    Mismatch(String),
    /// A movement primitive's config or input is unusable (black-box envs).
    #[error(transparent)]
    Mp(#[from] orbit_mp::MpError),
    /// The video recorder could not be set up.
    #[error(transparent)]
    Render(#[from] orbit_render::RenderError),
}
