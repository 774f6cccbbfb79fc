//! The contact solver's sweeps with one thread per env against four, on Ant-shaped rows.
//!
//! ```text
//! cargo run --release -p orbit-physics-wgpu --example lane_sweeps -- --num-envs 4096,65536
//! ```
//!
//! A stand-alone measurement, not the physics backend: each env holds the rows of an Ant on
//! the ground (four legs of two dofs on a floating root of six; per leg a foot contact of
//! three rows with probability 0.9, one joint-limit row, a second with probability 0.1), drawn
//! from a hash of the env and the substep. The velocities live in coordinates where the mass
//! matrix is block-diagonal (the root's Schur complement and each leg's block), so that
//! `W = A⁻¹ Jᵀ` is exact for every row. Each substep builds the rows and runs the sweeps of
//! the backend's projected Gauss–Seidel (relaxation 1.5, friction disk).
//!
//! - `one-thread`: one thread per env, as the generated Ant kernel: the rows in private arrays
//!   indexed at run time (so in local memory), each 2 Jacobian entries and 14 of `W`.
//! - `four-threads-workgroup` and `four-threads-quad`: one thread per leg. A thread keeps its
//!   leg's rows in registers, as the root's 6 and its own 2 entries of `W`; the legs take turns
//!   through the rows, and after each turn the others take the root's velocity from the owner
//!   (through workgroup memory, or by a quad broadcast where the device has subgroup
//!   operations) and move their own dofs by `C_k Δq̇_root`, `C_k = −A_kk⁻¹ A_k,root`.
//!
//! The one-thread kernel, visiting the rows leg by leg, must agree with the four-thread ones
//! to rounding; the table gives milliseconds per substep with 1 and 12 sweeps, from the wall
//! clock over `--reps` dispatches of `--substeps` substeps each.

use std::time::Instant;

use clap::Parser;
use wgpu::util::DeviceExt;

const COMMON: &str = include_str!("lane_sweeps/common.wgsl");
const ONE_THREAD: &str = include_str!("lane_sweeps/one_thread.wgsl");
const FOUR_THREADS: &str = include_str!("lane_sweeps/four_threads.wgsl");
const EXCHANGE_WORKGROUP: &str = include_str!("lane_sweeps/exchange_workgroup.wgsl");
const EXCHANGE_QUAD: &str = include_str!("lane_sweeps/exchange_quad.wgsl");

#[derive(Parser)]
#[command(about = "Contact-solver sweeps with one thread per env against four")]
struct Args {
    /// Comma-separated env counts.
    #[arg(long, value_delimiter = ',', default_value = "4096,65536")]
    num_envs: Vec<u32>,
    /// Substeps per dispatch.
    #[arg(long, default_value_t = 10)]
    substeps: u32,
    /// Timed dispatches per figure.
    #[arg(long, default_value_t = 20)]
    reps: u32,
}

struct Gpu {
    device: wgpu::Device,
    queue: wgpu::Queue,
}

fn gpu() -> Gpu {
    let mut desc = wgpu::InstanceDescriptor::new_without_display_handle();
    desc.backends = wgpu::Backends::VULKAN;
    let instance = wgpu::Instance::new(desc);
    let adapter = pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
        power_preference: wgpu::PowerPreference::HighPerformance,
        ..Default::default()
    }))
    .expect("no Vulkan adapter");
    println!("adapter: {}", adapter.get_info().name);
    let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
        required_limits: adapter.limits(),
        required_features: adapter.features() & wgpu::Features::SUBGROUP,
        ..Default::default()
    }))
    .expect("no device");
    Gpu { device, queue }
}

/// A kernel and its threads per env.
struct Kernel {
    name: &'static str,
    pipeline: wgpu::ComputePipeline,
    threads: u32,
}

fn kernel(g: &Gpu, name: &'static str, parts: &[&str], threads: u32) -> Kernel {
    let source = std::iter::once(COMMON)
        .chain(parts.iter().copied())
        .collect::<Vec<_>>()
        .join("\n");
    // Without index clamps, as the backend builds its step kernel.
    // SAFETY: every index in these kernels is in bounds: rows < 50, slots < 192, and the output
    // index < 14 × envs.
    let module = unsafe {
        g.device.create_shader_module_trusted(
            wgpu::ShaderModuleDescriptor {
                label: Some(name),
                source: wgpu::ShaderSource::Wgsl(source.into()),
            },
            wgpu::ShaderRuntimeChecks::unchecked(),
        )
    };
    let pipeline = g
        .device
        .create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some(name),
            layout: None,
            module: &module,
            entry_point: Some("main"),
            compilation_options: Default::default(),
            cache: None,
        });
    Kernel {
        name,
        pipeline,
        threads,
    }
}

/// Runs `reps` dispatches after two untimed ones; seconds per dispatch and the final q̇
/// (14 per env, envs fastest).
fn run(g: &Gpu, k: &Kernel, envs: u32, substeps: u32, sweeps: u32, reps: u32) -> (f64, Vec<f32>) {
    let params = g
        .device
        .create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: None,
            contents: bytemuck::cast_slice(&[envs, substeps, sweeps, 0u32]),
            usage: wgpu::BufferUsages::UNIFORM,
        });
    let size = 14 * u64::from(envs) * 4;
    let buffer = |usage| {
        g.device.create_buffer(&wgpu::BufferDescriptor {
            label: None,
            size,
            usage,
            mapped_at_creation: false,
        })
    };
    let out = buffer(wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC);
    let read = buffer(wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST);
    let bind = g.device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: None,
        layout: &k.pipeline.get_bind_group_layout(0),
        entries: &[
            wgpu::BindGroupEntry {
                binding: 0,
                resource: params.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 1,
                resource: out.as_entire_binding(),
            },
        ],
    });
    let groups = (envs * k.threads).div_ceil(32);
    let dispatch = |n: u32| {
        let mut enc = g.device.create_command_encoder(&Default::default());
        for _ in 0..n {
            let mut pass = enc.begin_compute_pass(&Default::default());
            pass.set_pipeline(&k.pipeline);
            pass.set_bind_group(0, &bind, &[]);
            pass.dispatch_workgroups(groups, 1, 1);
        }
        g.queue.submit([enc.finish()]);
        g.device
            .poll(wgpu::PollType::wait_indefinitely())
            .expect("device lost");
    };
    dispatch(2);
    let t = Instant::now();
    dispatch(reps);
    let secs = t.elapsed().as_secs_f64() / f64::from(reps);
    let mut enc = g.device.create_command_encoder(&Default::default());
    enc.copy_buffer_to_buffer(&out, 0, &read, 0, size);
    g.queue.submit([enc.finish()]);
    read.slice(..).map_async(wgpu::MapMode::Read, |_| {});
    g.device
        .poll(wgpu::PollType::wait_indefinitely())
        .expect("device lost");
    let view = read.slice(..).get_mapped_range().expect("mapped");
    (secs, bytemuck::cast_slice::<u8, f32>(&view).to_vec())
}

fn max_diff(a: &[f32], b: &[f32]) -> f32 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f32::max)
}

fn main() {
    let args = Args::parse();
    let g = gpu();
    let one = kernel(&g, "one-thread", &[ONE_THREAD], 1);
    let by_leg = ONE_THREAD.replace("const LEG_ORDER = false;", "const LEG_ORDER = true;");
    let one_by_leg = kernel(&g, "one-thread, rows by leg", &[&by_leg], 1);
    let mut kernels = vec![
        one,
        kernel(
            &g,
            "four-threads-workgroup",
            &[FOUR_THREADS, EXCHANGE_WORKGROUP],
            4,
        ),
    ];
    if g.device.features().contains(wgpu::Features::SUBGROUP) {
        kernels.push(kernel(
            &g,
            "four-threads-quad",
            &[FOUR_THREADS, EXCHANGE_QUAD],
            4,
        ));
    }
    // Agreement on 256 envs, 2 substeps: the same sweeps in the same order, so rounding apart.
    for sweeps in [1, 12, 300] {
        let (_, reference) = run(&g, &one_by_leg, 256, 2, sweeps, 1);
        let scale = reference.iter().fold(0.0f32, |m, x| m.max(x.abs()));
        // The kernel's own order (contacts, then limit rows) converges elsewhere.
        let (_, own_order) = run(&g, &kernels[0], 256, 2, sweeps, 1);
        println!(
            "{sweeps:>3} sweeps: one thread, the kernel's order, against by leg: max |Δq̇| {:.2e}",
            max_diff(&own_order, &reference)
        );
        for k in &kernels[1..] {
            let (_, q) = run(&g, k, 256, 2, sweeps, 1);
            println!(
                "{sweeps:>3} sweeps: {} against one thread by leg: max |Δq̇| {:.2e} of {scale:.2}",
                k.name,
                max_diff(&q, &reference)
            );
        }
    }
    println!("| kernel | envs | 1 sweep, ms / substep | 12 sweeps, ms / substep | 11 sweeps, ms |");
    println!("|---|---:|---:|---:|---:|");
    for &envs in &args.num_envs {
        for k in &kernels {
            let (t1, _) = run(&g, k, envs, args.substeps, 1, args.reps);
            let (t12, _) = run(&g, k, envs, args.substeps, 12, args.reps);
            let per = 1e3 / f64::from(args.substeps);
            println!(
                "| {} | {envs} | {:.4} | {:.4} | {:.4} |",
                k.name,
                t1 * per,
                t12 * per,
                (t12 - t1) * per
            );
        }
    }
}
