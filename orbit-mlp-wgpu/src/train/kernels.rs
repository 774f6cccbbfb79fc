//! The trainer's compute pipelines and the bindings of each dispatch.

use crate::MlpError;

const MATMUL_SOURCE: &str = concat!(
    include_str!("../activation.wgsl"),
    include_str!("matmul.wgsl")
);
const PPO_SOURCE: &str = include_str!("ppo.wgsl");

/// Rows and columns of the output tile one workgroup of `matmul.wgsl` computes.
pub(super) const TILE: usize = 64;

/// What one dispatch of `matmul.wgsl` computes (its `Params` uniform).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
pub(super) struct MatmulParams {
    pub mode: u32,
    pub rows: u32,
    pub cols: u32,
    pub depth: u32,
    pub a_off: u32,
    pub a_stride: u32,
    pub w_off: u32,
    pub b_off: u32,
    pub activation: u32,
    pub chunk_rows: u32,
    pub batch: u32,
    pub out_stride: u32,
}

/// `matmul.wgsl`'s modes.
pub(super) const FORWARD: u32 = 0;
pub(super) const BACKWARD: u32 = 1;
pub(super) const WEIGHTS: u32 = 2;

/// The entry points of `ppo.wgsl`, with the bindings each one uses.
pub(super) const GATHER: (&str, &[u32]) = ("gather", &[0, 1, 2, 3, 20]);
pub(super) const LOSS: (&str, &[u32]) = ("loss", &[0, 4, 5, 6, 7, 8, 9, 10, 11]);
pub(super) const COLUMN_SUMS: (&str, &[u32]) = ("column_sums", &[0, 12, 13]);
pub(super) const FINISH: (&str, &[u32]) = ("finish", &[0, 7, 14, 15, 16]);
pub(super) const SCALARS: (&str, &[u32]) = ("scalars", &[0, 7, 17, 18, 19]);
pub(super) const ADAM: (&str, &[u32]) = ("adam", &[0, 17, 20, 21, 22, 23]);

/// The compiled kernels.
pub(super) struct Pipelines {
    pub matmul: wgpu::ComputePipeline,
    pub gather: wgpu::ComputePipeline,
    pub loss: wgpu::ComputePipeline,
    pub column_sums: wgpu::ComputePipeline,
    pub finish: wgpu::ComputePipeline,
    pub scalars: wgpu::ComputePipeline,
    pub adam: wgpu::ComputePipeline,
}

impl Pipelines {
    /// Compiles both modules; an error says what the driver reported. Trusted, they are
    /// compiled without the clamps wgpu would put on their indices and the counters it would
    /// put on their loops: every index into workgroup memory stays below its tile by
    /// construction (`kx * 64 + r` with `kx < 16`, `r < 64`), every loop runs over uniform
    /// sizes, every buffer access is guarded by the row, column and depth counts it was
    /// sized for, and the device's robust buffer access stands behind them.
    pub(super) fn new(device: &wgpu::Device, trusted: bool) -> Result<Self, MlpError> {
        let scopes = [
            wgpu::ErrorFilter::Validation,
            wgpu::ErrorFilter::OutOfMemory,
            wgpu::ErrorFilter::Internal,
        ]
        .map(|filter| device.push_error_scope(filter));
        let module = |label: &str, source: &str| {
            let descriptor = wgpu::ShaderModuleDescriptor {
                label: Some(label),
                source: wgpu::ShaderSource::Wgsl(source.into()),
            };
            let mut checks = wgpu::ShaderRuntimeChecks::checked();
            if trusted {
                checks.bounds_checks = false;
                checks.force_loop_bounding = false;
            }
            // SAFETY: see `new`.
            unsafe { device.create_shader_module_trusted(descriptor, checks) }
        };
        let matmul = module("orbit train matmul", MATMUL_SOURCE);
        let ppo = module("orbit train ppo", PPO_SOURCE);
        let pipeline = |module: &wgpu::ShaderModule, entry: &str| {
            device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(entry),
                layout: None,
                module,
                entry_point: Some(entry),
                compilation_options: Default::default(),
                cache: None,
            })
        };
        let pipelines = Self {
            matmul: pipeline(&matmul, "main"),
            gather: pipeline(&ppo, GATHER.0),
            loss: pipeline(&ppo, LOSS.0),
            column_sums: pipeline(&ppo, COLUMN_SUMS.0),
            finish: pipeline(&ppo, FINISH.0),
            scalars: pipeline(&ppo, SCALARS.0),
            adam: pipeline(&ppo, ADAM.0),
        };
        for scope in scopes.into_iter().rev() {
            if let Some(e) = pollster::block_on(scope.pop()) {
                return Err(MlpError::Device(format!(
                    "the driver could not build the training kernels: {e}"
                )));
            }
        }
        Ok(pipelines)
    }
}

/// A bind group of `pipeline`'s group 0 binding `buffers[i]` at `bindings[i]`.
pub(super) fn bind(
    device: &wgpu::Device,
    pipeline: &wgpu::ComputePipeline,
    bindings: &[u32],
    buffers: &[&wgpu::Buffer],
) -> wgpu::BindGroup {
    assert_eq!(bindings.len(), buffers.len(), "one buffer per binding");
    let entries: Vec<_> = bindings
        .iter()
        .zip(buffers)
        .map(|(&binding, buffer)| wgpu::BindGroupEntry {
            binding,
            resource: buffer.as_entire_binding(),
        })
        .collect();
    device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: None,
        layout: &pipeline.get_bind_group_layout(0),
        entries: &entries,
    })
}
