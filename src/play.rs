//! The `play` workflow (Isaac Lab's `rsl_rl/play.py`): load a checkpoint and replay its
//! policy with mean actions, reporting each episode and the means over all of them.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use clap::Parser;
use orbit_render::VideoCfg;
use orbit_rl::burn::tensor::Device;
use orbit_rl::run_dir::{checkpoint_env_config, find_checkpoint};
use orbit_rl::{Policy, RlError, RunnerCfg, VecEnv};

use crate::train::{agent_file, check_black_box_overrides, check_task, split_overrides};

/// Flags of `play`.
#[derive(Parser, Debug, Clone)]
pub struct PlayArgs {
    /// Task id (default: BoxPushing-JointPos-Franka-v0).
    #[arg(long)]
    pub task: Option<String>,
    /// Training config file whose experiment holds the runs (default: the task's); only used
    /// to find the newest checkpoint when `--checkpoint` is not given.
    #[arg(long)]
    pub agent_config: Option<PathBuf>,
    /// Black-box wrapper config file used instead of the task's (makes the run episodic: one
    /// movement primitive per episode).
    #[arg(long)]
    pub bb_config: Option<PathBuf>,
    /// Env config file (default: the task's), envs (default: the env config's), seed and
    /// physics backend of the env.
    #[command(flatten)]
    pub env: crate::EnvArgs,
    /// Checkpoint to play, as `train --resume` takes it: a path (`…/model_<it>`, with or
    /// without an extension) or a regex of names within the `--load-run` run; default: the
    /// newest run's last checkpoint of the task's experiment.
    #[arg(long)]
    pub checkpoint: Option<String>,
    /// Run directory regex used when `--checkpoint` is not a path.
    #[arg(long, default_value = ".*")]
    pub load_run: String,
    /// Root of the run directories.
    #[arg(long, default_value = "logs")]
    pub log_root: PathBuf,
    /// A video of the first steps, written beside the checkpoint (`videos/play/`).
    #[command(flatten)]
    pub video: crate::VideoArgs,
    /// Episodes to play per env.
    #[arg(long, default_value_t = 1)]
    pub episodes: usize,
    /// Build the env from the task's registered configs, not from the `params/` of the run
    /// that wrote the checkpoint (the default, so that the env is the one it trained in).
    #[arg(long)]
    pub registered_config: bool,
    /// Env overrides `env.<path>=<value>` and black-box overrides `bb.<path>=<value>`.
    pub overrides: Vec<String>,
}

/// Means over the episodes `play` reports: returns, and the env's logged episode metrics.
#[derive(Default, Debug)]
struct EpisodeSummary {
    /// Reported episodes.
    episodes: usize,
    /// Sum of their returns.
    return_sum: f64,
    /// Per metric: the sum of (step mean × resets of that step) and the resets.
    metrics: BTreeMap<String, (f64, usize)>,
}

impl EpisodeSummary {
    /// Counts one finished episode with its return.
    fn add_return(&mut self, episode_return: f32) {
        self.episodes += 1;
        self.return_sum += f64::from(episode_return);
    }

    /// Folds in a step's log, whose values are means over the `resets` envs that finished in
    /// that step, so each weighs as many episodes as it averages.
    fn add_log(&mut self, log: &BTreeMap<String, f32>, resets: usize) {
        for (key, &value) in log {
            let m = self.metrics.entry(key.clone()).or_default();
            m.0 += f64::from(value) * resets as f64;
            m.1 += resets;
        }
    }

    /// Mean return of the reported episodes (0 before any).
    fn mean_return(&self) -> f64 {
        self.return_sum / self.episodes.max(1) as f64
    }

    /// Each metric's mean over the episodes it was logged for.
    fn metrics(&self) -> impl Iterator<Item = (&str, f64)> {
        self.metrics
            .iter()
            .filter(|(_, (_, n))| *n > 0)
            .map(|(k, &(sum, n))| (k.as_str(), sum / n as f64))
    }
}

/// Replays a trained policy (mean actions), prints each finished episode's return and the
/// step's episode metrics, then the mean return and metrics over all played episodes.
pub fn play(args: &PlayArgs) -> Result<(), Box<dyn std::error::Error>> {
    crate::link_registrations();
    if args.episodes == 0 {
        return Err("`--episodes` must be at least 1 (episodes to play per env)".into());
    }
    check_task(args.task.as_deref())?;
    let overrides = split_overrides(&args.overrides);
    let mut configs = crate::RunConfigs::resolve(
        args.task.as_deref(),
        crate::DEFAULT_TASK,
        args.env.task_config.as_deref(),
        args.agent_config.as_deref(),
        args.bb_config.as_deref(),
    )?;
    check_black_box_overrides(&configs, &overrides.black_box)?;
    let experiment = match agent_file(&configs) {
        Ok(file) => {
            let doc = orbit_managers::load_config(&file, &[])?;
            let agent: RunnerCfg = orbit_core::config::from_node(&doc)?;
            agent.experiment_name
        }
        // Without a training config only a checkpoint path can say what to play.
        Err(e) if args.checkpoint.is_none() => return Err(e.into()),
        Err(_) => String::new(),
    };
    let base = find_checkpoint(
        &args.log_root.join(experiment),
        &args.load_run,
        args.checkpoint.as_deref(),
    )?;
    let given = crate::run_params::GivenFiles {
        registered: args.registered_config,
        env: args.env.task_config.is_some(),
        agent: true,
        black_box: args.bb_config.is_some(),
    };
    println!(
        "{}",
        crate::run_params::choose_configs(&mut configs, &base, given)
    );
    let policy = Policy::load(&base, Device::flex())?;
    let e = &args.env;
    let mut env_overrides =
        crate::run_overrides(e.num_envs, e.seed, e.backend.as_deref(), &overrides.env);
    crate::choose_run_backend(&configs.env, &mut env_overrides)?;
    let video = args.video.video.then(|| {
        let run_dir = base.parent().unwrap_or(Path::new("."));
        VideoCfg {
            dir: run_dir.join("videos").join("play"),
            length: args.video.video_length,
            interval: None,
        }
    });
    let video_dir = video.as_ref().map(|v| v.dir.clone());
    let (mut env, video_progress) =
        crate::make_vec_env(&configs, &env_overrides, &overrides.black_box, video)?;
    // Like Isaac Lab's play, keep going until the video is complete.
    let video_frames = args.video.video_length as u64;
    let video_due = || {
        video_progress
            .as_ref()
            .is_some_and(|p| p.frames() < video_frames)
    };
    if env.num_obs() != policy.num_obs() {
        return Err(RlError::EnvMismatch(format!(
            "the policy expects {} observations, the env gives {}: the env config it was \
             trained with is in {} (a task's observation terms may have changed since: set \
             them back with `env.observations.policy…` overrides, or train a new policy)",
            policy.num_obs(),
            env.num_obs(),
            checkpoint_env_config(&base).display()
        ))
        .into());
    }
    println!("playing {} with {}", configs.name, base.display());
    let n = env.num_envs();
    let mut returns = vec![0.0f32; n];
    let mut finished = vec![0usize; n];
    let mut summary = EpisodeSummary::default();
    while finished.iter().any(|&f| f < args.episodes) || video_due() {
        let actions = policy.act(env.observations());
        let step = env.step(&actions)?;
        let mut reported = false;
        for e in 0..n {
            returns[e] += step.rewards[e];
            if step.dones[e] {
                if finished[e] < args.episodes {
                    println!(
                        "env {e:>4}: episode {} return {:>9.3}",
                        finished[e], returns[e]
                    );
                    summary.add_return(returns[e]);
                    reported = true;
                }
                finished[e] += 1;
                returns[e] = 0.0;
            }
        }
        if reported {
            for (key, value) in step.log {
                println!("    {key}: {value:.4}");
            }
            summary.add_log(step.log, step.dones.iter().filter(|&&d| d).count());
        }
    }
    println!(
        "{} episodes (mean actions): mean return {:.3}",
        summary.episodes,
        summary.mean_return()
    );
    for (key, value) in summary.metrics() {
        println!("    {key}: {value:.4}");
    }
    // Dropping the env closes the video file.
    drop(env);
    if let Some(dir) = video_dir {
        println!("video: {}", orbit_render::video_path(&dir, 0).display());
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A metric logged as a mean over 3 resets (1.0) and then over 1 reset (0.0) is 0.75 over
    /// the four episodes, not the 0.5 of the two step means; the mean return is exact.
    #[test]
    fn episode_summary_weighs_each_step_mean_by_its_resets() {
        let mut summary = EpisodeSummary::default();
        let log = |v: f32| BTreeMap::from([("Metrics/target/success".to_string(), v)]);
        for r in [-1.0, -2.0, -3.0] {
            summary.add_return(r);
        }
        summary.add_log(&log(1.0), 3);
        summary.add_return(-6.0);
        summary.add_log(&log(0.0), 1);
        summary.add_log(&BTreeMap::new(), 2);
        assert_eq!(summary.episodes, 4);
        assert!((summary.mean_return() - (-3.0)).abs() < 1e-12);
        let metrics: Vec<_> = summary.metrics().collect();
        assert_eq!(metrics.len(), 1);
        assert_eq!(metrics[0].0, "Metrics/target/success");
        assert!((metrics[0].1 - 0.75).abs() < 1e-12);
    }
}
