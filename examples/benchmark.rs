//! Physics throughput on the box-pushing scene: env-steps per second (one env step = 10
//! substeps of 2 ms, Fancy Gym's control period) for a list of env counts, printed as a table.
//!
//! ```text
//! cargo run --release --example benchmark -- --num-envs 1,16,64,256
//! ```
//!
//! The arm runs Fancy Gym's torque law with a sinusoidal normalised action per joint
//! (`τ = clip(10 a + bias, ±τ_max)`), so the multibody, the box–table contacts and the bias
//! forces are all exercised every step.

use std::time::Instant;

use clap::Parser;
use orbit::core::physics::{SimCfg, build_backend};

#[derive(Parser)]
#[command(about = "Env-steps/s of the box-pushing scene per physics backend")]
struct Args {
    /// Physics backend.
    #[arg(long, default_value = "rapier")]
    backend: String,
    /// Comma-separated env counts.
    #[arg(long, value_delimiter = ',', default_value = "1,16,64,256")]
    num_envs: Vec<usize>,
    /// Measured env steps per env count (after 20 warm-up steps).
    #[arg(long, default_value_t = 200)]
    steps: usize,
    /// Worker threads (0 = one per core).
    #[arg(long, default_value_t = 0)]
    threads: usize,
    /// Physics substeps per env step.
    #[arg(long, default_value_t = 10)]
    decimation: usize,
    /// Velocity-solver iterations per physics step.
    #[arg(long, default_value_t = SimCfg::default().solver_iterations)]
    solver_iterations: usize,
    /// Scene config overrides `key.path=value`.
    #[arg(long = "set")]
    overrides: Vec<String>,
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args = Args::parse();
    let scene = orbit::assets::box_pushing_scene(&args.overrides)?;
    let sim = SimCfg {
        backend: args.backend.clone(),
        num_threads: args.threads,
        solver_iterations: args.solver_iterations,
        ..SimCfg::default()
    };
    let threads = if args.threads == 0 {
        std::thread::available_parallelism().map_or(1, |n| n.get())
    } else {
        args.threads
    };
    println!(
        "backend {} | {} substeps of {} s per env step | {threads} threads",
        args.backend, args.decimation, sim.dt
    );
    println!("| envs | env-steps/s | env-steps/s per thread | µs per env step (batch) |");
    println!("|-----:|------------:|-----------------------:|------------------------:|");
    for &n in &args.num_envs {
        let mut backend = build_backend(&scene, n, &sim)?;
        let dofs = backend.layout().articulations[0].num_dofs();
        let limits = [87.0f32, 87.0, 87.0, 87.0, 12.0, 12.0, 12.0];
        let mut efforts = vec![0.0f32; n * dofs];
        let mut run = |backend: &mut Box<dyn orbit::core::physics::PhysicsBackend>,
                       steps: usize,
                       t0: usize|
         -> Result<(), Box<dyn std::error::Error>> {
            for k in t0..t0 + steps {
                let t = k as f32 * 0.02;
                let bias = backend.articulation(0).bias_forces;
                for (i, tau) in efforts.iter_mut().enumerate() {
                    let d = i % dofs;
                    let a = 0.3 * (2.0 * std::f32::consts::PI * 0.5 * t + d as f32).sin();
                    let lim = limits.get(d).copied().unwrap_or(87.0);
                    *tau = (10.0 * a + bias[i]).clamp(-lim, lim);
                }
                backend.set_joint_efforts(0, &efforts)?;
                for _ in 0..args.decimation {
                    backend.step()?;
                }
            }
            Ok(())
        };
        run(&mut backend, 20, 0)?;
        let start = Instant::now();
        run(&mut backend, args.steps, 20)?;
        let secs = start.elapsed().as_secs_f64();
        let rate = (n * args.steps) as f64 / secs;
        println!(
            "| {n:>4} | {rate:>11.0} | {:>22.0} | {:>23.1} |",
            rate / threads as f64,
            secs / args.steps as f64 * 1e6
        );
    }
    Ok(())
}
