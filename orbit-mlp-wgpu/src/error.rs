//! What can go wrong building or running a [`StackedMlp`](crate::StackedMlp).

/// An error of this crate.
#[derive(Debug, thiserror::Error)]
pub enum MlpError {
    /// A network's shape or a buffer's length does not fit.
    #[error("{0}")]
    Shape(String),
    /// The device refused a kernel or a buffer, or lost the results.
    #[error("the GPU could not run the networks: {0}")]
    Device(String),
}
