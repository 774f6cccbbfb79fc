//! The backend: [`WgpuBackend`], its GPU resources and their creation. Its methods are split
//! by concern: [`PhysicsBackend`](orbit_core::physics::PhysicsBackend) and the argument checks
//! (`physics_backend.rs`), host writes and their uploads (`upload.rs`), dispatches and
//! republishes (`dispatch.rs`), reading the state back (`readback.rs`), kernel timestamps
//! (`timer.rs`).

mod dispatch;
mod physics_backend;
mod readback;
#[cfg(test)]
mod tests;
mod timer;
mod upload;

use std::sync::Arc;

use orbit_core::physics::{PhysicsError, SceneLayout, SimCfg};
use orbit_core::scene::SceneDesc;

use crate::BACKEND_NAME;
use crate::codegen::{self, KernelForm};
use crate::compile::CompiledScene;
use crate::gather::RowGather;
use crate::gpu::{self, Gpu, KernelChecks};
use crate::layout::BufferLayout;
use crate::mirror::HostMirror;
use readback::Stale;
use timer::KernelTimer;

/// Invocations (envs) per workgroup: one warp, so that a few thousand envs already spread
/// over every multiprocessor (with 64, 4 096 envs would leave half of an H100's 132 idle).
const WORKGROUP: usize = 32;

/// The GPU backend.
pub struct WgpuBackend {
    layout: SceneLayout,
    scene: CompiledScene,
    buffers: BufferLayout,
    sim: SimCfg,
    gpu: Arc<Gpu>,
    pipeline: wgpu::ComputePipeline,
    bind_group: wgpu::BindGroup,
    state_buf: wgpu::Buffer,
    inputs_buf: wgpu::Buffer,
    params_buf: wgpu::Buffer,
    staging: wgpu::Buffer,
    /// The host's copy of the state buffer, read back when first looked at after a dispatch
    /// (16-byte aligned for `Quat` views).
    state: HostMirror,
    /// What the next refresh of `state` has to read.
    stale: Stale,
    /// Reads back the rows of a few envs.
    gather: RowGather,
    /// The last dispatch, until the next one has been submitted and waits for it.
    pending: Option<wgpu::SubmissionIndex>,
    /// Receives the step kernel's two timestamps.
    timestamps: wgpu::Buffer,
    /// Mirror of the input buffer.
    inputs: Vec<f32>,
    /// Ranges of `inputs` written since the last upload (only those are sent: per-step targets
    /// and efforts, not the per-env parameters that rarely change).
    dirty: Vec<std::ops::Range<usize>>,
    /// Envs flagged fresh (state written) since the last step: the next step's first substep
    /// runs their solver without warm starts.
    fresh_envs: Vec<usize>,
    /// Default masses of links then objects, for mass scales.
    default_masses: Vec<f32>,
    /// Entries of the layout table.
    lay_len: usize,
    /// Timestamps around the step kernel, on devices that have them.
    timer: Option<KernelTimer>,
    /// Workgroups per dispatch of the step kernel.
    groups: u32,
    /// `timestamps` holds the kernel times of a dispatch that ran substeps.
    timed: bool,
}

fn err(reason: String) -> PhysicsError {
    PhysicsError::Unsupported {
        backend: BACKEND_NAME.into(),
        reason,
    }
}

impl WgpuBackend {
    /// Builds `num_envs` copies of `scene` on the process's GPU.
    pub fn new(desc: &SceneDesc, num_envs: usize, sim: &SimCfg) -> Result<Self, PhysicsError> {
        // The step kernel meets `KernelChecks::Trusted`'s conditions: its contacts stop at
        // `MAX_C`, its limit rows at one per dof, its walks down the tree of dofs at the root,
        // and every other private array is indexed by the scene's own tables; its loops run
        // over those counts or a fixed number of sweeps. The checks wgpu would add cost a
        // fifth of the Ant's step (docs/experiments/trusted-step-kernel.md).
        Self::build(desc, num_envs, sim, KernelChecks::Trusted, None)
    }

    /// [`WgpuBackend::new`] with the step kernel compiled with the given run-time checks, in
    /// `form` (by default the scene's, [`KernelForm::for_scene`]).
    fn build(
        desc: &SceneDesc,
        num_envs: usize,
        sim: &SimCfg,
        checks: KernelChecks,
        form: Option<KernelForm>,
    ) -> Result<Self, PhysicsError> {
        sim.validate()?;
        if num_envs == 0 {
            return Err(PhysicsError::InvalidInput(
                "num_envs must be at least 1".into(),
            ));
        }
        let scene = CompiledScene::new(desc)?;
        let gpu = gpu::gpu().map_err(err)?;
        let mut buffers = BufferLayout::new(&scene, num_envs);
        let limits = &gpu.limits;
        let subgroups = gpu.device.features().contains(wgpu::Features::SUBGROUP);
        let form = form.unwrap_or_else(|| KernelForm::for_scene(&scene, subgroups));
        buffers.warm_len = num_envs * form.warm_entries(&scene) * 4;
        let groups = (num_envs * form.threads_per_env()).div_ceil(WORKGROUP);
        if groups > limits.max_compute_workgroups_per_dimension as usize {
            return Err(err(format!(
                "{num_envs} envs need {groups} workgroups of {WORKGROUP} invocations, more than the device's {}",
                limits.max_compute_workgroups_per_dimension
            )));
        }
        let largest = buffers
            .state_len
            .max(buffers.inputs_len)
            .max(buffers.warm_len) as u64
            * 4;
        let rows = codegen::row_storage_floats(&scene, num_envs).unwrap_or(0) as u64 * 4;
        let largest = largest.max(rows);
        let max_binding = limits.max_storage_buffer_binding_size;
        if largest > max_binding.min(limits.max_buffer_size) {
            return Err(err(format!(
                "{num_envs} envs need a {largest}-byte buffer; the device allows {} bytes per storage binding: use fewer envs",
                max_binding
            )));
        }
        let mut geometry = scene.geometry_table().data;
        if geometry.is_empty() {
            geometry.push([0.0; 4]);
        }
        let geometry_bytes = (geometry.len() * 16) as u64;
        if geometry_bytes > limits.max_uniform_buffer_binding_size {
            return Err(err(format!(
                "the scene's geometry table needs {geometry_bytes} bytes, more than the device's {}-byte uniform buffers: use fewer shapes or collision pairs",
                limits.max_uniform_buffer_binding_size
            )));
        }
        let source = codegen::kernel_source(&scene, sim, WORKGROUP, form);
        let pipeline = gpu.pipeline(&source, checks).map_err(err)?;
        let device = &gpu.device;
        let storage = |label: &str, floats: usize| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: (floats.max(4) * 4) as u64,
                usage: wgpu::BufferUsages::STORAGE
                    | wgpu::BufferUsages::COPY_DST
                    | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            })
        };
        let state_buf = storage("orbit state", buffers.state_len);
        let inputs_buf = storage("orbit inputs", buffers.inputs_len);
        let warm_buf = storage("orbit warm start", buffers.warm_len);
        let table = buffers.table(&scene);
        let lay_buf = storage("orbit layout", table.len());
        gpu.queue
            .write_buffer(&lay_buf, 0, bytemuck::cast_slice(&table));
        // (The bind group keeps the buffer alive.)
        // The thread-per-branch form keeps its rows in registers.
        let rows_buf = codegen::row_storage_floats(&scene, num_envs)
            .filter(|_| form != KernelForm::ThreadPerBranch)
            .map(|n| storage("orbit rows", n));
        let geometry_buf = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("orbit geometry"),
            size: geometry_bytes,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        gpu.queue
            .write_buffer(&geometry_buf, 0, bytemuck::cast_slice(&geometry));
        let params_buf = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("orbit params"),
            size: 16,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let timer = KernelTimer::new(&gpu);
        let readback = |label: &str, size: usize| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: size as u64,
                usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            })
        };
        let staging = readback("orbit readback", buffers.state_len * 4);
        let gather = RowGather::new(&gpu, &buffers, &state_buf);
        let timestamps = readback("orbit step timestamps", 16);
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("orbit step"),
            layout: &pipeline.get_bind_group_layout(0),
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: state_buf.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: inputs_buf.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: warm_buf.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 3,
                    resource: params_buf.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 4,
                    resource: lay_buf.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 5,
                    resource: geometry_buf.as_entire_binding(),
                },
            ]
            .into_iter()
            .chain(rows_buf.as_ref().map(|buf| wgpu::BindGroupEntry {
                binding: 6,
                resource: buf.as_entire_binding(),
            }))
            .collect::<Vec<_>>(),
        });
        let default_masses = scene
            .links
            .iter()
            .map(|l| l.inertial.mass)
            .chain(scene.objects.iter().map(|o| o.mass))
            .collect();
        let mut backend = Self {
            layout: SceneLayout::from_desc(desc),
            scene,
            sim: sim.clone(),
            gpu,
            pipeline,
            bind_group,
            state_buf,
            inputs_buf,
            params_buf,
            staging,
            state: HostMirror::new(buffers.state_len.div_ceil(4)),
            stale: Stale::All,
            gather,
            pending: None,
            timestamps,
            inputs: vec![0.0; buffers.inputs_len],
            dirty: std::iter::once(0..buffers.inputs_len).collect(),
            fresh_envs: Vec::new(),
            default_masses,
            lay_len: table.len(),
            buffers,
            timer,
            groups: groups as u32,
            timed: false,
        };
        backend.init_state(desc);
        backend.upload_state();
        // Mark every env fresh (nothing to warm-start from) and publish the initial state.
        backend.refresh_all()?;
        Ok(backend)
    }

    /// The adapter the backend runs on.
    pub fn adapter_info(&self) -> &wgpu::AdapterInfo {
        &self.gpu.info
    }
}
