//! Moving the rows of a few envs between the host and the GPU. After a reset writes some envs'
//! state, only those envs are republished (see `WgpuBackend::after_write`), so only their rows
//! of the host mirror are stale. A small kernel copies those rows from every state section into
//! one compact buffer, which is read back instead of the whole state (tens of megabytes at
//! 65 536 envs, for the one percent of envs that finished an episode). The written rows go the
//! other way: packed on the host, uploaded compactly and put in place by a second kernel,
//! instead of uploading every row between the lowest and the highest env written.

use crate::gpu::{Gpu, KernelChecks};
use crate::layout::BufferLayout;

/// Invocations per workgroup of the gather kernel (one float each).
const WORKGROUP: u32 = 64;

/// Envs whose rows the kernel reads back at most, as a fraction of all envs (`1 / N`); beyond
/// that the whole state is read back, which is one contiguous copy.
const MAX_FRACTION: usize = 4;

/// A kernel over the `F` floats of each listed env: invocation `i` handles float `k = i mod F`
/// of env slot `i / F`, whose place in the state is `cols[2k] + ids[slot] · cols[2k + 1]`;
/// `body` moves it between `st` (the state) and `rows` (the packed rows).
fn kernel(state_access: &str, rows_access: &str, body: &str) -> String {
    format!(
        "
struct Params {{
    envs: u32,
    floats: u32,
    pad0: u32,
    pad1: u32,
}}

@group(0) @binding(0) var<storage, {state_access}> st: array<f32>;
@group(0) @binding(1) var<storage, read> ids: array<u32>;
@group(0) @binding(2) var<storage, read> cols: array<u32>;
@group(0) @binding(3) var<storage, {rows_access}> rows: array<f32>;
@group(0) @binding(4) var<uniform> params: Params;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>,
        @builtin(num_workgroups) groups: vec3<u32>) {{
    let i = gid.x + gid.y * groups.x * 64u;
    if i >= params.envs * params.floats {{
        return;
    }}
    let at = cols[2u * (i % params.floats)] + ids[i / params.floats] * cols[2u * (i % params.floats) + 1u];
    {body}
}}
"
    )
}

/// The `(base, stride)` pair of every float of `sections` (each `(first float, floats per env)`):
/// float `j` of a section starts at `first + j` and steps by the section's width per env.
fn columns(sections: &[(usize, usize)]) -> Vec<u32> {
    sections
        .iter()
        .flat_map(|&(start, width)| {
            (0..width).flat_map(move |j| [(start + j) as u32, width as u32])
        })
        .collect()
}

/// The gather: `rows[i·F + k] = st[base_k + ids[i] · stride_k]`.
fn gather_source() -> String {
    kernel("read", "read_write", "rows[i] = st[at];")
}

/// The write, the inverse of the gather: `st[base_k + ids[i] · stride_k] = rows[i·F + k]`.
fn write_source() -> String {
    kernel("read_write", "read", "st[at] = rows[i];")
}

/// The gather and write kernels with their buffers, bound to one backend's state buffer.
pub struct RowGather {
    pipeline: wgpu::ComputePipeline,
    bind_group: wgpu::BindGroup,
    /// The write kernel, bound to the same ids, rows (`out`) and params, and its own columns.
    write_pipeline: wgpu::ComputePipeline,
    write_bind_group: wgpu::BindGroup,
    write_cols: wgpu::Buffer,
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
        let cols = columns(&sections);
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
            storage | wgpu::BufferUsages::COPY_SRC,
        );
        let write_cols = buffer("orbit write columns", cols.len() * 4, storage);
        let params = buffer(
            "orbit gather params",
            16,
            wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        );
        let bind = |label: &str, pipeline: &wgpu::ComputePipeline, buffers: [&wgpu::Buffer; 5]| {
            let entries = buffers
                .into_iter()
                .enumerate()
                .map(|(i, b)| wgpu::BindGroupEntry {
                    binding: i as u32,
                    resource: b.as_entire_binding(),
                })
                .collect::<Vec<_>>();
            device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some(label),
                layout: &pipeline.get_bind_group_layout(0),
                entries: &entries,
            })
        };
        let pipeline = gpu
            .pipeline(&gather_source(), KernelChecks::Checked)
            .expect("the fixed gather kernel builds");
        let bind_group = bind(
            "orbit gather",
            &pipeline,
            [state, &ids, &cols_buf, &out, &params],
        );
        let write_pipeline = gpu
            .pipeline(&write_source(), KernelChecks::Checked)
            .expect("the fixed write kernel builds");
        let write_bind_group = bind(
            "orbit write",
            &write_pipeline,
            [state, &ids, &write_cols, &out, &params],
        );
        Self {
            pipeline,
            bind_group,
            write_pipeline,
            write_bind_group,
            write_cols,
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
        4 * (self.max_envs * (self.floats + 1) + 4 * self.floats + 4)
    }

    /// Uploads the rows of `env_ids` in `sections` (each `(first float, floats per env)`, per-env
    /// sections of the state) from the host copy `state` and puts them in place on the GPU, in
    /// a submission of its own; false (nothing done) where uploading every row between the
    /// lowest and the highest env is as cheap, or there are too many envs.
    pub fn write(
        &self,
        gpu: &Gpu,
        env_ids: &[usize],
        sections: &[(usize, usize)],
        state: &[f32],
    ) -> bool {
        let Some(span) = crate::layout::env_rows(0, 1, env_ids) else {
            return true;
        };
        let floats: usize = sections.iter().map(|&(_, w)| w).sum();
        let packed_floats = env_ids.len() * (floats + 1) + 2 * floats;
        if env_ids.len() > self.max_envs || packed_floats >= span.len() * floats {
            return false;
        }
        let cols = columns(sections);
        let mut rows = Vec::with_capacity(env_ids.len() * floats);
        for &e in env_ids {
            for &(start, width) in sections {
                rows.extend_from_slice(&state[start + e * width..start + (e + 1) * width]);
            }
        }
        let ids: Vec<u32> = env_ids.iter().map(|&e| e as u32).collect();
        gpu.queue
            .write_buffer(&self.write_cols, 0, bytemuck::cast_slice(&cols));
        gpu.queue
            .write_buffer(&self.out, 0, bytemuck::cast_slice(&rows));
        let mut encoder = gpu
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("orbit write"),
            });
        let pass = (&self.write_pipeline, &self.write_bind_group);
        self.encode_pass(gpu, &mut encoder, pass, &ids, floats);
        gpu.queue.submit([encoder.finish()]);
        true
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
        let pass = (&self.pipeline, &self.bind_group);
        self.encode_pass(gpu, encoder, pass, env_ids, self.floats);
        let bytes = (env_ids.len() * self.floats * 4) as u64;
        encoder.copy_buffer_to_buffer(&self.out, 0, staging, 0, bytes);
        bytes
    }

    /// Queues one pass of a kernel (`pipeline` with its bind group) over `floats` floats of each
    /// env in `env_ids`, after uploading the ids and the sizes.
    fn encode_pass(
        &self,
        gpu: &Gpu,
        encoder: &mut wgpu::CommandEncoder,
        (pipeline, bind_group): (&wgpu::ComputePipeline, &wgpu::BindGroup),
        env_ids: &[u32],
        floats: usize,
    ) {
        gpu.queue
            .write_buffer(&self.ids, 0, bytemuck::cast_slice(env_ids));
        gpu.queue.write_buffer(
            &self.params,
            0,
            bytemuck::cast_slice(&[env_ids.len() as u32, floats as u32, 0, 0]),
        );
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("orbit rows"),
            timestamp_writes: None,
        });
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, bind_group, &[]);
        let groups = ((env_ids.len() * floats) as u32).div_ceil(WORKGROUP);
        let x = groups.min(gpu.limits.max_compute_workgroups_per_dimension);
        pass.dispatch_workgroups(x, groups.div_ceil(x.max(1)), 1);
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
