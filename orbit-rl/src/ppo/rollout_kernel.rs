//! The GPU learner's collection pass outside burn: the stacked actor and critic as
//! [`orbit_mlp_wgpu::StackedMlp`] kernels on the learner's device, one submission and one read
//! per step instead of a dozen tensor operations, each of which costs burn's GPU backend host
//! time (docs/training.md).

use burn::tensor::Device;
use orbit_mlp_wgpu::StackedMlp;

use crate::RlError;
use crate::model::{StackedActorCritic, kernel_activation};

/// The most rows (envs) the kernels collect for. They save burn's fixed host cost per step,
/// which dominates small batches; larger batches amortise it, and there the kernels' second
/// upload of the observations costs more than they save (docs/experiments/rollout-kernel.md).
const MAX_ROWS: usize = 8192;

/// The stacked networks' kernels.
pub(super) struct RolloutKernel {
    mlp: StackedMlp,
    /// Floats of [`Self::forward`]'s output.
    outputs: usize,
}

impl RolloutKernel {
    /// The kernels for `stacked` on `rows` rows, where the learner runs on a GPU whose wgpu
    /// device was shared (see [`orbit_mlp_wgpu::share_device`]): with the fused update
    /// always (burn's copy of the network is then on the CPU), with burn's GPU update up to
    /// [`MAX_ROWS`]; else `None`.
    pub(super) fn for_learner(
        device: &Device,
        stacked: &StackedActorCritic,
        rows: usize,
        fused: bool,
    ) -> Result<Option<Self>, RlError> {
        if !fused && (rows > MAX_ROWS || crate::on_cpu(device)) {
            return Ok(None);
        }
        let Some((wgpu_device, queue)) = orbit_mlp_wgpu::shared_device() else {
            return Ok(None);
        };
        let widths = stacked.widths();
        let activation = kernel_activation(stacked.activation());
        let mlp = StackedMlp::new(&wgpu_device, &queue, rows, 2, &widths, activation)
            .map_err(|e| RlError::Device(e.to_string()))?;
        let outputs = 2 * rows * widths.last().expect("a network has outputs");
        Ok(Some(Self { mlp, outputs }))
    }

    /// Copies `stacked`'s parameters into the kernels' buffers.
    pub(super) fn load(&mut self, stacked: &StackedActorCritic) -> Result<(), RlError> {
        for (l, (w, b)) in stacked.host_layers().iter().enumerate() {
            self.mlp
                .load_layer(l, w, b)
                .map_err(|e| RlError::Device(e.to_string()))?;
        }
        Ok(())
    }

    /// `[2, rows, num_actions]` for the actor's observations and the critic's (`None` where
    /// it reads the actor's), as [`StackedActorCritic::forward`] lays them out.
    pub(super) fn forward(
        &mut self,
        obs: &[f32],
        critic_obs: Option<&[f32]>,
    ) -> Result<Vec<f32>, RlError> {
        let inputs: Vec<&[f32]> = match critic_obs {
            Some(c) => vec![obs, c],
            None => vec![obs],
        };
        let mut out = vec![0.0; self.outputs];
        self.mlp
            .forward(&inputs, &mut out)
            .map_err(|e| RlError::Device(e.to_string()))?;
        Ok(out)
    }
}
