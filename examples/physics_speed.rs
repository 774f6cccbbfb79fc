//! Physics throughput of a scene file: physics steps per second of all envs together, for a
//! list of env counts, printed as a table.
//!
//! ```text
//! cargo run --release --example physics_speed -- --scene orbit-assets/assets/scenes/ant.ron \
//!     --backend wgpu --num-envs 4096,65536
//! ```
//!
//! Every joint of the scene's first articulation takes a sinusoidal effort, its phase different
//! per env and joint (`effort · sin(πt + j + 0.01 e)` for joint `j` of env `e`), so that the
//! envs move apart as an untrained policy's do. Efforts are set once per dispatch of
//! `--substeps` physics steps (`step_n`), and the state is read only after the last step, so
//! the time covers the physics alone: no resets, no observations, no host reads in between.
//! After at least one second of warm-up, `--steps` physics steps are timed; the kernel column
//! (a GPU backend) sums the GPU timestamps of a second pass that reads after every dispatch.

use std::path::PathBuf;
use std::time::{Duration, Instant};

use clap::Parser;
use orbit::core::physics::{PhysicsBackend, SimCfg, build_backend};
use rayon::prelude::*;

#[derive(Parser)]
#[command(about = "Physics steps/s of a scene file per physics backend")]
struct Args {
    /// Scene config file (RON; entities may name registered asset configs).
    #[arg(long)]
    scene: PathBuf,
    /// Physics backend.
    #[arg(long, default_value = "wgpu")]
    backend: String,
    /// Comma-separated env counts.
    #[arg(long, value_delimiter = ',', default_value = "4096")]
    num_envs: Vec<usize>,
    /// Timed physics steps per env count.
    #[arg(long, default_value_t = 1000)]
    steps: usize,
    /// Physics steps per dispatch (`step_n`), between two effort updates.
    #[arg(long, default_value_t = 10)]
    substeps: usize,
    /// Physics step (s).
    #[arg(long, default_value_t = 1.0 / 120.0)]
    dt: f32,
    /// Amplitude of the joint efforts (N·m or N).
    #[arg(long, default_value_t = 1.5)]
    effort: f32,
    /// Worker threads of a CPU backend (0 = one per core).
    #[arg(long, default_value_t = 0)]
    threads: usize,
    /// Velocity-solver iterations per physics step (0: the backend's default).
    #[arg(long, default_value_t = 0)]
    solver_iterations: usize,
    /// Scene config overrides `key.path=value`.
    #[arg(long = "set")]
    overrides: Vec<String>,
}

fn main() -> std::process::ExitCode {
    orbit::exit_code(run())
}

/// Steps `chunks` dispatches of `substeps` physics steps from dispatch index `k0`; with `read`,
/// reads the state after each and sums the kernel times the backend reports.
fn pass(
    backend: &mut dyn PhysicsBackend,
    args: &Args,
    chunks: usize,
    k0: usize,
    read: bool,
) -> Result<(Duration, Option<Duration>), Box<dyn std::error::Error>> {
    let n = backend.num_envs();
    let dofs = backend.layout().articulations[0].num_dofs();
    let mut efforts = vec![0.0f32; n * dofs];
    let start = Instant::now();
    let mut kernel: Option<Duration> = None;
    let mut checksum = 0.0f32;
    for k in k0..k0 + chunks {
        let t = (k * args.substeps) as f32 * args.dt;
        // On every core: 65 536 envs' sines take one core about 3 ms, most of the time the GPU
        // takes for the dispatch they go with.
        efforts
            .par_chunks_exact_mut(dofs)
            .enumerate()
            .for_each(|(e, row)| {
                for (j, x) in row.iter_mut().enumerate() {
                    *x =
                        args.effort * (std::f32::consts::PI * t + j as f32 + 0.01 * e as f32).sin();
                }
            });
        backend.set_joint_efforts(0, &efforts)?;
        backend.step_n(args.substeps)?;
        if read || k + 1 == k0 + chunks {
            checksum += backend.articulation(0).link_pos[0].z;
        }
        if read && let Some(t) = backend.last_kernel_time() {
            kernel = Some(kernel.unwrap_or_default() + t);
        }
    }
    if !checksum.is_finite() {
        return Err(format!(
            "the simulation diverged: lower --effort ({}) or --dt ({})",
            args.effort, args.dt
        )
        .into());
    }
    Ok((start.elapsed(), kernel))
}

fn run() -> Result<(), Box<dyn std::error::Error>> {
    let args = Args::parse();
    let scene = orbit::assets::load_scene(&args.scene, &args.overrides)?;
    if scene.articulations.is_empty() {
        return Err(format!(
            "{}: the scene has no articulation to drive",
            args.scene.display()
        )
        .into());
    }
    let sim = SimCfg {
        backend: args.backend.clone(),
        num_threads: args.threads,
        solver_iterations: args.solver_iterations,
        dt: args.dt,
        ..SimCfg::default()
    };
    let chunks = args.steps.div_ceil(args.substeps);
    let steps = chunks * args.substeps;
    println!(
        "scene {} | backend {} | dt {} s | {} physics steps per dispatch | solver iterations {} (0: the \
         backend's default) | {steps} timed steps",
        args.scene.display(),
        args.backend,
        args.dt,
        args.substeps,
        args.solver_iterations
    );
    println!("|  envs | physics steps/s | kernel ms / step | kernel steps/s | memory per env |");
    println!("|------:|----------------:|-----------------:|---------------:|---------------:|");
    for &n in &args.num_envs {
        let mut backend = build_backend(&scene, n, &sim)?;
        // Warm up for at least two dispatches and one second, so that a GPU has left its
        // idle clocks and compiled its kernel.
        let warm_up = Instant::now();
        let mut k0 = 0;
        while k0 < 2 || warm_up.elapsed().as_secs_f64() < 1.0 {
            pass(&mut *backend, &args, 2, k0, false)?;
            k0 += 2;
        }
        let (elapsed, _) = pass(&mut *backend, &args, chunks, k0, false)?;
        let rate = (n * steps) as f64 / elapsed.as_secs_f64();
        let (_, kernel) = pass(&mut *backend, &args, chunks, k0 + chunks, true)?;
        let kernel_ms = kernel.map_or("—".to_string(), |k| {
            format!("{:.4}", k.as_secs_f64() * 1e3 / steps as f64)
        });
        let kernel_rate = kernel.map_or("—".to_string(), |k| {
            format!("{:.0}", (n * steps) as f64 / k.as_secs_f64())
        });
        let memory = backend.device_memory_bytes() as f64 / n as f64;
        println!(
            "| {n:>5} | {rate:>15.0} | {kernel_ms:>16} | {kernel_rate:>14} | {memory:>12.0} B |"
        );
    }
    Ok(())
}
