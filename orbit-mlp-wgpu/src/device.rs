//! The process's device for [`StackedMlp`](crate::StackedMlp)s: the one the GPU learner runs on,
//! registered by whoever created it, so that networks and learner share one queue and its
//! memory.

use std::sync::OnceLock;

static SHARED: OnceLock<(wgpu::Device, wgpu::Queue)> = OnceLock::new();

/// Registers the device and queue that [`shared_device`] returns. The first registration of a
/// process stands; later ones are ignored (a process has one GPU learner).
pub fn share_device(device: wgpu::Device, queue: wgpu::Queue) {
    let _ = SHARED.set((device, queue));
}

/// The device and queue registered by [`share_device`], if any.
pub fn shared_device() -> Option<(wgpu::Device, wgpu::Queue)> {
    SHARED.get().cloned()
}
