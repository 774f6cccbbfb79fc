//! Errors of environment construction and stepping.

use orbit_core::config::ConfigError;
use orbit_core::physics::PhysicsError;

/// Errors raised while building or stepping a manager-based environment.
#[derive(Debug, thiserror::Error)]
pub enum EnvError {
    /// The config file is malformed (file:line:col, field path, expectation in the message).
    #[error(transparent)]
    Config(#[from] ConfigError),
    /// The scene or its assets do not resolve.
    #[error(transparent)]
    Asset(#[from] orbit_assets::AssetError),
    /// The physics backend refused an operation.
    #[error(transparent)]
    Physics(#[from] PhysicsError),
    /// A term name that no crate registered.
    #[error("{field}: no {kind} term named `{name}`; registered {kind} terms: {available:?}")]
    UnknownTerm {
        /// Config field of the term.
        field: String,
        /// Term kind ("observation", "reward", ...).
        kind: &'static str,
        /// Requested name.
        name: String,
        /// Registered names.
        available: Vec<String>,
    },
    /// A term's parameters or scene references are invalid.
    #[error("{field}: {message}")]
    InvalidTerm {
        /// Config field of the term.
        field: String,
        /// What is wrong and what is expected.
        message: String,
    },
    /// A state write (episode counters, …) with values the env cannot take.
    #[error("invalid state: {0}")]
    InvalidState(String),
    /// An action batch of the wrong shape or with non-finite values.
    #[error("invalid action: {0}")]
    InvalidAction(String),
    /// The simulated state became non-finite or exploded in a step: the simulation settings,
    /// not the policy, are at fault.
    #[error(
        "the physics became unstable in env step {step} (counted from the env's start; \
         {substeps} physics steps of {dt} s each): {instability}. Lower `sim.dt`, raise \
         `sim.solver_iterations` (now {solver_iterations}; 0 is the backend's default), or \
         check the scene's masses, stiffnesses and gains. With `sim.keep_pre_step_state=true` \
         the log gives the state the step began from, for the `replay_step` example"
    )]
    Unstable {
        /// Env steps since the env was built, the failing one included.
        step: u64,
        /// Physics steps per env step (`decimation`).
        substeps: usize,
        /// The physics time step.
        dt: f32,
        /// The configured solver iterations.
        solver_iterations: usize,
        /// The quantity that went out of range, where.
        instability: orbit_core::physics::Instability,
    },
    /// A step observer (e.g. a video recorder) failed.
    #[error("step observer: {0}")]
    Observer(String),
}
