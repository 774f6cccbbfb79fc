//! Errors of the movement primitives.

/// A movement-primitive config or input that cannot be used.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum MpError {
    /// A config field holds an unusable value.
    #[error("movement primitive config: field `{field}`: {message}")]
    InvalidConfig {
        /// The field.
        field: &'static str,
        /// What is wrong and what is expected.
        message: String,
    },
    /// Input slices whose lengths do not fit the primitive and each other.
    #[error("movement primitive input `{name}`: expected {expected} values, got {got}")]
    Length {
        /// The argument.
        name: &'static str,
        /// Its expected length.
        expected: usize,
        /// Its length.
        got: usize,
    },
    /// A parameter or start position is NaN or infinite.
    #[error("movement primitive input `{name}` of env {env} is not finite ({value})")]
    NonFinite {
        /// The argument.
        name: &'static str,
        /// The env.
        env: usize,
        /// The offending value.
        value: f32,
    },
}
