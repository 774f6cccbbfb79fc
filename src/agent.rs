//! The loop behind the `random_agent` and `zero_agent` examples (Isaac Lab's scripts of the
//! same names): build a registered task, step it with random or zero actions, report.

use clap::Parser;
use orbit_core::rng::{EnvRng, streams};

/// Isaac Lab's agent-script flags.
#[derive(Parser, Debug)]
pub struct AgentArgs {
    /// Task id (see the `list_tasks` example; default: BoxPushing-Torque-Franka-v0).
    #[arg(long)]
    pub task: Option<String>,
    /// Env config file, envs, seed, backend.
    #[command(flatten)]
    pub env: crate::EnvArgs,
    /// Env steps to run.
    #[arg(long, default_value_t = 200)]
    pub steps: usize,
    /// Config overrides `key.path=value` (or `env.key.path=value`, as `train` takes them).
    #[arg(long = "set")]
    pub overrides: Vec<String>,
    /// Record the rollout into DIR as NumPy files: `actions` `[steps, envs, action]`,
    /// `observations` (group `policy`, the reset's first) `[steps + 1, envs, obs]`, `rewards`,
    /// `terminated` and `time_outs` `[steps, envs]`.
    #[arg(long, value_name = "DIR")]
    pub record: Option<std::path::PathBuf>,
}

/// A rollout kept for `--record`.
#[derive(Default)]
struct Recording {
    actions: Vec<f32>,
    observations: Vec<f32>,
    rewards: Vec<f32>,
    terminated: Vec<bool>,
    time_outs: Vec<bool>,
}

impl Recording {
    /// Appends the policy observations of `env` as they are now.
    fn observe(&mut self, env: &crate::managers::ManagerBasedRlEnv) -> Result<usize, String> {
        let (obs, dim) = env
            .observation("policy")
            .ok_or("the env has no `policy` observation group to record")?;
        self.observations.extend_from_slice(obs);
        Ok(dim)
    }

    /// Writes the files into `dir`.
    fn save(&self, dir: &std::path::Path, n: usize, d: usize, obs: usize) -> std::io::Result<()> {
        use crate::npy::write_npy;
        std::fs::create_dir_all(dir)?;
        let steps = self.rewards.len() / n;
        write_npy(&dir.join("actions.npy"), &[steps, n, d], &self.actions)?;
        let shape = [steps + 1, n, obs];
        write_npy(&dir.join("observations.npy"), &shape, &self.observations)?;
        write_npy(&dir.join("rewards.npy"), &[steps, n], &self.rewards)?;
        write_npy(&dir.join("terminated.npy"), &[steps, n], &self.terminated)?;
        write_npy(&dir.join("time_outs.npy"), &[steps, n], &self.time_outs)
    }
}

/// Builds and resets the step-based env of `task` (default: box pushing), or of the env file
/// `env.task_config`, with `env`'s flags and `overrides` (`key.path=value`, with or without
/// `env.`), on the backend chosen for this machine; returns it with the task's name.
pub fn make_step_env(
    task: Option<&str>,
    env: &crate::EnvArgs,
    overrides: &[String],
) -> Result<(crate::managers::ManagerBasedRlEnv, String), Box<dyn std::error::Error>> {
    let user: Vec<String> = overrides.iter().map(|o| crate::env_override(o)).collect();
    let mut overrides = crate::run_overrides(env.num_envs, env.seed, env.backend.as_deref(), &user);
    let configs = crate::RunConfigs::resolve(
        task,
        crate::envs::DEFAULT_STEP_TASK,
        env.task_config.as_deref(),
        None,
        None,
    )?;
    crate::choose_run_backend(&configs.env, &mut overrides)?;
    let mut made = crate::managers::make_from_file(&configs.env, &overrides)?;
    made.reset()?;
    Ok((made, configs.name))
}

/// Runs the task with uniform random actions in `[-1, 1]` (or zeros) and prints episode logs
/// and throughput.
pub fn run(args: &AgentArgs, zero: bool) -> Result<(), Box<dyn std::error::Error>> {
    crate::link_registrations();
    if args.steps == 0 {
        return Err("`--steps` must be at least 1: there is nothing to report of no steps".into());
    }
    let e = &args.env;
    let (mut env, name) = make_step_env(args.task.as_deref(), e, &args.overrides)?;
    let (n, d) = (env.num_envs(), env.action_dim());
    let mut rng = EnvRng::new(e.seed.unwrap_or(0), 0, streams::POLICY);
    let mut action = vec![0.0f32; n * d];
    let mut recording = args.record.as_ref().map(|_| Recording::default());
    let obs_dim = match &mut recording {
        Some(r) => r.observe(&env)?,
        None => 0,
    };
    let start = std::time::Instant::now();
    let mut mean_reward = 0.0f64;
    for step in 0..args.steps {
        if !zero {
            action
                .iter_mut()
                .for_each(|a| *a = rng.uniform_range(-1.0, 1.0));
        }
        let r = env.step(&action)?;
        mean_reward += r.reward.iter().map(|&x| f64::from(x)).sum::<f64>() / n as f64;
        if r.time_outs.iter().chain(r.terminated).any(|&x| x) {
            println!("step {:>5}: episode end {:?}", step + 1, r.extras.log);
        }
        if let Some(rec) = &mut recording {
            rec.actions.extend_from_slice(&action);
            rec.rewards.extend_from_slice(r.reward);
            rec.terminated.extend_from_slice(r.terminated);
            rec.time_outs.extend_from_slice(r.time_outs);
            rec.observe(&env)?;
        }
    }
    let secs = start.elapsed().as_secs_f64();
    println!(
        "{}: {n} envs × {} steps in {secs:.2} s ({:.0} env-steps/s), mean reward per step {:.4}",
        name,
        args.steps,
        (n * args.steps) as f64 / secs,
        mean_reward / args.steps as f64
    );
    if let (Some(rec), Some(dir)) = (&recording, &args.record) {
        rec.save(dir, n, d, obs_dim)?;
        println!(
            "recorded {} steps of {n} envs into {}",
            args.steps,
            dir.display()
        );
    }
    Ok(())
}
