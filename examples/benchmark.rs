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
//! are all exercised every step; the substeps of an env step are one `step_n` call. The physics
//! column reads the state only after the last step (a GPU backend then pipelines the steps and
//! reads nothing back in between); the next column reads the joint positions after every step,
//! as an env does, which on the GPU waits for each step and copies the state back. The kernel
//! columns come from GPU timestamps around the step kernel. The full-env column steps the
//! registered task with the same kind of actions and times only its `env.step` calls (not the
//! drawing of the actions); its `managers / physics` ratio and the per-phase table come from
//! the env's own step timings. `--actions gaussian` and
//! `--staggered` make that column's load training's: random actions as an untrained policy
//! takes, and episodes that end at different steps, so that some envs reset every step.

use std::time::Instant;

use clap::Parser;
use orbit::core::physics::{SimCfg, build_backend};
use orbit::core::rng::EnvRng;
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
    /// Worker threads of every parallel loop: the physics', the managers', the host copies'
    /// (0 = one per core).
    #[arg(long, default_value_t = 0)]
    threads: usize,
    /// Physics substeps per env step.
    #[arg(long, default_value_t = 10)]
    decimation: usize,
    /// Velocity-solver iterations per physics step (0: the backend's default).
    #[arg(long, default_value_t = 0)]
    solver_iterations: usize,
    /// Task used for the full-env column (default: BoxPushing-Torque-Franka-v0).
    #[arg(long)]
    task: Option<String>,
    /// Env config file of the full-env column, used instead of the task's.
    #[arg(long)]
    task_config: Option<std::path::PathBuf>,
    /// Scene config overrides `key.path=value`.
    #[arg(long = "set")]
    overrides: Vec<String>,
    /// Overrides of the full env's task config `key.path=value` (e.g. an extra observation
    /// term), with or without `train`'s `env.` prefix.
    #[arg(long = "env-set")]
    env_overrides: Vec<String>,
    /// Actions of the full-env column: small sines (the arm stays near its start and the rod
    /// in the box), or standard-normal noise per env and joint, as an untrained policy with
    /// initial noise std 1.0 acts (the arm sweeps the table: more contacts per env).
    #[arg(long, value_enum, default_value = "sine")]
    actions: EnvActions,
    /// Stagger the full env's episodes (env `e` starts at step `e mod max_episode_length`;
    /// training draws the start steps at random), so that some envs reset every step instead
    /// of all at once.
    #[arg(long)]
    staggered: bool,
}

/// How the full-env column chooses its actions.
#[derive(Clone, Copy, clap::ValueEnum)]
enum EnvActions {
    /// `0.03·sin(πt + j)` for joint `j`, the same in every env.
    Sine,
    /// Independent standard-normal actions per env, joint and step (seeded, deterministic).
    Gaussian,
}

/// The full env's figures for one env count.
struct FullEnv {
    /// Seconds spent in `env.step` over `args.steps` steps (choosing the actions not counted).
    secs: f64,
    /// The env's own per-phase timings of those steps.
    timings: StepTimings,
    /// The step kernel's mean GPU time per env step, from a second pass of as many steps that
    /// reads the GPU timestamps after each (None on a backend without them). The timestamps
    /// cover an env step's last dispatch: the whole step when the env runs its substeps as one
    /// (actions fixed within a step, as box pushing's are), else only the last substep.
    kernel: Option<std::time::Duration>,
}

/// Steps the full manager-based env (`--task`) with the actions `--actions` chooses: 20
/// warm-up steps, `args.steps` timed ones, then as many reading the kernel's GPU time.
fn full_env(args: &Args, n: usize) -> Result<FullEnv, Box<dyn std::error::Error>> {
    let mut overrides = orbit::run_overrides(Some(n), None, Some(&args.backend), &[]);
    overrides.push(format!("sim.num_threads={}", args.threads));
    overrides.push(format!("sim.solver_iterations={}", args.solver_iterations));
    overrides.push(format!("decimation={}", args.decimation));
    overrides.extend(args.env_overrides.iter().map(|o| orbit::env_override(o)));
    orbit::link_registrations();
    let (mut env, _) = orbit::make_env(
        args.task.as_deref(),
        args.task_config.as_deref(),
        &overrides,
    )?;
    env.reset()?;
    if args.staggered {
        let max = env.max_episode_length();
        env.set_episode_length(&(0..n as u32).map(|e| e % max).collect::<Vec<_>>())?;
    }
    let d = env.action_dim();
    let mut action = vec![0.0f32; n * d];
    let mut rngs: Vec<EnvRng> = (0..n as u32).map(|e| EnvRng::new(7, e, 0)).collect();
    let mut run = |env: &mut orbit::managers::ManagerBasedRlEnv,
                   steps: usize,
                   t0: usize,
                   kernel: &mut Option<std::time::Duration>|
     -> Result<std::time::Duration, Box<dyn std::error::Error>> {
        // Only `env.step` is timed: drawing 65 536 × 7 actions on one thread takes milliseconds.
        let mut stepping = std::time::Duration::ZERO;
        for k in t0..t0 + steps {
            let t = k as f32 * 0.02;
            match args.actions {
                EnvActions::Sine => {
                    for (i, a) in action.iter_mut().enumerate() {
                        *a = 0.03 * (2.0 * std::f32::consts::PI * 0.5 * t + (i % d) as f32).sin();
                    }
                }
                EnvActions::Gaussian => {
                    for (row, rng) in action.chunks_exact_mut(d).zip(&mut rngs) {
                        row.iter_mut().for_each(|a| *a = rng.normal());
                    }
                }
            }
            let start = Instant::now();
            env.step(&action)?;
            stepping += start.elapsed();
            if let Some(k) = kernel
                && let Some(t) = env.scene().backend.last_kernel_time()
            {
                *k += t;
            }
        }
        Ok(stepping)
    };
    run(&mut env, 20, 0, &mut None)?;
    env.timings_mut().clear();
    let secs = run(&mut env, args.steps, 20, &mut None)?.as_secs_f64();
    let timings = *env.timings();
    let mut kernel = Some(std::time::Duration::ZERO);
    run(&mut env, args.steps, 20 + args.steps, &mut kernel)?;
    let kernel = kernel
        .filter(|k| !k.is_zero())
        .map(|k| k / args.steps as u32);
    Ok(FullEnv {
        secs,
        timings,
        kernel,
    })
}

// Errors are printed as their messages, not as debug structs.
fn main() -> std::process::ExitCode {
    orbit::init_logging();
    orbit::exit_code(run())
}

fn run() -> Result<(), Box<dyn std::error::Error>> {
    let args = Args::parse();
    if args.threads > 0 {
        // The managers and the host copies run on rayon's global pool; `sim.num_threads` sizes
        // only the rapier backend's own.
        rayon::ThreadPoolBuilder::new()
            .num_threads(args.threads)
            .build_global()?;
    }
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
        "|  envs | physics env-steps/s | + reading every step | per thread | kernel ms / step | kernel env-steps/s | full env env-steps/s | managers / physics | memory per env |"
    );
    println!(
        "|------:|--------------------:|---------------------:|-----------:|-----------------:|-------------------:|---------------------:|-------------------:|---------------:|"
    );
    let mut phases = Vec::new();
    for &n in &args.num_envs {
        let mut backend = build_backend(&scene, n, &sim)?;
        let dofs = backend.layout().articulations[0].num_dofs();
        // Fancy Gym's law with the backend adding the bias forces every substep.
        backend.set_bias_compensation(0, &(0..dofs).collect::<Vec<_>>(), true)?;
        let mut efforts = vec![0.0f32; n * dofs];
        // One pass of `steps` env steps from step index `t0`. `read` looks at the state after
        // every step (the GPU backend then waits for the step and reads it back) and sums the
        // kernel times the backend reports; otherwise only the last step is read, so the
        // measured time covers every step's completion.
        let mut run =
            |backend: &mut Box<dyn orbit::core::physics::PhysicsBackend>,
             steps: usize,
             t0: usize,
             read: bool|
             -> Result<(f64, Option<std::time::Duration>), Box<dyn std::error::Error>> {
                let start = Instant::now();
                let mut kernel: Option<std::time::Duration> = None;
                let mut checksum = 0.0f32;
                for k in t0..t0 + steps {
                    let t = k as f32 * 0.02;
                    // The same action in every env: one sine per joint.
                    let per_joint: Vec<f32> = (0..dofs)
                        .map(|j| 3.0 * (2.0 * std::f32::consts::PI * 0.5 * t + j as f32).sin())
                        .collect();
                    for row in efforts.chunks_exact_mut(dofs) {
                        row.copy_from_slice(&per_joint);
                    }
                    backend.set_joint_efforts(0, &efforts)?;
                    backend.step_n(args.decimation)?;
                    if read || k + 1 == t0 + steps {
                        checksum += backend.articulation(0).joint_pos[0];
                    }
                    if read && let Some(t) = backend.last_kernel_time() {
                        kernel = Some(kernel.unwrap_or_default() + t);
                    }
                }
                if !checksum.is_finite() {
                    return Err("the simulation diverged".into());
                }
                Ok((start.elapsed().as_secs_f64(), kernel))
            };
        // Warm up for at least 20 steps and one second, so that a GPU has left its idle
        // clocks before anything is measured.
        let warm_up = Instant::now();
        let mut t0 = 0;
        while t0 < 20 || warm_up.elapsed().as_secs_f64() < 1.0 {
            run(&mut backend, 10, t0, false)?;
            t0 += 10;
        }
        let (secs, _) = run(&mut backend, args.steps, t0, false)?;
        let rate = (n * args.steps) as f64 / secs;
        let (read_secs, kernel) = run(&mut backend, args.steps, t0 + args.steps, true)?;
        let read_rate = (n * args.steps) as f64 / read_secs;
        let memory = backend.device_memory_bytes() as f64 / n as f64;
        drop(backend);
        let FullEnv {
            secs: env_secs,
            timings,
            kernel: env_kernel,
        } = full_env(&args, n)?;
        let env_rate = (n * args.steps) as f64 / env_secs;
        let overhead = timings.managers().as_secs_f64() / timings.physics.as_secs_f64();
        let kernel_ms = kernel.map_or("—".to_string(), |k| {
            format!("{:.3}", k.as_secs_f64() * 1e3 / args.steps as f64)
        });
        let kernel_rate = kernel.map_or("—".to_string(), |k| {
            format!("{:.0}", (n * args.steps) as f64 / k.as_secs_f64())
        });
        println!(
            "| {n:>5} | {rate:>19.0} | {read_rate:>22.0} | {:>10.0} | {kernel_ms:>16} | {kernel_rate:>18} | {env_rate:>20.0} | {:>16.1} % | {:>12.0} B |",
            rate / threads as f64,
            overhead * 100.0,
            memory
        );
        phases.push((n, timings, env_kernel));
    }
    // Where a full env step's time goes, measured inside the env (same runs as above).
    println!();
    let names: Vec<&str> = StepTimings::default()
        .phases()
        .iter()
        .map(|p| p.0)
        .collect();
    println!("µs per env step by phase (full env; the kernel's GPU time is part of the physics):");
    println!("| envs | {} | kernel |", names.join(" | "));
    println!("|-----:|{}", "-----:|".repeat(names.len() + 1));
    for (n, t, kernel) in phases {
        let cells: Vec<String> = t
            .phases()
            .iter()
            .map(|(_, d)| format!("{:.1}", d.as_secs_f64() * 1e6 / t.steps as f64))
            .collect();
        let kernel = kernel.map_or("—".into(), |k| format!("{:.1}", k.as_secs_f64() * 1e6));
        println!("| {n:>4} | {} | {kernel} |", cells.join(" | "));
    }
    Ok(())
}
