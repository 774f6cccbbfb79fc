//! The learner's burn device: the CPU (flex), or burn's wgpu backend on the Vulkan device the
//! wgpu physics backend uses (one device per process, so physics and learner share a queue and
//! its memory).

use orbit_rl::burn::tensor::Device;
use orbit_rl::{LearnerDevice, RlError};

/// The burn device for `kind`. A GPU device is registered with burn once per process; later
/// calls return the same device.
pub fn learner_device(kind: LearnerDevice) -> Result<Device, RlError> {
    match kind {
        LearnerDevice::Cpu => Ok(Device::flex()),
        LearnerDevice::Gpu => gpu_device(),
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
        "this build has no GPU learner: build with `--features gpu-learner` (adds burn's wgpu \
         backend), or set `device: Cpu` in the agent config"
            .into(),
    ))
}
