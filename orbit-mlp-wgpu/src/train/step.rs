//! The trainer's device buffers and the dispatches of one gradient step, recorded once.

use super::kernels::{self, MatmulParams, Pipelines, TILE, bind};
use super::layout::{LayerAt, Layout};
use super::{PpoShape, SCALARS_BYTES};
use crate::MlpError;

/// One dispatch of a gradient step.
pub(super) struct Dispatch {
    /// What it computes (for [`super::PpoTrainer::profile_step`]).
    pub(super) label: String,
    pub(super) pipeline: wgpu::ComputePipeline,
    pub(super) bind_group: wgpu::BindGroup,
    pub(super) groups: [u32; 3],
}

/// The device buffers the update reads from the host or back to it.
pub(super) struct Buffers {
    pub(super) hyper: wgpu::Buffer,
    pub(super) params: wgpu::Buffer,
    pub(super) first: wgpu::Buffer,
    pub(super) second: wgpu::Buffer,
    pub(super) scal: wgpu::Buffer,
    /// Copies of params, first, second and scal taken before an update.
    pub(super) backup: [wgpu::Buffer; 4],
    pub(super) rollout: wgpu::Buffer,
    pub(super) perm: wgpu::Buffer,
    pub(super) old_sigma: wgpu::Buffer,
    /// The last gradient step's gradients (before clipping), then its loss slots.
    pub(super) grads: wgpu::Buffer,
}

/// The buffers for `layout` and `shape` and the dispatches of a gradient step on them.
pub(super) fn record(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    layout: &Layout,
    shape: &PpoShape,
) -> Result<(Buffers, Vec<Dispatch>), MlpError> {
    let max_groups = device.limits().max_compute_workgroups_per_dimension;
    let pipelines = Pipelines::new(device, true)?;
    let storage =
        wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::COPY_SRC;
    let buffer = |label: &str, floats: usize| {
        device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size: (4 * floats).max(16) as u64,
            usage: storage,
            mapped_at_creation: false,
        })
    };
    let uniform = |label: &str, bytes: &[u8]| {
        let b = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size: bytes.len() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        queue.write_buffer(&b, 0, bytes);
        b
    };
    let (p, m, a) = (
        layout.params,
        layout.rows,
        shape.actor_widths[shape.actor_widths.len() - 1],
    );
    let scal_floats = (SCALARS_BYTES / 4) as usize;
    let buffers = Buffers {
        hyper: uniform("orbit train hyper", bytemuck::bytes_of(&layout.hyper)),
        params: buffer("orbit train params", p),
        first: buffer("orbit train first moment", p),
        second: buffer("orbit train second moment", p),
        scal: buffer("orbit train scalars", scal_floats),
        backup: [p, p, p, scal_floats].map(|n| buffer("orbit train backup", n)),
        rollout: buffer("orbit train rollout", layout.rollout_floats),
        perm: buffer("orbit train permutation", shape.batch),
        old_sigma: buffer("orbit train sigma", a),
        grads: buffer("orbit train gradients", p + 3),
    };
    let grads = &buffers.grads;
    // Each `finish` workgroup's shares of the two squared norms.
    let squares = buffer("orbit train squares", 2 * (p + 3).div_ceil(256));
    let partials = buffer("orbit train partials", layout.chunks * (p + 3));
    let mb = buffer("orbit train minibatch", layout.minibatch_floats);
    let acts = |layers: &[LayerAt]| -> Vec<wgpu::Buffer> {
        layers
            .iter()
            .map(|l| buffer("orbit train activations", m * l.n))
            .collect()
    };
    let (actor_acts, critic_acts) = (acts(&layout.actor), acts(&layout.critic));
    let widest = layout
        .actor
        .iter()
        .chain(&layout.critic)
        .map(|l| l.k.max(l.n))
        .max()
        .unwrap_or(1);
    let ping = [0, 1].map(|_| buffer("orbit train layer gradients", m * widest));
    let actor_grad = buffer("orbit train actor output gradients", m * a);
    let critic_grad = buffer("orbit train critic output gradients", m);
    let row_terms = buffer("orbit train row terms", m * (a + 3));
    let b = &buffers;
    let groups = |threads: usize, size: usize| [threads.div_ceil(size) as u32, 1, 1];
    let ppo = |pipeline: &wgpu::ComputePipeline,
               (label, bindings): (&str, &[u32]),
               buffers: &[&wgpu::Buffer],
               groups: [u32; 3]| Dispatch {
        label: label.to_string(),
        pipeline: pipeline.clone(),
        bind_group: bind(device, pipeline, bindings, buffers),
        groups,
    };
    let h = &b.hyper;
    let hy = &layout.hyper;
    // Floats of a minibatch row, every section's.
    let critic_floats = if shape.separate_critic {
        hy.critic_width
    } else {
        0
    };
    let row_floats = (hy.obs_width + critic_floats + 2 * hy.actions + 4) as usize;
    let mut step = vec![ppo(
        &pipelines.gather,
        kernels::GATHER,
        &[h, &b.perm, &b.rollout, &mb, &b.scal],
        [
            (m * row_floats).div_ceil(256).min(max_groups as usize) as u32,
            1,
            1,
        ],
    )];
    let matmul =
        |label: String, params: MatmulParams, operands: [&wgpu::Buffer; 4], groups: [u32; 3]| {
            let uniform = uniform("orbit train layer", bytemuck::bytes_of(&params));
            let [lhs, rhs, aux, out] = operands;
            Dispatch {
                label,
                pipeline: pipelines.matmul.clone(),
                bind_group: bind(
                    device,
                    &pipelines.matmul,
                    &[0, 1, 2, 3, 4],
                    &[lhs, rhs, aux, out, &uniform],
                ),
                groups,
            }
        };
    let tiles = |rows: usize, cols: usize, z: usize| {
        [
            cols.div_ceil(TILE) as u32,
            rows.div_ceil(TILE) as u32,
            z as u32,
        ]
    };
    let activation = shape.activation.code();
    // Forward: layer 0 reads its section of the minibatch.
    let networks = [
        ("actor", &layout.actor, &actor_acts, hy.mb_obs, &actor_grad),
        (
            "critic",
            &layout.critic,
            &critic_acts,
            hy.mb_critic,
            &critic_grad,
        ),
    ];
    for (net, layers, acts, input_at, _) in networks {
        for (l, layer) in layers.iter().enumerate() {
            let last = l + 1 == layers.len();
            let (x, a_off) = if l == 0 {
                (&mb, input_at)
            } else {
                (&acts[l - 1], 0)
            };
            let params = MatmulParams {
                mode: kernels::FORWARD,
                rows: m as u32,
                cols: layer.n as u32,
                depth: layer.k as u32,
                a_off,
                a_stride: layer.k as u32,
                w_off: layer.weight as u32,
                b_off: (layer.weight + layer.k * layer.n) as u32,
                activation: if last { 0 } else { activation },
                ..Default::default()
            };
            let operands = [x, &b.params, &b.params, &acts[l]];
            let label = format!("forward {net} {l}");
            step.push(matmul(label, params, operands, tiles(m, layer.n, 1)));
        }
    }
    step.push(ppo(
        &pipelines.loss,
        kernels::LOSS,
        &[
            h,
            &mb,
            &actor_acts[actor_acts.len() - 1],
            &critic_acts[critic_acts.len() - 1],
            &b.params,
            &b.old_sigma,
            &actor_grad,
            &critic_grad,
            &row_terms,
        ],
        groups(m, 64),
    ));
    step.push(ppo(
        &pipelines.column_sums,
        kernels::COLUMN_SUMS,
        &[h, &row_terms, &partials],
        groups(layout.chunks * (a + 3), 64),
    ));
    // Backward, last layer first: its weight gradient, then the gradient at the previous
    // layer's pre-activation (alternating between two buffers).
    for (net, layers, acts, input_at, output_grad) in networks {
        let mut g = output_grad;
        for (l, layer) in layers.iter().enumerate().rev() {
            let (x, a_off) = if l == 0 {
                (&mb, input_at)
            } else {
                (&acts[l - 1], 0)
            };
            let params = MatmulParams {
                mode: kernels::WEIGHTS,
                rows: layer.k as u32,
                cols: layer.n as u32,
                a_off,
                a_stride: layer.k as u32,
                w_off: layer.weight as u32,
                chunk_rows: layout.chunk_rows as u32,
                batch: m as u32,
                out_stride: (p + 3) as u32,
                ..Default::default()
            };
            let operands = [x, g, &b.params, &partials];
            let label = format!("weights {net} {l}");
            let groups = tiles(layer.k, layer.n, layout.chunks);
            step.push(matmul(label, params, operands, groups));
            if l > 0 {
                let previous = &ping[l % 2];
                let params = MatmulParams {
                    mode: kernels::BACKWARD,
                    rows: m as u32,
                    cols: layer.k as u32,
                    depth: layer.n as u32,
                    a_stride: layer.n as u32,
                    w_off: layer.weight as u32,
                    activation,
                    ..Default::default()
                };
                let operands = [g, &b.params, &acts[l - 1], previous];
                let label = format!("backward {net} {l}");
                step.push(matmul(label, params, operands, tiles(m, layer.k, 1)));
                g = previous;
            }
        }
    }
    step.push(ppo(
        &pipelines.finish,
        kernels::FINISH,
        &[h, &b.params, &partials, grads, &squares],
        groups(p + 3, 256),
    ));
    step.push(ppo(
        &pipelines.scalars,
        kernels::SCALARS,
        &[h, &b.params, grads, &squares, &b.scal],
        [1, 1, 1],
    ));
    step.push(ppo(
        &pipelines.adam,
        kernels::ADAM,
        &[h, grads, &b.scal, &b.params, &b.first, &b.second],
        groups(p, 256),
    ));
    Ok((buffers, step))
}
