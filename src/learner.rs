//! The learner's burn device: the CPU (flex), or burn's wgpu backend on the Vulkan device the
//! wgpu physics backend uses (one device per process, so physics and learner share a queue and
//! its memory). The fused GPU update runs on that Vulkan device too, with burn's copy of the
//! network on the CPU.

use orbit_rl::burn::tensor::Device;
use orbit_rl::{GpuUpdate, LearnerDevice, RlError, RunnerCfg};

/// The burn device for `cfg`'s learner, one of `ranks` data-parallel replicas. A GPU device
/// is registered once per process; later calls return the same device.
pub fn learner_device(cfg: &RunnerCfg, ranks: usize) -> Result<Device, RlError> {
    match (cfg.device, cfg.gpu_update) {
        (LearnerDevice::Cpu, _) => Ok(Device::flex()),
        (LearnerDevice::Gpu, GpuUpdate::Fused) if ranks > 1 => Err(RlError::Device(
            "data-parallel training averages gradients on the host after every minibatch, \
             which the fused GPU update does not: set `gpu_update: Burn` (a build with \
             `--features gpu-learner`) or train on one rank"
                .into(),
        )),
        (LearnerDevice::Gpu, GpuUpdate::Fused) => {
            let gpu = orbit_physics_wgpu::gpu().map_err(RlError::Device)?;
            orbit_rl::share_wgpu_device(gpu.device.clone(), gpu.queue.clone());
            tracing::info!(adapter = %gpu.info.name, "fused PPO update on the physics' Vulkan device");
            Ok(Device::flex())
        }
        (LearnerDevice::Gpu, GpuUpdate::Burn) => gpu_device(),
    }
}

#[cfg(feature = "gpu-learner")]
fn gpu_device() -> Result<Device, RlError> {
    use orbit_rl::burn::tensor::wgpu::{WgpuSetup, wgpu};
    use std::sync::OnceLock;
    static DEVICE: OnceLock<Result<Device, String>> = OnceLock::new();
    DEVICE
        .get_or_init(|| {
            let gpu = orbit_physics_wgpu::gpu()?;
            let setup = WgpuSetup {
                instance: gpu.instance.clone(),
                adapter: gpu.adapter.clone(),
                device: gpu.device.clone(),
                queue: gpu.queue.clone(),
                backend: wgpu::Backend::Vulkan,
            };
            let device = Device::wgpu_options()
                .setup(setup)
                .init()
                .map_err(|e| format!("burn could not use the Vulkan device: {e}"))?;
            // The rollout's forward passes run as kernels of their own on the same device.
            orbit_rl::share_wgpu_device(gpu.device.clone(), gpu.queue.clone());
            tracing::info!(adapter = %gpu.info.name, "learner on the physics' Vulkan device");
            Ok(device)
        })
        .clone()
        .map_err(RlError::Device)
}

#[cfg(not(feature = "gpu-learner"))]
fn gpu_device() -> Result<Device, RlError> {
    Err(RlError::Device(
        "this build has no burn GPU learner: build with `--features gpu-learner` (adds burn's \
         wgpu backend), or set `gpu_update: Fused` or `device: Cpu` in the agent config"
            .into(),
    ))
}
