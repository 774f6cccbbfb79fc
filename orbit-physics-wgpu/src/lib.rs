//! orbit-physics-wgpu: the GPU physics backend. Every env is one invocation of a WGSL compute
//! kernel that runs reduced-coordinate articulation dynamics (RNEA, CRBA, Cholesky), free rigid
//! bodies, primitive contacts (MuJoCo's soft constraints or Box2D's soft step) and a projected
//! Gauss–Seidel solver with warm starting (see `docs/physics.md`). All envs share one topology:
//! `codegen.rs` writes the scene-specific half of the kernel as straight-line code, `step.wgsl`
//! is the rest. State stays on the GPU between steps and is read back, in exactly the layout the
//! batched views expose, when it is first looked at after a step (`mirror.rs`).
//!
//! Determinism: each env is computed by a fixed sequence of operations in one invocation, with
//! no atomics; the same inputs give the same bits on the same device.

mod codegen;
mod compile;
mod gather;
mod gpu;
mod layout;
mod mirror;
mod weights;

use std::sync::Arc;

use glam::{Quat, Vec3, Vec4};
use orbit_core::physics::{
    ArticulationView, BackendRegistration, BodyRef, PhysicsBackend, PhysicsError, RigidObjectView,
    SceneLayout, SimCfg, check_batch, check_dof_ids, check_env_ids, check_root_states,
    check_values,
};
use orbit_core::scene::{RootState, SceneDesc};

pub use compile::{MAX_CONTACTS, MAX_DOFS, MAX_LINKS, default_solver_iterations};
pub use gpu::{Gpu, gpu};

use compile::CompiledScene;
use gather::RowGather;
use layout::{BufferLayout, FRESH, NOT_FRESH, REPUBLISH};
use mirror::HostMirror;

/// Name under which this backend is registered.
pub const BACKEND_NAME: &str = "wgpu";

inventory::submit! {
    BackendRegistration {
        name: BACKEND_NAME,
        description: "GPU: all envs in one WGSL compute kernel (wgpu, Vulkan)",
        build: |scene, num_envs, sim| Ok(Box::new(WgpuBackend::new(scene, num_envs, sim)?)),
    }
}

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
    /// `timestamps` holds the kernel times of a dispatch that ran substeps.
    timed: bool,
}

/// The part of the host mirror that the dispatches since it was last current have changed.
enum Stale {
    /// Every env (a step ran, or a republish of all envs).
    All,
    /// Only these envs were republished (after a state write or a mass change); every other
    /// row is current.
    Envs(Vec<u32>),
}

/// Two GPU timestamps around the step kernel, resolved into a buffer that each step copies
/// into `timestamps` for `last_kernel_time` to read.
struct KernelTimer {
    queries: wgpu::QuerySet,
    resolved: wgpu::Buffer,
    /// Nanoseconds per timestamp tick.
    period_ns: f64,
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
        sim.validate()?;
        if num_envs == 0 {
            return Err(PhysicsError::InvalidInput(
                "num_envs must be at least 1".into(),
            ));
        }
        let scene = CompiledScene::new(desc)?;
        let gpu = gpu::gpu().map_err(err)?;
        let buffers = BufferLayout::new(&scene, num_envs);
        let limits = &gpu.limits;
        let groups = num_envs.div_ceil(WORKGROUP);
        if groups > limits.max_compute_workgroups_per_dimension as usize {
            return Err(err(format!(
                "{num_envs} envs need {groups} workgroups of {WORKGROUP}, more than the device's {}",
                limits.max_compute_workgroups_per_dimension
            )));
        }
        let largest = buffers
            .state_len
            .max(buffers.inputs_len)
            .max(buffers.warm_len) as u64
            * 4;
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
        let source = codegen::kernel_source(&scene, sim, WORKGROUP);
        let pipeline = gpu.pipeline(&source);
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
        let timer = device
            .features()
            .contains(wgpu::Features::TIMESTAMP_QUERY)
            .then(|| KernelTimer {
                queries: device.create_query_set(&wgpu::QuerySetDescriptor {
                    label: Some("orbit step timestamps"),
                    ty: wgpu::QueryType::Timestamp,
                    count: 2,
                }),
                resolved: device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("orbit step timestamps"),
                    size: 16,
                    usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
                    mapped_at_creation: false,
                }),
                period_ns: f64::from(gpu.queue.get_timestamp_period()),
            });
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
            ],
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

    /// The published state, read back first if a dispatch ran since it was last read.
    fn state_f32(&self) -> &[f32] {
        bytemuck::cast_slice(self.state.get(|dst| self.read_back(dst)))
    }

    /// The host copy of the state for host-side writes (current first, so that rows written
    /// back in the same span as the written envs hold the GPU's values).
    fn state_f32_mut(&mut self) -> &mut [f32] {
        self.state_f32();
        bytemuck::cast_slice_mut(self.state.get_mut())
    }

    /// Waits for `slice` of a readback buffer to be mapped (after the submission that fills it).
    /// The views cannot return errors: a GPU lost while reading back is a panic.
    fn map_read(&self, slice: &wgpu::BufferSlice<'_>) {
        slice.map_async(wgpu::MapMode::Read, |_| {});
        self.gpu
            .device
            .poll(wgpu::PollType::Wait {
                submission_index: None,
                timeout: None,
            })
            .unwrap_or_else(|e| panic!("the GPU did not finish the physics step: {e}"));
    }

    /// Copies the last dispatch's published state into `dst`. The copy into the readback
    /// buffer is queued here, when the state is looked at, not with every step: at 65 536
    /// envs it is tens of megabytes over the bus, as long as a quarter of the step's kernel.
    fn read_back(&self, dst: &mut [Vec4]) {
        match &self.stale {
            Stale::All => self.read_back_all(dst),
            Stale::Envs(ids) => self.read_back_rows(ids, dst),
        }
    }

    /// Copies the rows of `env_ids` (all that changed since `dst` was current) into `dst`.
    fn read_back_rows(&self, env_ids: &[u32], dst: &mut [Vec4]) {
        if env_ids.is_empty() {
            return;
        }
        let mut encoder = self
            .gpu
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("orbit gather"),
            });
        let bytes = self
            .gather
            .encode(&self.gpu, &mut encoder, env_ids, &self.staging);
        self.gpu.queue.submit([encoder.finish()]);
        let slice = self.staging.slice(..bytes.max(4));
        self.map_read(&slice);
        {
            let view = slice
                .get_mapped_range()
                .unwrap_or_else(|e| panic!("reading the reset envs' state back failed: {e}"));
            self.gather.scatter(
                env_ids,
                bytemuck::cast_slice(&view),
                bytemuck::cast_slice_mut(dst),
            );
        }
        self.staging.unmap();
    }

    /// Copies the whole published state into `dst`.
    fn read_back_all(&self, dst: &mut [Vec4]) {
        let bytes = (self.buffers.state_len * 4) as u64;
        let mut encoder = self
            .gpu
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("orbit readback"),
            });
        encoder.copy_buffer_to_buffer(&self.state_buf, 0, &self.staging, 0, bytes);
        self.gpu.queue.submit([encoder.finish()]);
        let slice = self.staging.slice(..bytes);
        self.map_read(&slice);
        {
            let view = slice
                .get_mapped_range()
                .unwrap_or_else(|e| panic!("reading the physics state back failed: {e}"));
            let len = self.buffers.state_len;
            let state: &mut [f32] = bytemuck::cast_slice_mut(dst);
            // Tens of megabytes at 65 536 envs: copied on every core.
            orbit_core::parallel::copy(bytemuck::cast_slice(&view), &mut state[..len]);
        }
        self.staging.unmap();
    }

    /// Waits for the submission `index` (the dispatch before the one just submitted, see
    /// `dispatch`), if any.
    fn wait_for(&self, index: Option<wgpu::SubmissionIndex>) -> Result<(), PhysicsError> {
        if let Some(index) = index {
            self.gpu
                .device
                .poll(wgpu::PollType::Wait {
                    submission_index: Some(index),
                    timeout: None,
                })
                .map_err(|e| err(format!("the GPU did not finish the step: {e}")))?;
        }
        Ok(())
    }

    /// Default joint state, object root states, unit mass scales and the shapes' frictions.
    fn init_state(&mut self, desc: &SceneDesc) {
        let n = self.buffers.num_envs;
        for (a, art) in desc.articulations.iter().enumerate() {
            let off = self.buffers.articulations[a].clone();
            let dofs = off.dofs;
            for e in 0..n {
                for i in 0..dofs {
                    let s = self.state_f32_mut();
                    s[off.joints + e * dofs + i] = art.default_joint_pos[i];
                    s[off.joints + off.joint_len + e * dofs + i] = art.default_joint_vel[i];
                    self.inputs[off.inputs + e * dofs + i] = art.default_joint_pos[i];
                    self.inputs[off.inputs + off.joint_len + e * dofs + i] =
                        art.default_joint_vel[i];
                }
            }
        }
        for (o, obj) in desc.rigid_objects.iter().enumerate() {
            let states = vec![obj.default_root_state; n];
            self.put_root_states(o, &(0..n).collect::<Vec<_>>(), &states);
        }
        let bodies = self.scene.num_bodies();
        let shapes = self.scene.shapes.len();
        for e in 0..n {
            for b in 0..bodies {
                self.inputs[self.buffers.mass_scale + e * bodies + b] = 1.0;
            }
            for s in 0..shapes {
                self.inputs[self.buffers.friction + e * shapes + s] = self.scene.shapes[s].friction;
            }
        }
    }

    fn put_root_states(&mut self, o: usize, env_ids: &[usize], states: &[RootState]) {
        let off = self.buffers.objects[o].clone();
        let s = self.state_f32_mut();
        for (&e, st) in env_ids.iter().zip(states) {
            s[off.pos + e * 3..off.pos + e * 3 + 3].copy_from_slice(&st.pose.pos.to_array());
            s[off.quat + e * 4..off.quat + e * 4 + 4]
                .copy_from_slice(&st.pose.rot.normalize().to_array());
            s[off.lin + e * 3..off.lin + e * 3 + 3].copy_from_slice(&st.lin_vel.to_array());
            s[off.ang + e * 3..off.ang + e * 3 + 3].copy_from_slice(&st.ang_vel.to_array());
        }
    }

    fn upload_state(&self) {
        self.gpu
            .queue
            .write_buffer(&self.state_buf, 0, bytemuck::cast_slice(self.state_f32()));
    }

    /// Uploads the rows of `env_ids` in each state section `(first float, floats per env)`:
    /// packed and put in place by the write kernel when the envs are few (at most a quarter)
    /// and far apart, else per section the span from the lowest to the highest env written.
    fn upload_state_rows(&self, env_ids: &[usize], sections: &[(usize, usize)]) {
        if self
            .gather
            .write(&self.gpu, env_ids, sections, self.state_f32())
        {
            return;
        }
        for &(start, width) in sections {
            let Some(range) = layout::env_rows(start, width, env_ids) else {
                return;
            };
            self.gpu.queue.write_buffer(
                &self.state_buf,
                (range.start * 4) as u64,
                bytemuck::cast_slice(&self.state_f32()[range]),
            );
        }
    }

    /// Uploads the dirty ranges of `inputs`, overlapping ones merged.
    fn upload_inputs(&mut self) {
        self.dirty.sort_unstable_by_key(|r| r.start);
        let mut ranges = self.dirty.drain(..);
        let Some(mut run) = ranges.next() else {
            return;
        };
        let upload = |r: std::ops::Range<usize>| {
            self.gpu.queue.write_buffer(
                &self.inputs_buf,
                (r.start * 4) as u64,
                bytemuck::cast_slice(&self.inputs[r]),
            );
        };
        for r in ranges {
            if r.start <= run.end {
                run.end = run.end.max(r.end);
            } else {
                upload(std::mem::replace(&mut run, r));
            }
        }
        upload(run);
    }

    /// Marks `len` inputs from `start` for the next upload.
    fn mark(&mut self, start: usize, len: usize) {
        self.dirty.push(start..start + len);
    }

    /// Marks the rows of `env_ids` in the per-env input section at `section` (`per_env`
    /// values per env) for the next upload: the span from the lowest to the highest.
    fn mark_env_rows(&mut self, section: usize, per_env: usize, env_ids: &[usize]) {
        self.dirty
            .extend(layout::env_rows(section, per_env, env_ids));
    }

    /// Runs `substeps` substeps (0: only recompute what is published, for the envs `marked` if
    /// given, which [`republish`](Self::republish) flagged with [`REPUBLISH`]; else for all).
    /// The host mirror reads the published state back when it is next looked at.
    fn dispatch(&mut self, substeps: u32, marked: Option<&[usize]>) -> Result<(), PhysicsError> {
        let marked = marked.filter(|_| substeps == 0);
        self.upload_inputs();
        // Steps (not republishes) are timed.
        let timer = self.timer.as_ref().filter(|_| substeps > 0);
        let gpu = self.gpu.clone();
        let queue = &gpu.queue;
        queue.write_buffer(
            &self.params_buf,
            0,
            bytemuck::cast_slice(&[substeps, u32::from(marked.is_some()), 0, 0]),
        );
        let device = &gpu.device;
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("orbit step"),
        });
        {
            let timestamp_writes = timer.map(|t| wgpu::ComputePassTimestampWrites {
                query_set: &t.queries,
                beginning_of_pass_write_index: Some(0),
                end_of_pass_write_index: Some(1),
            });
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("orbit step"),
                timestamp_writes,
            });
            pass.set_pipeline(&self.pipeline);
            pass.set_bind_group(0, &self.bind_group, &[]);
            pass.dispatch_workgroups(self.buffers.num_envs.div_ceil(WORKGROUP) as u32, 1, 1);
        }
        if let Some(t) = timer {
            encoder.resolve_query_set(&t.queries, 0..2, &t.resolved, 0);
            encoder.copy_buffer_to_buffer(&t.resolved, 0, &self.timestamps, 0, 16);
        }
        // Submit this step, then wait for the one before it: the GPU always has the next
        // step queued, and at most two are in flight.
        let submitted = queue.submit([encoder.finish()]);
        if timer.is_some() {
            self.timed = true;
        }
        self.mark_stale(marked);
        let previous = self.pending.replace(submitted);
        // Fresh flags last until a step has consumed them (its first substep skips the warm
        // start); a republish leaves them set. The submitted step consumes them whether or
        // not the wait below succeeds.
        if substeps > 0 {
            let fresh = self.buffers.fresh;
            let rows = layout::env_rows(fresh, 1, &self.fresh_envs);
            for e in self.fresh_envs.drain(..) {
                self.inputs[fresh + e] = NOT_FRESH;
            }
            self.dirty.extend(rows);
        }
        self.wait_for(previous)
    }

    /// Records what a dispatch makes stale: the envs `marked` if it republished only those,
    /// else every env.
    fn mark_stale(&mut self, marked: Option<&[usize]>) {
        let previous = std::mem::replace(&mut self.stale, Stale::All);
        let ids = marked.map(|ids| ids.iter().map(|&e| e as u32));
        let stale = match (ids, previous) {
            (Some(ids), _) if self.state.is_current() => Stale::Envs(ids.collect()),
            (Some(ids), Stale::Envs(mut earlier)) => {
                earlier.extend(ids);
                Stale::Envs(earlier)
            }
            _ => Stale::All,
        };
        self.stale = match stale {
            Stale::Envs(ids) if self.gather.worthwhile(ids.len()) => Stale::Envs(ids),
            _ => Stale::All,
        };
        self.state.invalidate();
    }

    /// Marks every env fresh and republishes (after construction).
    fn refresh_all(&mut self) -> Result<(), PhysicsError> {
        let (fresh, n) = (self.buffers.fresh, self.buffers.num_envs);
        self.inputs[fresh..fresh + n].fill(FRESH);
        self.mark(fresh, n);
        self.fresh_envs = (0..n).collect();
        self.dispatch(0, None)
    }

    /// After a state write to `sections` (see [`upload_state_rows`](Self::upload_state_rows)):
    /// upload those rows, flag the envs fresh (the next step's first substep runs them without
    /// warm starts) and republish the envs of this write.
    fn after_write(
        &mut self,
        env_ids: &[usize],
        sections: &[(usize, usize)],
    ) -> Result<(), PhysicsError> {
        let fresh = self.buffers.fresh;
        for &e in env_ids {
            if self.inputs[fresh + e] == NOT_FRESH {
                self.inputs[fresh + e] = FRESH;
                self.fresh_envs.push(e);
            }
        }
        self.upload_state_rows(env_ids, sections);
        self.republish(env_ids)
    }

    /// Republishes `env_ids` only, so that only their rows are read back and every other env's
    /// state stays as it was, envs written earlier in the same step included (a republish
    /// normalises quaternions and moves velocities to the centre of mass and back, which can
    /// move the last bits of a state it republishes again). Their fresh flags carry
    /// [`REPUBLISH`] for the dispatch and are restored after it, also when it fails.
    fn republish(&mut self, env_ids: &[usize]) -> Result<(), PhysicsError> {
        if env_ids.is_empty() {
            return Ok(());
        }
        let fresh = self.buffers.fresh;
        for &e in env_ids {
            self.inputs[fresh + e] += REPUBLISH;
        }
        self.mark_env_rows(fresh, 1, env_ids);
        let published = self.dispatch(0, Some(env_ids));
        for &e in env_ids {
            self.inputs[fresh + e] -= REPUBLISH;
        }
        self.mark_env_rows(fresh, 1, env_ids);
        published
    }

    fn check_articulation(&self, a: usize) -> Result<layout::ArticulationOffsets, PhysicsError> {
        self.buffers.articulations.get(a).cloned().ok_or_else(|| {
            PhysicsError::InvalidInput(format!(
                "articulation index {a} out of range ({} articulations)",
                self.buffers.articulations.len()
            ))
        })
    }

    /// Copies a full `num_envs × dofs` input batch into input quantity `k`.
    fn set_inputs(
        &mut self,
        a: usize,
        k: usize,
        what: &str,
        values: &[f32],
    ) -> Result<(), PhysicsError> {
        let off = self.check_articulation(a)?;
        check_batch(what, values, self.buffers.num_envs, off.dofs)?;
        let start = off.inputs + k * off.joint_len;
        self.inputs[start..start + values.len()].copy_from_slice(values);
        self.mark(start, values.len());
        Ok(())
    }

    /// Global body index of a body reference, checked.
    fn body_index(&self, body: BodyRef) -> Result<usize, PhysicsError> {
        match body {
            BodyRef::Link { articulation, link } => {
                let &(first, links, _, _) =
                    self.scene.articulations.get(articulation).ok_or_else(|| {
                        PhysicsError::InvalidInput(format!(
                            "articulation index {articulation} out of range"
                        ))
                    })?;
                if link >= links {
                    return Err(PhysicsError::InvalidInput(format!(
                        "link index {link} out of range ({links} links)"
                    )));
                }
                Ok(first + link)
            }
            BodyRef::RigidObject(o) => {
                if o >= self.scene.objects.len() {
                    return Err(PhysicsError::InvalidInput(format!(
                        "rigid object index {o} out of range"
                    )));
                }
                Ok(self.scene.links.len() + o)
            }
        }
    }
}

impl PhysicsBackend for WgpuBackend {
    fn name(&self) -> &'static str {
        BACKEND_NAME
    }

    fn num_envs(&self) -> usize {
        self.buffers.num_envs
    }

    fn layout(&self) -> &SceneLayout {
        &self.layout
    }

    fn dt(&self) -> f32 {
        self.sim.dt
    }

    fn sync(&self) {
        self.state_f32();
    }

    fn last_kernel_time(&self) -> Option<std::time::Duration> {
        let t = self.timer.as_ref().filter(|_| self.timed)?;
        let slice = self.timestamps.slice(..);
        self.map_read(&slice);
        let ticks: [u64; 2] = {
            let view = slice
                .get_mapped_range()
                .unwrap_or_else(|e| panic!("reading the kernel timestamps back failed: {e}"));
            bytemuck::pod_read_unaligned(&view)
        };
        self.timestamps.unmap();
        let ns = ticks[1].saturating_sub(ticks[0]) as f64 * t.period_ns;
        Some(std::time::Duration::from_nanos(ns as u64))
    }

    fn device_memory_bytes(&self) -> usize {
        // State, inputs, warm starts, the readback copy, the layout table and the gather's.
        let b = &self.buffers;
        4 * (2 * b.state_len + b.inputs_len + b.warm_len + self.lay_len)
            + self.gather.device_memory_bytes()
    }

    fn step(&mut self) -> Result<(), PhysicsError> {
        self.dispatch(1, None)
    }

    fn step_n(&mut self, n: usize) -> Result<(), PhysicsError> {
        if n == 0 {
            return Ok(());
        }
        let n = u32::try_from(n)
            .map_err(|_| PhysicsError::InvalidInput(format!("{n} steps in one call")))?;
        self.dispatch(n, None)
    }

    fn articulation(&self, a: usize) -> ArticulationView<'_> {
        let off = &self.buffers.articulations[a];
        let n = self.buffers.num_envs;
        let s = self.state_f32();
        let (d, l) = (n * off.dofs, n * off.links);
        let j = |k: usize| &s[off.joints + k * off.joint_len..off.joints + k * off.joint_len + d];
        ArticulationView {
            num_links: off.links,
            joint_pos: j(0),
            joint_vel: j(1),
            bias_forces: j(2),
            applied_effort: j(3),
            link_pos: bytemuck::cast_slice(&s[off.link_pos..off.link_pos + 3 * l]),
            link_quat: bytemuck::cast_slice(&s[off.link_quat..off.link_quat + 4 * l]),
            link_lin_vel: bytemuck::cast_slice(&s[off.link_lin..off.link_lin + 3 * l]),
            link_ang_vel: bytemuck::cast_slice(&s[off.link_ang..off.link_ang + 3 * l]),
        }
    }

    fn rigid_object(&self, o: usize) -> RigidObjectView<'_> {
        let off = &self.buffers.objects[o];
        let n = self.buffers.num_envs;
        let s = self.state_f32();
        RigidObjectView {
            pos: bytemuck::cast_slice::<f32, Vec3>(&s[off.pos..off.pos + 3 * n]),
            quat: bytemuck::cast_slice::<f32, Quat>(&s[off.quat..off.quat + 4 * n]),
            lin_vel: bytemuck::cast_slice(&s[off.lin..off.lin + 3 * n]),
            ang_vel: bytemuck::cast_slice(&s[off.ang..off.ang + 3 * n]),
        }
    }

    fn set_joint_position_targets(
        &mut self,
        a: usize,
        targets: &[f32],
    ) -> Result<(), PhysicsError> {
        self.set_inputs(a, 0, "joint position targets", targets)
    }

    fn set_joint_velocity_targets(
        &mut self,
        a: usize,
        targets: &[f32],
    ) -> Result<(), PhysicsError> {
        self.set_inputs(a, 1, "joint velocity targets", targets)
    }

    fn set_joint_efforts(&mut self, a: usize, efforts: &[f32]) -> Result<(), PhysicsError> {
        self.set_inputs(a, 2, "joint efforts", efforts)
    }

    fn set_bias_compensation(
        &mut self,
        a: usize,
        dofs: &[usize],
        enabled: bool,
    ) -> Result<(), PhysicsError> {
        check_dof_ids(dofs, self.check_articulation(a)?.dofs)?;
        let first = self.scene.articulations[a].2;
        for &d in dofs {
            self.inputs[self.buffers.compensate + first + d] = if enabled { 1.0 } else { 0.0 };
        }
        self.mark(self.buffers.compensate, self.scene.dofs.len());
        Ok(())
    }

    fn write_joint_state(
        &mut self,
        a: usize,
        env_ids: &[usize],
        pos: &[f32],
        vel: &[f32],
    ) -> Result<(), PhysicsError> {
        let off = self.check_articulation(a)?;
        check_env_ids(env_ids, self.buffers.num_envs)?;
        let dofs = off.dofs;
        check_batch("joint positions", pos, env_ids.len(), dofs)?;
        check_batch("joint velocities", vel, env_ids.len(), dofs)?;
        let s = self.state_f32_mut();
        for (i, &e) in env_ids.iter().enumerate() {
            let row = off.joints + e * dofs;
            s[row..row + dofs].copy_from_slice(&pos[i * dofs..(i + 1) * dofs]);
            let row = row + off.joint_len;
            s[row..row + dofs].copy_from_slice(&vel[i * dofs..(i + 1) * dofs]);
        }
        let sections = [off.joint_section(0), off.joint_section(1)];
        self.after_write(env_ids, &sections)
    }

    fn write_root_state(
        &mut self,
        o: usize,
        env_ids: &[usize],
        states: &[RootState],
    ) -> Result<(), PhysicsError> {
        self.body_index(BodyRef::RigidObject(o))?;
        check_env_ids(env_ids, self.buffers.num_envs)?;
        check_root_states(states, env_ids.len())?;
        self.put_root_states(o, env_ids, states);
        let sections = self.buffers.objects[o].sections();
        self.after_write(env_ids, &sections)
    }

    fn set_masses(
        &mut self,
        body: BodyRef,
        env_ids: &[usize],
        masses: &[f32],
    ) -> Result<(), PhysicsError> {
        let b = self.body_index(body)?;
        check_env_ids(env_ids, self.buffers.num_envs)?;
        check_values("masses", masses, env_ids.len(), "> 0", |m| m > 0.0)?;
        let default = self.default_masses[b];
        if default <= 0.0 {
            return Err(PhysicsError::InvalidInput(format!(
                "body {body:?} has no mass to scale"
            )));
        }
        let bodies = self.scene.num_bodies();
        for (&e, &m) in env_ids.iter().zip(masses) {
            self.inputs[self.buffers.mass_scale + e * bodies + b] = m / default;
        }
        self.mark_env_rows(self.buffers.mass_scale, bodies, env_ids);
        // Bias forces depend on the masses: republish the envs whose masses changed.
        self.republish(env_ids)
    }

    fn set_friction(
        &mut self,
        body: BodyRef,
        env_ids: &[usize],
        friction: &[f32],
    ) -> Result<(), PhysicsError> {
        let b = self.body_index(body)?;
        check_env_ids(env_ids, self.buffers.num_envs)?;
        check_values("friction", friction, env_ids.len(), ">= 0", |f| f >= 0.0)?;
        let shapes = self.scene.shapes.len();
        for (s, shape) in self.scene.shapes.iter().enumerate() {
            if shape.body == Some(b) {
                for (&e, &f) in env_ids.iter().zip(friction) {
                    self.inputs[self.buffers.friction + e * shapes + s] = f;
                }
            }
        }
        self.mark_env_rows(self.buffers.friction, shapes, env_ids);
        Ok(())
    }
}

/// For tests: whether a GPU is available. Without one it prints `SKIPPED: …` and returns
/// false, unless `ORBIT_REQUIRE_GPU=1` (set by `.ci/run`), which makes a missing GPU a panic.
pub fn gpu_available_for_tests() -> bool {
    match gpu() {
        Ok(gpu) => {
            eprintln!(
                "wgpu adapter: {} ({:?})",
                gpu.info.name, gpu.info.device_type
            );
            true
        }
        Err(e) if std::env::var("ORBIT_REQUIRE_GPU").is_ok_and(|v| v == "1") => {
            panic!("ORBIT_REQUIRE_GPU=1 but no GPU: {e}")
        }
        Err(e) => {
            eprintln!("SKIPPED: no Vulkan adapter for the wgpu backend: {e}");
            false
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The box-pushing scene on `n` envs after one env step under fixed efforts, synchronised;
    /// None without a GPU.
    fn stepped_box_pushing(n: usize) -> Option<(SceneDesc, WgpuBackend)> {
        if !gpu_available_for_tests() {
            return None;
        }
        let scene = orbit_assets::box_pushing_scene(&[]).expect("bundled scene");
        let mut b = WgpuBackend::new(&scene, n, &SimCfg::default()).expect("backend");
        let efforts: Vec<f32> = (0..n * 7).map(|i| ((i % 13) as f32 - 6.0) * 0.5).collect();
        b.set_joint_efforts(0, &efforts).unwrap();
        b.step_n(10).unwrap();
        b.sync();
        Some((scene, b))
    }

    /// Asserts that the host mirror (refreshed as a reader would) holds, bit for bit, what a
    /// read of the whole state gives.
    fn assert_mirror_is_whole_state(b: &mut WgpuBackend) {
        let mirror: Vec<u32> = b.state_f32().iter().map(|x| x.to_bits()).collect();
        let mut whole = vec![Vec4::ZERO; b.buffers.state_len.div_ceil(4)];
        b.read_back_all(&mut whole);
        let whole: Vec<u32> = bytemuck::cast_slice::<Vec4, f32>(&whole)
            .iter()
            .map(|x| x.to_bits())
            .collect();
        assert_eq!(mirror, whole);
    }

    /// After a reset of a few envs the host mirror reads back only their rows; it must then
    /// hold exactly what a read of the whole state gives, in every section.
    #[test]
    fn reading_back_the_reset_rows_gives_the_whole_state() {
        let Some((_, mut b)) = stepped_box_pushing(64) else {
            return;
        };
        let ids = [3, 17, 40, 41, 63];
        let pos: Vec<f32> = (0..ids.len() * 7).map(|i| 0.01 * i as f32).collect();
        b.write_joint_state(0, &ids, &pos, &vec![0.1; ids.len() * 7])
            .unwrap();
        let mut root = RootState::default();
        root.pose.pos = Vec3::new(0.4, 0.1, 0.3);
        b.write_root_state(0, &ids[1..3], &[root; 2]).unwrap();
        // The root write read the joint write's rows back before changing two of them, and
        // republished only those two.
        assert!(
            matches!(&b.stale, Stale::Envs(e) if e[..] == [17, 40]),
            "only the envs of the last write are stale"
        );
        assert_mirror_is_whole_state(&mut b);
        assert_eq!(b.articulation(0).joint_pos[17 * 7 + 3], pos[7 + 3]);
        assert_eq!(b.rigid_object(0).pos[40], root.pose.pos);
    }

    /// A mass change republishes its env at once (the bias forces follow the new mass) and
    /// leaves the host mirror exactly what a read of the whole state gives.
    #[test]
    fn a_mass_change_republishes_its_env() {
        let n = 16;
        let Some((scene, mut b)) = stepped_box_pushing(n) else {
            return;
        };
        let links = &scene.articulations[0].model.links;
        let link = links.iter().rposition(|l| l.inertial.mass > 0.0).unwrap();
        let hand = BodyRef::Link {
            articulation: 0,
            link,
        };
        let before = b.articulation(0).bias_forces.to_vec();
        b.set_masses(hand, &[5], &[3.0 * links[link].inertial.mass])
            .unwrap();
        let after = b.articulation(0).bias_forces.to_vec();
        for e in 0..n {
            let moved = before[e * 7..e * 7 + 7] != after[e * 7..e * 7 + 7];
            assert_eq!(moved, e == 5, "env {e}'s bias forces");
        }
        assert_mirror_is_whole_state(&mut b);
    }
}
