//! Physics throughput on the box-pushing scene: env-steps per second (one env step = 10
//! substeps of 2 ms, Fancy Gym's control period) for a list of env counts, printed as a table.
//!
//! ```text
//! cargo run --release --example benchmark -- --num-envs 1,16,64,256
//! ```
//!
//! The arm runs Fancy Gym's torque law with a sinusoidal normalised action per joint
//! (`τ = clip(10 a + bias, ±τ_max)`, the backend adding the bias forces and clamping at the
//! effort limits every substep), so the multibody, the box–table contacts and the bias forces
//! are all exercised every step; the substeps of an env step are one `step_n` call. The full-env column steps the registered task with
//! the same kind of actions; its `managers / physics` ratio and the per-phase table come from the
//! env's own step timings.

use std::time::Instant;

use clap::Parser;
use orbit::core::physics::{SimCfg, build_backend};
use orbit::managers::StepTimings;

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
    /// Task used for the full-env column.
    #[arg(long, default_value = "BoxPushing-Torque-Franka-v0")]
    task: String,
    /// Scene config overrides `key.path=value`.
    #[arg(long = "set")]
    overrides: Vec<String>,
}

/// Seconds for `args.steps` steps of the full manager-based env (`--task`) with the same
/// sinusoidal actions (after 20 warm-up steps), and the env's own per-phase timings of them.
fn full_env_seconds(
    args: &Args,
    n: usize,
) -> Result<(f64, StepTimings), Box<dyn std::error::Error>> {
    let mut overrides = orbit::run_overrides(Some(n), None, Some(&args.backend), &[]);
    overrides.push(format!("sim.num_threads={}", args.threads));
    overrides.push(format!("sim.solver_iterations={}", args.solver_iterations));
    overrides.push(format!("decimation={}", args.decimation));
    let mut env = orbit::make(&args.task, &overrides)?;
    env.reset()?;
    let d = env.action_dim();
    let mut action = vec![0.0f32; n * d];
    let mut run = |env: &mut orbit::managers::ManagerBasedRlEnv,
                   steps: usize,
                   t0: usize|
     -> Result<(), Box<dyn std::error::Error>> {
        for k in t0..t0 + steps {
            let t = k as f32 * 0.02;
            for (i, a) in action.iter_mut().enumerate() {
                *a = 0.03 * (2.0 * std::f32::consts::PI * 0.5 * t + (i % d) as f32).sin();
            }
            env.step(&action)?;
        }
        Ok(())
    };
    run(&mut env, 20, 0)?;
    env.timings_mut().clear();
    let start = Instant::now();
    run(&mut env, args.steps, 20)?;
    Ok((start.elapsed().as_secs_f64(), *env.timings()))
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
    println!(
        "| envs | physics env-steps/s | per thread | full env env-steps/s | managers / physics |"
    );
    println!(
        "|-----:|--------------------:|-----------:|---------------------:|-------------------:|"
    );
    let mut phases = Vec::new();
    for &n in &args.num_envs {
        let mut backend = build_backend(&scene, n, &sim)?;
        let dofs = backend.layout().articulations[0].num_dofs();
        // Fancy Gym's law with the backend adding the bias forces every substep.
        backend.set_bias_compensation(0, &(0..dofs).collect::<Vec<_>>(), true)?;
        let mut efforts = vec![0.0f32; n * dofs];
        let mut run = |backend: &mut Box<dyn orbit::core::physics::PhysicsBackend>,
                       steps: usize,
                       t0: usize|
         -> Result<(), Box<dyn std::error::Error>> {
            for k in t0..t0 + steps {
                let t = k as f32 * 0.02;
                for (i, tau) in efforts.iter_mut().enumerate() {
                    let a = 0.3 * (2.0 * std::f32::consts::PI * 0.5 * t + (i % dofs) as f32).sin();
                    *tau = 10.0 * a;
                }
                backend.set_joint_efforts(0, &efforts)?;
                backend.step_n(args.decimation)?;
            }
            Ok(())
        };
        run(&mut backend, 20, 0)?;
        let start = Instant::now();
        run(&mut backend, args.steps, 20)?;
        let secs = start.elapsed().as_secs_f64();
        let rate = (n * args.steps) as f64 / secs;
        let memory = backend.device_memory_bytes() as f64 / n as f64;
        drop(backend);
        let (env_secs, timings) = full_env_seconds(&args, n)?;
        let env_rate = (n * args.steps) as f64 / env_secs;
        let overhead = timings.managers().as_secs_f64() / timings.physics.as_secs_f64();
        println!(
            "| {n:>4} | {rate:>19.0} | {:>10.0} | {env_rate:>20.0} | {:>16.1} % | {:>19.0} B |",
            rate / threads as f64,
            overhead * 100.0,
            memory
        );
        phases.push((n, timings));
    }
    // Where a full env step's time goes, measured inside the env (same runs as above).
    println!();
    let names: Vec<&str> = StepTimings::default()
        .phases()
        .iter()
        .map(|p| p.0)
        .collect();
    println!("µs per env step by phase (full env):");
    println!("| envs | {} |", names.join(" | "));
    println!("|-----:|{}", "-----:|".repeat(names.len()));
    for (n, t) in phases {
        let cells: Vec<String> = t
            .phases()
            .iter()
            .map(|(_, d)| format!("{:.1}", d.as_secs_f64() * 1e6 / t.steps as f64))
            .collect();
        println!("| {n:>4} | {} |", cells.join(" | "));
    }
    Ok(())
}
