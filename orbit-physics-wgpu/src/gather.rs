//! Reading back the rows of a few envs. After a reset writes some envs' state, only those envs
//! are republished (see `WgpuBackend::after_write`), so only their rows of the host mirror are
//! stale. A small kernel copies those rows from every state section into one compact buffer,
//! which is read back instead of the whole state (tens of megabytes at 65 536 envs, for the
//! one percent of envs that finished an episode).

use crate::gpu::Gpu;
use crate::layout::BufferLayout;

/// Invocations per workgroup of the gather kernel (one float each).
const WORKGROUP: u32 = 64;

/// Envs whose rows the kernel reads back at most, as a fraction of all envs (`1 / N`); beyond
/// that the whole state is read back, which is one contiguous copy.
const MAX_FRACTION: usize = 4;

/// The kernel: `out[i·F + k] = st[base_k + ids[i] · stride_k]` for the `F` per-env floats
/// `k`, whose `(base, stride)` pairs are in `cols`.
const SOURCE: &str = "
struct Params {
    envs: u32,
    floats: u32,
    pad0: u32,
    pad1: u32,
}

@group(0) @binding(0) var<storage, read> st: array<f32>;
@group(0) @binding(1) var<storage, read> ids: array<u32>;
@group(0) @binding(2) var<storage, read> cols: array<u32>;
@group(0) @binding(3) var<storage, read_write> out: array<f32>;
@group(0) @binding(4) var<uniform> params: Params;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>,
        @builtin(num_workgroups) groups: vec3<u32>) {
    let i = gid.x + gid.y * groups.x * 64u;
    if i >= params.envs * params.floats {
        return;
    }
    let row = i / params.floats;
    let k = i % params.floats;
    out[i] = st[cols[2u * k] + ids[row] * cols[2u * k + 1u]];
}
";

/// The gather kernel with its buffers, bound to one backend's state buffer.
pub struct RowGather {
    pipeline: wgpu::ComputePipeline,
    bind_group: wgpu::BindGroup,
    ids: wgpu::Buffer,
    params: wgpu::Buffer,
    out: wgpu::Buffer,
    /// Per-env state sections `(first float, floats per env)`, in the order the kernel packs
    /// them.
    sections: Vec<(usize, usize)>,
    /// Floats per env (the sum of the sections' widths).
    floats: usize,
    /// Most envs one gather reads.
    max_envs: usize,
}

impl RowGather {
    /// The kernel and buffers for `layout`'s state, held in `state`.
    pub fn new(gpu: &Gpu, layout: &BufferLayout, state: &wgpu::Buffer) -> Self {
        let device = &gpu.device;
        let sections = layout.env_sections();
        let floats: usize = sections.iter().map(|&(_, w)| w).sum();
        let cols: Vec<u32> = sections
            .iter()
            .flat_map(|&(start, width)| {
                (0..width).flat_map(move |j| [(start + j) as u32, width as u32])
            })
            .collect();
        let max_envs = layout.num_envs.div_ceil(MAX_FRACTION);
        let buffer = |label: &str, bytes: usize, usage: wgpu::BufferUsages| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: bytes.max(16) as u64,
                usage,
                mapped_at_creation: false,
            })
        };
        let storage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST;
        let ids = buffer("orbit gather ids", max_envs * 4, storage);
        let cols_buf = buffer("orbit gather columns", cols.len() * 4, storage);
        gpu.queue
            .write_buffer(&cols_buf, 0, bytemuck::cast_slice(&cols));
        let out = buffer(
            "orbit gather rows",
            max_envs * floats * 4,
            wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
        );
        let params = buffer(
            "orbit gather params",
            16,
            wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        );
        let pipeline = gpu.pipeline(SOURCE);
        let entries = [state, &ids, &cols_buf, &out, &params]
            .into_iter()
            .enumerate()
            .map(|(i, b)| wgpu::BindGroupEntry {
                binding: i as u32,
                resource: b.as_entire_binding(),
            })
            .collect::<Vec<_>>();
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("orbit gather"),
            layout: &pipeline.get_bind_group_layout(0),
            entries: &entries,
        });
        Self {
            pipeline,
            bind_group,
            ids,
            params,
            out,
            sections,
            floats,
            max_envs,
        }
    }

    /// Whether the rows of `envs` envs are worth gathering (else read the whole state).
    pub fn worthwhile(&self, envs: usize) -> bool {
        self.floats > 0 && envs <= self.max_envs
    }

    /// Bytes of GPU memory the gather's buffers take.
    pub fn device_memory_bytes(&self) -> usize {
        4 * (self.max_envs * (self.floats + 1) + 2 * self.floats + 4)
    }

    /// Queues the copy of `env_ids`' rows into the compact buffer and from there into
    /// `staging`; returns the bytes copied. `env_ids` must be [`worthwhile`](Self::worthwhile).
    pub fn encode(
        &self,
        gpu: &Gpu,
        encoder: &mut wgpu::CommandEncoder,
        env_ids: &[u32],
        staging: &wgpu::Buffer,
    ) -> u64 {
        debug_assert!(self.worthwhile(env_ids.len()));
        let total = (env_ids.len() * self.floats) as u32;
        gpu.queue
            .write_buffer(&self.ids, 0, bytemuck::cast_slice(env_ids));
        gpu.queue.write_buffer(
            &self.params,
            0,
            bytemuck::cast_slice(&[env_ids.len() as u32, self.floats as u32, 0, 0]),
        );
        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("orbit gather"),
                timestamp_writes: None,
            });
            pass.set_pipeline(&self.pipeline);
            pass.set_bind_group(0, &self.bind_group, &[]);
            let groups = total.div_ceil(WORKGROUP);
            let x = groups.min(gpu.limits.max_compute_workgroups_per_dimension);
            pass.dispatch_workgroups(x, groups.div_ceil(x.max(1)), 1);
        }
        let bytes = u64::from(total) * 4;
        encoder.copy_buffer_to_buffer(&self.out, 0, staging, 0, bytes);
        bytes
    }

    /// Writes the packed rows `packed` (as [`encode`](Self::encode) read them) of `env_ids`
    /// into the full state `state`.
    pub fn scatter(&self, env_ids: &[u32], packed: &[f32], state: &mut [f32]) {
        for (&e, row) in env_ids.iter().zip(packed.chunks_exact(self.floats)) {
            let mut at = 0;
            for &(start, width) in &self.sections {
                let to = start + e as usize * width;
                state[to..to + width].copy_from_slice(&row[at..at + width]);
                at += width;
            }
        }
    }
}
