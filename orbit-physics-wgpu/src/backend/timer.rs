//! Kernel timing: two GPU timestamps around the step kernel, on devices that have timestamp
//! queries, read back by [`PhysicsBackend::last_kernel_time`].
//!
//! [`PhysicsBackend::last_kernel_time`]: orbit_core::physics::PhysicsBackend::last_kernel_time

use super::WgpuBackend;
use crate::gpu::Gpu;

/// Two GPU timestamps around the step kernel, resolved into a buffer that each step copies
/// into `timestamps` for `last_kernel_time` to read.
pub(super) struct KernelTimer {
    pub(super) queries: wgpu::QuerySet,
    pub(super) resolved: wgpu::Buffer,
    /// Nanoseconds per timestamp tick.
    pub(super) period_ns: f64,
}

impl KernelTimer {
    /// The timer, on devices with timestamp queries.
    pub(super) fn new(gpu: &Gpu) -> Option<Self> {
        let device = &gpu.device;
        device
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
            })
    }
}

impl WgpuBackend {
    /// The step kernel's time in the last dispatch that ran substeps, on devices with
    /// timestamps.
    pub(super) fn kernel_time(&self) -> Option<std::time::Duration> {
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
}
