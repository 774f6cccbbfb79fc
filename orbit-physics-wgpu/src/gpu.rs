//! The GPU: one Vulkan device shared by every backend of the process (wgpu with
//! `Backends::VULKAN` only, so a missing driver is reported instead of silently falling back to
//! a GL adapter).

use std::cell::RefCell;
use std::collections::HashMap;
use std::sync::{Arc, Mutex, OnceLock};

use orbit_core::physics::{BackendProbe, DeviceKind};

/// A wgpu device and its queue, with the instance and adapter they came from (so another wgpu
/// user, such as burn's learner, can share the device).
pub struct Gpu {
    /// The instance.
    pub instance: wgpu::Instance,
    /// The adapter (the physical device).
    pub adapter: wgpu::Adapter,
    /// The device.
    pub device: wgpu::Device,
    /// Its queue.
    pub queue: wgpu::Queue,
    /// What the adapter is (name, driver, device type).
    pub info: wgpu::AdapterInfo,
    /// The device's limits (the adapter's, all requested).
    pub limits: wgpu::Limits,
    /// Compiled kernels by WGSL source and checks: backends of the same scene share one
    /// (compiling is slow, seconds on a CPU Vulkan driver).
    pipelines: Mutex<HashMap<(KernelChecks, String), wgpu::ComputePipeline>>,
}

/// The run-time checks wgpu adds to a kernel's code.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub(crate) enum KernelChecks {
    /// All of wgpu's checks (the default for WGSL it has not seen before).
    Checked,
    /// Without the clamps of run-time array indices and without the counters wgpu puts on
    /// every loop; buffer accesses stay bounds-checked by the device's robust buffer access,
    /// and integer divisions keep their guards. Only for kernels whose private arrays are
    /// indexed below their lengths and whose loops end, by construction.
    Trusted,
}

impl Gpu {
    /// The compute pipeline of a WGSL source with entry point `main` and the given run-time
    /// checks, compiled once; an error says what the driver reported (a kernel it cannot
    /// compile, memory it cannot give).
    pub(crate) fn pipeline(
        &self,
        source: &str,
        checks: KernelChecks,
    ) -> Result<wgpu::ComputePipeline, String> {
        let mut cache = self.pipelines.lock().expect("pipeline cache lock");
        let key = (checks, source.to_string());
        if let Some(p) = cache.get(&key) {
            return Ok(p.clone());
        }
        let scopes = [
            wgpu::ErrorFilter::Validation,
            wgpu::ErrorFilter::OutOfMemory,
            wgpu::ErrorFilter::Internal,
        ]
        .map(|filter| self.device.push_error_scope(filter));
        let start = std::time::Instant::now();
        let mut runtime_checks = wgpu::ShaderRuntimeChecks::checked();
        if checks == KernelChecks::Trusted {
            runtime_checks.bounds_checks = false;
            runtime_checks.force_loop_bounding = false;
        }
        let descriptor = wgpu::ShaderModuleDescriptor {
            label: Some("orbit step"),
            source: wgpu::ShaderSource::Wgsl(source.into()),
        };
        // SAFETY: `Trusted` is asked for only by kernels that meet its conditions (see
        // `KernelChecks`); `Checked` keeps every check.
        let module = unsafe {
            self.device
                .create_shader_module_trusted(descriptor, runtime_checks)
        };
        let pipeline = self
            .device
            .create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some("orbit step"),
                layout: None,
                module: &module,
                entry_point: Some("main"),
                compilation_options: Default::default(),
                cache: None,
            });
        // Scopes pop innermost first.
        for scope in scopes.into_iter().rev() {
            if let Some(e) = pollster::block_on(scope.pop()) {
                return Err(format!("the GPU driver could not build the kernel: {e}"));
            }
        }
        tracing::info!(
            seconds = start.elapsed().as_secs_f64(),
            lines = source.lines().count(),
            "compiled a physics kernel"
        );
        cache.insert(key, pipeline.clone());
        Ok(pipeline)
    }
}

static GPU: OnceLock<Result<Arc<Gpu>, String>> = OnceLock::new();

/// The GPU adapter chosen by [`select_gpu`].
static GPU_INDEX: OnceLock<usize> = OnceLock::new();

/// Makes the process's GPU the `index`-th GPU adapter in Vulkan's order (data-parallel
/// training puts each rank of a host on its own GPU). Without a GPU adapter every process uses
/// the CPU driver. Call it before the GPU is first used.
pub fn select_gpu(index: usize) -> Result<(), String> {
    if GPU.get().is_some() {
        return Err("the GPU is chosen before its first use".into());
    }
    GPU_INDEX
        .set(index)
        .map_err(|_| "the GPU can be chosen once per process".to_string())
}

thread_local! {
    /// The calling thread's own device, if it opened one ([`open_device_for_this_thread`]).
    static THREAD_GPU: RefCell<Option<Arc<Gpu>>> = const { RefCell::new(None) };
}

/// The GPU of the calling thread: its own device if it opened one, else the process's,
/// created on first use; an error says why none is available.
pub fn gpu() -> Result<Arc<Gpu>, String> {
    if let Some(own) = THREAD_GPU.with(|g| g.borrow().clone()) {
        return Ok(own);
    }
    GPU.get_or_init(|| pollster::block_on(create()).map(Arc::new))
        .clone()
}

/// Opens a device of the calling thread's own, on the adapter the process's would use: the
/// backends (and a GPU learner) created on this thread afterwards run on it, until the returned
/// guard is dropped. Data-parallel ranks that are threads of one process each open one, since a
/// device runs one dispatch at a time, and a CPU driver (lavapipe) spreads a dispatch over its
/// threads by workgroups: a rank's few envs would leave most cores idle while the other ranks'
/// dispatches wait.
pub fn open_device_for_this_thread() -> Result<ThreadDevice, String> {
    let own = pollster::block_on(create()).map(Arc::new)?;
    THREAD_GPU.with(|g| *g.borrow_mut() = Some(own));
    Ok(ThreadDevice(()))
}

/// The calling thread's own device while it lives (see [`open_device_for_this_thread`]).
/// Dropping it lets go of the thread's reference in ordinary code: a device left to the
/// thread's exit would be destroyed in a thread-local destructor, where wgpu cannot run.
/// Backends made on the thread keep the device until they are dropped.
pub struct ThreadDevice(());

impl Drop for ThreadDevice {
    fn drop(&mut self) {
        let own = THREAD_GPU.with(|g| g.borrow_mut().take());
        drop(own);
    }
}

async fn create() -> Result<Gpu, String> {
    let mut desc = wgpu::InstanceDescriptor::new_without_display_handle();
    desc.backends = wgpu::Backends::VULKAN;
    let instance = wgpu::Instance::new(desc);
    if let Some(&index) = GPU_INDEX.get() {
        let gpus: Vec<wgpu::Adapter> = (instance.enumerate_adapters(wgpu::Backends::VULKAN).await)
            .into_iter()
            .filter(|a| a.get_info().device_type != wgpu::DeviceType::Cpu)
            .collect();
        if !gpus.is_empty() {
            let count = gpus.len();
            let adapter = gpus.into_iter().nth(index).ok_or_else(|| {
                format!(
                    "GPU {index} was asked for, and this host has {count} GPU adapters: start at \
                     most {count} ranks per host"
                )
            })?;
            return open(instance, adapter).await;
        }
    }
    let adapter = instance
        .request_adapter(&wgpu::RequestAdapterOptions {
            power_preference: wgpu::PowerPreference::HighPerformance,
            force_fallback_adapter: false,
            compatible_surface: None,
            apply_limit_buckets: false,
        })
        .await
        .map_err(|e| {
            format!(
                "no Vulkan adapter ({e}); install a Vulkan driver: Mesa's lavapipe runs the GPU \
                 kernel on the CPU (Debian/Ubuntu: `apt-get install mesa-vulkan-drivers \
                 libvulkan1`), a GPU needs its vendor's driver and `libvulkan1`"
            )
        })?;
    open(instance, adapter).await
}

/// A device on `adapter` with every stable feature and limit it has.
async fn open(instance: wgpu::Instance, adapter: wgpu::Adapter) -> Result<Gpu, String> {
    let info = adapter.get_info();
    let limits = adapter.limits();
    let (device, queue) = adapter
        .request_device(&wgpu::DeviceDescriptor {
            label: Some("orbit-physics-wgpu"),
            // Every stable feature the adapter has, so burn's learner can share the device and
            // pick its WGSL kernels by what the adapter reports (as cubecl asks for). Left out:
            // mappable primary buffers (they slow ordinary buffers on discrete GPUs) and
            // wgpu's experimental features (they need an unsafe opt-in, and WGSL kernels do
            // not use them).
            required_features: adapter.features().difference(
                wgpu::Features::MAPPABLE_PRIMARY_BUFFERS | wgpu::Features::all_experimental_mask(),
            ),
            required_limits: limits.clone(),
            experimental_features: wgpu::ExperimentalFeatures::disabled(),
            memory_hints: wgpu::MemoryHints::Performance,
            trace: wgpu::Trace::Off,
        })
        .await
        .map_err(|e| format!("the Vulkan adapter `{}` refused a device: {e}", info.name))?;
    tracing::info!(adapter = %info.name, driver = %info.driver, "wgpu physics device");
    // A lost device turns every later call into an error about invalid objects: say why first.
    device.set_device_lost_callback(|reason, message| {
        if reason != wgpu::DeviceLostReason::Destroyed {
            eprintln!("the GPU device was lost ({reason:?}): {message}");
        }
    });
    Ok(Gpu {
        instance,
        adapter,
        device,
        queue,
        info,
        limits,
        pipelines: Mutex::new(HashMap::new()),
    })
}

/// What this backend runs on here: the Vulkan adapter's kind and name, or why there is none
/// and how to install Mesa's lavapipe (a CPU driver, several times rapier's speed on a CPU).
pub fn probe() -> BackendProbe {
    match gpu() {
        Ok(gpu) => {
            let cpu = gpu.info.device_type == wgpu::DeviceType::Cpu;
            BackendProbe {
                kind: if cpu {
                    DeviceKind::CpuVulkan
                } else {
                    DeviceKind::Gpu
                },
                detail: format!(
                    "wgpu on the Vulkan adapter `{}`{}",
                    gpu.info.name,
                    if cpu {
                        " (a CPU driver; no GPU adapter)"
                    } else {
                        ""
                    }
                ),
            }
        }
        Err(e) => BackendProbe {
            kind: DeviceKind::Unavailable,
            detail: e,
        },
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
