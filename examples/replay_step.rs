//! Replays a step that broke the physics in a one-env copy of its task. Train with
//! `env.sim.keep_pre_step_state=true` on its command line; when a step fails, the log holds a line
//! `env E before the failing step (…): (step: …, env: …, action: […], state: (…))`. Save that
//! line (or the RON from `(step:` on) in a file and replay it, on any backend:
//!
//! ```text
//! cargo run --release --example replay_step -- --task Isaac-Humanoid-v0 --backend rapier \
//!     --failed failed.ron --steps 3
//! ```
//!
//! The env is written to the logged state and stepped with the logged action (held for
//! `--steps` steps); after each step the example prints the env's state, or the physics
//! failure as training reported it. A written env starts its solver without the warm start
//! of the original run.

use clap::Parser;
use orbit::managers::FailedStep;

#[derive(Parser, Debug)]
struct Args {
    /// Task id of the run that failed.
    #[arg(long)]
    task: Option<String>,
    /// Env config file used instead of the task's.
    #[arg(long)]
    task_config: Option<std::path::PathBuf>,
    /// Physics backend to replay on (default: the config's).
    #[arg(long)]
    backend: Option<String>,
    /// Config overrides `key.path=value` of the failed run (with or without `env.`).
    #[arg(long = "set")]
    overrides: Vec<String>,
    /// A file holding the failed step's log line, or its RON.
    #[arg(long)]
    failed: std::path::PathBuf,
    /// Env steps to run with the logged action.
    #[arg(long, default_value_t = 1)]
    steps: usize,
}

fn main() -> std::process::ExitCode {
    orbit::init_logging();
    orbit::exit_code(run(&Args::parse()))
}

fn run(args: &Args) -> Result<(), Box<dyn std::error::Error>> {
    orbit::link_registrations();
    let text = std::fs::read_to_string(&args.failed)
        .map_err(|e| format!("cannot read {}: {e}", args.failed.display()))?;
    let start = text.find("(step:").ok_or_else(|| {
        format!(
            "{} holds no failed step: expected the log line's RON, `(step: …, env: …, \
             action: […], state: (…))`",
            args.failed.display()
        )
    })?;
    let failed = FailedStep::from_ron(&text[start..])
        .map_err(|e| format!("{}: {e}", args.failed.display()))?;
    let flags = orbit::EnvArgs {
        task_config: args.task_config.clone(),
        num_envs: Some(1),
        seed: None,
        backend: args.backend.clone(),
    };
    let (mut env, name) =
        orbit::agent::make_step_env(args.task.as_deref(), &flags, &args.overrides)?;
    if failed.action.len() != env.action_dim() {
        return Err(format!(
            "the failed step's action has {} values; {} takes {}",
            failed.action.len(),
            name,
            env.action_dim()
        )
        .into());
    }
    failed.state.write(env.scene_mut().backend.as_mut(), 0)?;
    println!(
        "replaying env {} of step {} of {} on {}",
        failed.env,
        failed.step,
        name,
        env.scene().backend.name()
    );
    for step in 1..=args.steps {
        let result = env.step(&failed.action)?;
        if result.terminated[0] || result.time_outs[0] {
            println!("step {step}: the episode ended, and the env was reset");
            return Ok(());
        }
        let backend = env.scene().backend.as_ref();
        println!(
            "step {step}: no physics failure; {}",
            orbit::core::physics::describe_env_state(backend, 0)
        );
    }
    Ok(())
}
