//! Small dense networks (MLPs) on wgpu for the GPU learner: batched forward passes of the
//! policy and value networks that pick the actions of thousands of envs at every collection
//! step ([`StackedMlp`]), and PPO's whole update of them ([`PpoTrainer`]).
//!
//! A GPU learner built on a tensor library pays host time for every tensor operation (recording
//! it, matching it against fused kernels, handing it to the device's thread); a forward pass of
//! two four-layer networks is a dozen such operations for well under a millisecond of device
//! work. [`StackedMlp`] instead keeps its weights in its own buffers and runs every layer of
//! several networks of equal widths ("stacks": an actor and a critic) as one dispatch per
//! layer, uploading the inputs and reading the outputs back once per call.
//!
//! Each output is one invocation's sum over its inputs in a fixed order (the trainer's sums over
//! rows are split into chunks and then added in order), so a pass or an update gives the same
//! bits on every run of the same device and driver (no atomics).

mod device;
mod error;
mod layer;
mod readback;
mod train;

pub use device::{share_device, shared_device};
pub use error::MlpError;
pub use layer::{Activation, StackedMlp};
pub use train::{PpoSettings, PpoShape, PpoTrainer, UpdateInputs, UpdateOutcome};

/// The wgpu crate this one is built on, for callers that hand it their device.
pub use wgpu;
