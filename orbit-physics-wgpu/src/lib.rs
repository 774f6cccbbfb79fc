//! orbit-physics-wgpu: the GPU physics backend. Every env is one invocation of a WGSL compute
//! kernel that runs reduced-coordinate articulation dynamics (RNEA, CRBA, Cholesky), free rigid
//! bodies, primitive contacts (MuJoCo's soft constraints or Box2D's soft step) and a projected
//! Gauss–Seidel solver with warm starting (see `docs/physics.md`). All envs share one topology:
//! `codegen/` writes the scene-specific half of the kernel as straight-line code, the files of
//! `step/` are the rest. State stays on the GPU between steps and is read back, in exactly the layout the
//! batched views expose, when it is first looked at after a step (`mirror.rs`).
//!
//! Determinism: each env is computed by a fixed sequence of operations in one invocation, with
//! no atomics; the same inputs give the same bits on the same device.
//!
//! Modules: `backend/` is [`WgpuBackend`] (its resources, dispatches, uploads and readback),
//! `gpu.rs` the shared Vulkan device, `compile.rs` the scene compiled for the kernel,
//! `layout.rs` the buffers' layout, `codegen/` the kernel generator, `weights.rs` the
//! constraint rows' inverse weights, `gather.rs` the row gather and scatter kernels,
//! `mirror.rs` the host copy of the state.

mod backend;
mod codegen;
mod compile;
mod gather;
mod gpu;
mod layout;
mod mirror;
mod weights;

use orbit_core::physics::BackendRegistration;

pub use backend::WgpuBackend;
pub use compile::{MAX_CONTACTS, MAX_DOFS, MAX_LINKS, default_solver_iterations};
pub use gpu::{
    Gpu, ThreadDevice, gpu, gpu_available_for_tests, open_device_for_this_thread, select_gpu,
};

/// Name under which this backend is registered.
pub const BACKEND_NAME: &str = "wgpu";

inventory::submit! {
    BackendRegistration {
        name: BACKEND_NAME,
        description: "GPU: all envs in one WGSL compute kernel (wgpu, Vulkan)",
        build: |scene, num_envs, sim| Ok(Box::new(WgpuBackend::new(scene, num_envs, sim)?)),
        probe: gpu::probe,
    }
}
