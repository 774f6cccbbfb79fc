//! [`StackedMlp`]: networks of equal widths, evaluated layer by layer with one dispatch per layer
//! for all of them.

use crate::MlpError;

/// The layer kernel (a tiled product with the bias and activation fused).
const LAYER_SOURCE: &str = concat!(include_str!("activation.wgsl"), include_str!("layer.wgsl"));

/// Rows and columns of the output tile one workgroup computes (see `layer.wgsl`).
const TILE: usize = 64;

/// The nonlinearity after each hidden layer (the last layer has none).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Activation {
    /// `x` if `x > 0`, else `eˣ − 1`.
    Elu,
    /// Scaled ELU (Klambauer et al. 2017, PyTorch's constants).
    Selu,
    /// `max(x, 0)`.
    Relu,
    /// `x` if `x > 0`, else `0.01 x`.
    LeakyRelu,
    /// Hyperbolic tangent.
    Tanh,
    /// Logistic sigmoid.
    Sigmoid,
}

impl Activation {
    /// The kernel's code for it (0 is no activation).
    pub(crate) fn code(self) -> u32 {
        match self {
            Activation::Elu => 1,
            Activation::Selu => 2,
            Activation::Relu => 3,
            Activation::LeakyRelu => 4,
            Activation::Tanh => 5,
            Activation::Sigmoid => 6,
        }
    }
}

/// The kernel's uniform parameters of one layer (`Params` in `layer.wgsl`).
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct Params {
    rows: u32,
    n: u32,
    k: u32,
    x_stride: u32,
    activation: u32,
    pad: [u32; 3],
}

/// One layer: its weights, bias, parameters and the bindings of its dispatch.
struct Layer {
    k: usize,
    n: usize,
    weight: wgpu::Buffer,
    bias: wgpu::Buffer,
    /// The parameters as written to `params`.
    p: Params,
    params: wgpu::Buffer,
    bind_group: wgpu::BindGroup,
}

/// `stacks` networks of the same widths (the actor's and the critic's of a policy, the critic's
/// last layer padded to the actor's outputs) on `rows` rows of inputs at a time, on a wgpu
/// device. Layer `l` of network `z` is `y = act(x · W + b)` with `W` `[widths[l],
/// widths[l + 1]]` row-major; every layer but the last is followed by the activation.
pub struct StackedMlp {
    device: wgpu::Device,
    queue: wgpu::Queue,
    pipeline: wgpu::ComputePipeline,
    rows: usize,
    stacks: usize,
    layers: Vec<Layer>,
    input: wgpu::Buffer,
    output: wgpu::Buffer,
    readback: wgpu::Buffer,
    /// Whether the last [`forward`](Self::forward) gave one input to every network (layer 0's
    /// parameters say so).
    shared_input: Option<bool>,
}

impl StackedMlp {
    /// `stacks` networks of `widths` (inputs, hidden widths, outputs) for `rows` rows, with
    /// zero weights until [`load_layer`](Self::load_layer).
    pub fn new(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        rows: usize,
        stacks: usize,
        widths: &[usize],
        activation: Activation,
    ) -> Result<Self, MlpError> {
        Self::build(device, queue, (rows, stacks, widths, activation), true)
    }

    /// [`StackedMlp::new`] for `(rows, stacks, widths, activation)`, with the layer kernel
    /// compiled as trusted WGSL or with all of wgpu's run-time checks.
    fn build(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        (rows, stacks, widths, activation): (usize, usize, &[usize], Activation),
        trusted: bool,
    ) -> Result<Self, MlpError> {
        if widths.len() < 2 || widths.contains(&0) || rows == 0 || stacks == 0 {
            return Err(MlpError::Shape(format!(
                "a stacked MLP needs at least one row, one network and two non-zero widths \
                 (inputs and outputs), got {rows} rows, {stacks} networks, widths {widths:?}"
            )));
        }
        let limits = device.limits();
        let widest_layer = *widths.iter().max().expect("two widths");
        let groups = rows
            .div_ceil(TILE)
            .max(widest_layer.div_ceil(TILE))
            .max(stacks);
        if groups > limits.max_compute_workgroups_per_dimension as usize {
            return Err(MlpError::Shape(format!(
                "{rows} rows need {groups} workgroups in a dimension, more than the device's \
                 {}: use fewer envs",
                limits.max_compute_workgroups_per_dimension
            )));
        }
        // The kernel indexes floats with 32-bit integers.
        let widest = stacks * rows * widest_layer;
        let max_floats = (limits
            .max_storage_buffer_binding_size
            .min(limits.max_buffer_size)
            / 4)
        .min(u64::from(u32::MAX));
        if widest as u64 > max_floats {
            return Err(MlpError::Shape(format!(
                "a layer of {stacks} × {rows} rows × {widest_layer} values is more than the \
                 {max_floats} floats the device binds in one buffer: use fewer envs"
            )));
        }
        let pipeline = pipeline(device, trusted)?;
        let storage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST;
        let buffer = |label: &str, floats: usize, usage: wgpu::BufferUsages| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: (4 * floats).max(16) as u64,
                usage,
                mapped_at_creation: false,
            })
        };
        let outputs = *widths.last().expect("two widths");
        let input = buffer("orbit mlp input", stacks * rows * widths[0], storage);
        let output = buffer(
            "orbit mlp output",
            stacks * rows * outputs,
            storage | wgpu::BufferUsages::COPY_SRC,
        );
        let readback = buffer(
            "orbit mlp readback",
            stacks * rows * outputs,
            wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        );
        let num_layers = widths.len() - 1;
        let widest_hidden = widths[1..num_layers].iter().copied().max().unwrap_or(0);
        // Hidden layers alternate between two buffers.
        let hidden: Vec<wgpu::Buffer> = (0..2.min(num_layers - 1))
            .map(|i| {
                buffer(
                    &format!("orbit mlp hidden {i}"),
                    stacks * rows * widest_hidden,
                    storage,
                )
            })
            .collect();
        let layers = (0..num_layers)
            .map(|l| {
                let (k, n) = (widths[l], widths[l + 1]);
                let x = if l == 0 { &input } else { &hidden[(l - 1) % 2] };
                let y = if l + 1 == num_layers {
                    &output
                } else {
                    &hidden[l % 2]
                };
                let weight = buffer(&format!("orbit mlp weight {l}"), stacks * k * n, storage);
                let bias = buffer(&format!("orbit mlp bias {l}"), stacks * n, storage);
                let params = buffer(
                    &format!("orbit mlp params {l}"),
                    std::mem::size_of::<Params>() / 4,
                    wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                );
                let activation = if l + 1 == num_layers {
                    0
                } else {
                    activation.code()
                };
                let p = Params {
                    rows: rows as u32,
                    n: n as u32,
                    k: k as u32,
                    x_stride: (rows * k) as u32,
                    activation,
                    pad: [0; 3],
                };
                queue.write_buffer(&params, 0, bytemuck::bytes_of(&p));
                let entries: Vec<_> = [x, &weight, &bias, y, &params]
                    .into_iter()
                    .enumerate()
                    .map(|(i, b)| wgpu::BindGroupEntry {
                        binding: i as u32,
                        resource: b.as_entire_binding(),
                    })
                    .collect();
                let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
                    label: Some("orbit mlp layer"),
                    layout: &pipeline.get_bind_group_layout(0),
                    entries: &entries,
                });
                Layer {
                    k,
                    n,
                    weight,
                    bias,
                    p,
                    params,
                    bind_group,
                }
            })
            .collect();
        Ok(Self {
            device: device.clone(),
            queue: queue.clone(),
            pipeline,
            rows,
            stacks,
            layers,
            input,
            output,
            readback,
            shared_input: None,
        })
    }

    /// Sets layer `layer` of every network: `weight` `[stacks, d_in, d_out]` and `bias`
    /// `[stacks, d_out]`, row-major.
    pub fn load_layer(
        &mut self,
        layer: usize,
        weight: &[f32],
        bias: &[f32],
    ) -> Result<(), MlpError> {
        let l = self.layers.get(layer).ok_or_else(|| {
            MlpError::Shape(format!(
                "layer {layer} does not exist: the networks have {} layers",
                self.layers.len()
            ))
        })?;
        let (k, n, s) = (l.k, l.n, self.stacks);
        if weight.len() != s * k * n || bias.len() != s * n {
            return Err(MlpError::Shape(format!(
                "layer {layer} takes {s} × {k} × {n} weights and {s} × {n} biases, got {} and {}",
                weight.len(),
                bias.len()
            )));
        }
        self.queue
            .write_buffer(&l.weight, 0, bytemuck::cast_slice(weight));
        self.queue
            .write_buffer(&l.bias, 0, bytemuck::cast_slice(bias));
        Ok(())
    }

    /// The networks' outputs for `inputs` (`[rows, widths[0]]` each: one per network, or one
    /// that every network reads) into `out` (`[stacks, rows, outputs]`), waiting for the device.
    pub fn forward(&mut self, inputs: &[&[f32]], out: &mut [f32]) -> Result<(), MlpError> {
        let (rows, d_in) = (self.rows, self.layers[0].k);
        let outputs = self.stacks * rows * self.layers.last().expect("a layer").n;
        let shared = inputs.len() == 1;
        if !(shared || inputs.len() == self.stacks)
            || inputs.iter().any(|x| x.len() != rows * d_in)
            || out.len() != outputs
        {
            return Err(MlpError::Shape(format!(
                "a forward pass takes 1 or {} inputs of {rows} × {d_in} values and {outputs} \
                 outputs, got inputs of {:?} values and {} outputs",
                self.stacks,
                inputs.iter().map(|x| x.len()).collect::<Vec<_>>(),
                out.len()
            )));
        }
        if self.shared_input != Some(shared) {
            let first = &mut self.layers[0];
            first.p.x_stride = if shared { 0 } else { (rows * d_in) as u32 };
            self.queue
                .write_buffer(&first.params, 0, bytemuck::bytes_of(&first.p));
            self.shared_input = Some(shared);
        }
        for (z, x) in inputs.iter().enumerate() {
            self.queue.write_buffer(
                &self.input,
                (4 * z * rows * d_in) as u64,
                bytemuck::cast_slice(x),
            );
        }
        let mut encoder = self
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("orbit mlp forward"),
            });
        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("orbit mlp forward"),
                timestamp_writes: None,
            });
            pass.set_pipeline(&self.pipeline);
            for l in &self.layers {
                pass.set_bind_group(0, &l.bind_group, &[]);
                pass.dispatch_workgroups(
                    l.n.div_ceil(TILE) as u32,
                    rows.div_ceil(TILE) as u32,
                    self.stacks as u32,
                );
            }
        }
        let bytes = (4 * outputs) as u64;
        encoder.copy_buffer_to_buffer(&self.output, 0, &self.readback, 0, bytes);
        let submission = self.queue.submit([encoder.finish()]);
        crate::readback::read_mapped(
            &self.device,
            submission,
            (&self.readback, bytes),
            "forward pass",
            |values| out.copy_from_slice(values),
        )
    }
}

/// The layer kernel's pipeline; an error says what the driver reported. Trusted, it is
/// compiled without the clamps wgpu would put on its workgroup-memory indices and the counters
/// it would put on its loops, which cost 18 % of a forward pass on an H200: the indices
/// stay below the tiles' 1 024 floats by construction (`li + 256 i`, `16 kx + r`,
/// `64 kk + lid + 48`), the loops run over `p.k` and constants, and the buffer accesses are
/// guarded in the kernel and by the device's robust buffer access.
fn pipeline(device: &wgpu::Device, trusted: bool) -> Result<wgpu::ComputePipeline, MlpError> {
    let scopes = [
        wgpu::ErrorFilter::Validation,
        wgpu::ErrorFilter::OutOfMemory,
        wgpu::ErrorFilter::Internal,
    ]
    .map(|filter| device.push_error_scope(filter));
    let mut checks = wgpu::ShaderRuntimeChecks::checked();
    if trusted {
        checks.bounds_checks = false;
        checks.force_loop_bounding = false;
    }
    let descriptor = wgpu::ShaderModuleDescriptor {
        label: Some("orbit mlp layer"),
        source: wgpu::ShaderSource::Wgsl(LAYER_SOURCE.into()),
    };
    // SAFETY: the layer kernel meets the conditions above.
    let module = unsafe { device.create_shader_module_trusted(descriptor, checks) };
    let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some("orbit mlp layer"),
        layout: None,
        module: &module,
        entry_point: Some("main"),
        compilation_options: Default::default(),
        cache: None,
    });
    for scope in scopes.into_iter().rev() {
        if let Some(e) = pollster::block_on(scope.pop()) {
            return Err(MlpError::Device(format!(
                "the driver could not build the layer kernel: {e}"
            )));
        }
    }
    Ok(pipeline)
}

#[cfg(test)]
mod tests {
    use super::{Activation, StackedMlp};

    /// The outputs of `stacks` networks of `widths` on `rows` rows, as bits, with the kernel
    /// trusted or checked.
    fn outputs(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        trusted: bool,
        (rows, stacks, widths): (usize, usize, &[usize]),
    ) -> Vec<u32> {
        let mut mlp = StackedMlp::build(
            device,
            queue,
            (rows, stacks, widths, Activation::Elu),
            trusted,
        )
        .expect("network");
        for (l, d) in widths.windows(2).enumerate() {
            let w: Vec<f32> = (0..stacks * d[0] * d[1])
                .map(|i| ((i * 37 + l) % 101) as f32 / 101.0 - 0.5)
                .collect();
            let b: Vec<f32> = (0..stacks * d[1])
                .map(|i| (i % 7) as f32 * 0.1 - 0.3)
                .collect();
            mlp.load_layer(l, &w, &b).expect("layer");
        }
        let x: Vec<f32> = (0..stacks * rows * widths[0])
            .map(|i| ((i * 13) % 29) as f32 / 29.0 - 0.5)
            .collect();
        let inputs: Vec<&[f32]> = x.chunks(rows * widths[0]).collect();
        let mut out = vec![0.0; stacks * rows * widths[widths.len() - 1]];
        mlp.forward(&inputs, &mut out).expect("forward");
        out.iter().map(|v| v.to_bits()).collect()
    }

    /// The trusted kernel gives the checked kernel's outputs bit for bit, on shapes that leave
    /// every tile of rows, columns and inputs partly empty (an index out of a tile would read
    /// a clamped element in one and other memory in the other).
    #[test]
    fn the_trusted_layer_kernel_computes_what_the_checked_one_does() {
        if !orbit_physics_wgpu::gpu_available_for_tests() {
            return;
        }
        let gpu = orbit_physics_wgpu::gpu().expect("checked above");
        let shape = (100, 2, &[13, 70, 33, 5][..]);
        let trusted = outputs(&gpu.device, &gpu.queue, true, shape);
        let checked = outputs(&gpu.device, &gpu.queue, false, shape);
        assert_eq!(trusted, checked);
    }
}
