//! The `train` and `play` workflows (Isaac Lab's `rsl_rl/train.py` and `play.py`): resolve the
//! task's env and agent configs with overrides, make the run directory, train or replay.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::AtomicBool;

use clap::Parser;
use orbit_core::config::Node;
use orbit_render::VideoCfg;
use orbit_rl::burn::tensor::Device;
use orbit_rl::run_dir::{
    ENV_CONFIG_FILE, PARAMS_DIR, checkpoint_env_config, create_run_dir, find_checkpoint,
};

/// The training config in a run's `params/` (`--agent-config` takes it back).
pub const AGENT_CONFIG_FILE: &str = "agent.ron";
/// The black-box config in a run's `params/` (`--bb-config` takes it back).
pub const BLACK_BOX_CONFIG_FILE: &str = "black_box.ron";
use orbit_rl::{OnPolicyRunner, Policy, RlError, RunnerCfg, VecEnv};

/// Flags of `train` (Isaac Lab's names).
#[derive(Parser, Debug, Clone)]
pub struct TrainArgs {
    /// Task id (see the `list_tasks` example; default: BoxPushing-JointPos-Franka-v0).
    #[arg(long)]
    pub task: Option<String>,
    /// Env config file, envs (default: the agent config's, else the task's), seed of the
    /// learner and the env (default: the agent config's), physics backend.
    #[command(flatten)]
    pub env: crate::EnvArgs,
    /// Training config file used instead of the task's (RON, as `params/agent.ron` of a run).
    #[arg(long)]
    pub agent_config: Option<PathBuf>,
    /// Black-box wrapper config file used instead of the task's (makes the run episodic: one
    /// movement primitive per episode).
    #[arg(long)]
    pub bb_config: Option<PathBuf>,
    /// Device of the learner: `cpu` or `gpu` (default: the agent config's `device`).
    #[arg(long, value_parser = ["cpu", "gpu"])]
    pub rl_device: Option<String>,
    /// Training iterations (default: the agent config's).
    #[arg(long)]
    pub max_iterations: Option<usize>,
    /// Continue from a checkpoint (see `--load-run`, `--checkpoint`).
    #[arg(long)]
    pub resume: bool,
    /// Run directory to resume from: a regex matched at the start of the names under
    /// `<log-root>/<experiment>/`; the last match (the newest run) is taken.
    #[arg(long, default_value = ".*")]
    pub load_run: String,
    /// Checkpoint to resume from: a path (`logs/<experiment>/<run>/model_49`, with or without
    /// an extension), or a regex of names within the `--load-run` run, matched against whole
    /// names (`model_1` is iteration 1 only; the highest matching iteration is taken). Default:
    /// the run's last checkpoint.
    #[arg(long)]
    pub checkpoint: Option<String>,
    /// Videos during training.
    #[command(flatten)]
    pub video: crate::VideoArgs,
    /// Env steps between the starts of training videos.
    #[arg(long, default_value_t = 2000)]
    pub video_interval: u64,
    /// Experiment name (the directory under the log root).
    #[arg(long)]
    pub experiment_name: Option<String>,
    /// Suffix of the run directory.
    #[arg(long)]
    pub run_name: Option<String>,
    /// Root of the run directories.
    #[arg(long, default_value = "logs")]
    pub log_root: PathBuf,
    /// Config overrides: `env.<path>=<value>` for the env, `agent.<path>=<value>` for the runner,
    /// `bb.<path>=<value>` for a black-box task's wrapper (e.g. `env.episode_length_s=4.0
    /// agent.algorithm.learning_rate=3e-4 bb.trajectory[0].weights_scale=0.5`).
    pub overrides: Vec<String>,
}

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
    /// Env overrides `env.<path>=<value>` and black-box overrides `bb.<path>=<value>`.
    pub overrides: Vec<String>,
}

/// The resolved configs of a run.
pub struct ResolvedRun {
    /// The run's config files.
    pub configs: crate::RunConfigs,
    /// The runner config.
    pub agent: RunnerCfg,
    /// The agent config document (for `params/agent.ron`).
    pub agent_doc: Node,
    /// Overrides that turn the task's env config into this run's.
    pub env_overrides: Vec<String>,
    /// Overrides of a black-box task's wrapper config.
    pub black_box_overrides: Vec<String>,
}

/// Config overrides sorted by target.
#[derive(Default)]
struct Overrides {
    env: Vec<String>,
    agent: Vec<String>,
    black_box: Vec<String>,
}

/// Splits `env.`/`agent.`/`bb.` overrides (a token without prefix is an env override).
fn split_overrides(tokens: &[String]) -> Overrides {
    let mut o = Overrides::default();
    for t in tokens {
        if let Some(rest) = t.strip_prefix("agent.") {
            o.agent.push(rest.to_string());
        } else if let Some(rest) = t.strip_prefix("bb.") {
            o.black_box.push(rest.to_string());
        } else {
            o.env.push(crate::env_override(t));
        }
    }
    o
}

/// Resolves the agent config of `args.task` with overrides and the CLI flags (which win over
/// overrides, as in Isaac Lab), and the env overrides: the agent's `env_overrides`, then the
/// user's, then `num_envs`, the seed (the agent's, as Isaac Lab's script copies it) and the
/// backend.
pub fn resolve(args: &TrainArgs) -> Result<ResolvedRun, RlError> {
    crate::link_registrations();
    check_task(args.task.as_deref())?;
    let e = &args.env;
    let mut configs = crate::RunConfigs::resolve(
        args.task.as_deref(),
        crate::DEFAULT_TASK,
        e.task_config.as_deref(),
        args.agent_config.as_deref(),
        args.bb_config.as_deref(),
    )?;
    let Overrides {
        env: user_env,
        agent: mut agent_overrides,
        black_box: black_box_overrides,
    } = split_overrides(&args.overrides);
    // The backend is fixed before the agent config is chosen: physics on the CPU trains with
    // the task's config sized for CPUs, if it has one.
    let backend = crate::choose_run_backend(
        &configs.env,
        &crate::run_overrides(None, None, args.env.backend.as_deref(), &user_env),
    )?;
    if backend.probe.kind.is_cpu()
        && let Some(cpu_agent) = configs.cpu_agent.take()
    {
        println!(
            "training config: {} (the physics runs on the CPU; --agent-config {} trains with \
             the GPU-sized one)",
            cpu_agent.display(),
            configs
                .agent
                .as_ref()
                .map_or(String::new(), |a| a.display().to_string())
        );
        configs.agent = Some(cpu_agent);
    }
    let agent_file = agent_file(&configs)?;
    check_black_box_overrides(&configs, &black_box_overrides)?;
    if let Some(s) = args.env.seed {
        agent_overrides.push(format!("seed={s}"));
    }
    if let Some(d) = &args.rl_device {
        let variant = if d == "gpu" { "Gpu" } else { "Cpu" };
        agent_overrides.push(format!("device={variant}"));
    }
    if let Some(m) = args.max_iterations {
        agent_overrides.push(format!("max_iterations={m}"));
    }
    if let Some(e) = &args.experiment_name {
        agent_overrides.push(format!("experiment_name={e:?}"));
    }
    if let Some(r) = &args.run_name {
        agent_overrides.push(format!("run_name={r:?}"));
    }
    let agent_doc = orbit_managers::load_config(&agent_file, &agent_overrides)
        .map_err(|err| RlError::EnvMismatch(err.to_string()))?;
    let agent: RunnerCfg = orbit_core::config::from_node(&agent_doc)?;
    agent.validate(&agent_file.display().to_string())?;
    let mut env_overrides = agent.env_overrides.clone();
    env_overrides.extend(user_env);
    // The chosen backend, not `auto`: `params/env.ron` repeats the run on the same one.
    env_overrides.extend(crate::run_overrides(
        args.env.num_envs,
        Some(agent.seed),
        Some(&backend.name),
        &[],
    ));
    Ok(ResolvedRun {
        configs,
        agent,
        agent_doc,
        env_overrides,
        black_box_overrides,
    })
}

/// Fails with the trainable tasks listed when `task` is given and not registered.
fn check_task(task: Option<&str>) -> Result<(), RlError> {
    match task {
        Some(id) if orbit_managers::task(id).is_err() => Err(RlError::UnknownTask {
            task: id.to_string(),
            trainable: trainable_tasks(),
        }),
        _ => Ok(()),
    }
}

/// Fails when `bb.` overrides are given for a run without a black-box config (they would be
/// ignored).
fn check_black_box_overrides(
    configs: &crate::RunConfigs,
    overrides: &[String],
) -> Result<(), RlError> {
    match (overrides.first(), &configs.black_box) {
        (Some(first), None) => Err(RlError::InvalidConfig {
            file: "<command line>".into(),
            field: format!("bb.{first}"),
            message: format!(
                "`{}` is a step-based task, which has no black-box config to override: remove \
                 the `bb.` overrides, or run a black-box task (or pass --bb-config)",
                configs.name
            ),
        }),
        _ => Ok(()),
    }
}

/// The training config of a run, or an error naming the trainable tasks.
fn agent_file(configs: &crate::RunConfigs) -> Result<PathBuf, RlError> {
    configs.agent.clone().ok_or_else(|| {
        RlError::EnvMismatch(format!(
            "`{}` has no training config: pass one with --agent-config FILE, or train a task \
             that has one: {:?}",
            configs.name,
            trainable_tasks()
        ))
    })
}

/// The ids of the registered tasks that have a training config.
fn trainable_tasks() -> Vec<String> {
    orbit_managers::tasks()
        .into_iter()
        .filter(|t| t.agent.is_some())
        .map(|t| t.id.to_string())
        .collect()
}

/// Writes the run's resolved configs into `<dir>/params/`: `env.ron` (`env_doc`), `agent.ron`
/// and, for a black-box run, `black_box.ron`, each a self-contained file (includes merged,
/// overrides applied) that `--task-config`, `--agent-config` and `--bb-config` take back.
fn write_params(
    dir: &Path,
    run: &ResolvedRun,
    env_doc: &Node,
) -> Result<(), Box<dyn std::error::Error>> {
    let params = dir.join(PARAMS_DIR);
    std::fs::create_dir_all(&params).map_err(RlError::io(&params))?;
    let mut files = vec![
        (ENV_CONFIG_FILE, env_doc.to_ron()),
        (AGENT_CONFIG_FILE, run.agent_doc.to_ron()),
    ];
    if let Some(bb) = &run.configs.black_box {
        let doc = orbit_managers::load_config(bb, &run.black_box_overrides)?;
        files.push((BLACK_BOX_CONFIG_FILE, doc.to_ron()));
    }
    for (name, text) in files {
        let path = params.join(name);
        std::fs::write(&path, text).map_err(RlError::io(path))?;
    }
    Ok(())
}

/// Trains `args.task` with PPO; returns the runner (its `history` holds every iteration).
pub fn train(
    args: &TrainArgs,
    show_progress: bool,
) -> Result<OnPolicyRunner<Box<dyn VecEnv>>, Box<dyn std::error::Error>> {
    train_with(args, show_progress, None)
}

/// Signals within this time of the first one count as the same request: a wrapper such as
/// `timeout` sends its signal to the command and again to its process group.
const SIGNAL_GRACE: std::time::Duration = std::time::Duration::from_secs(1);

/// A flag that the first SIGINT (Ctrl-C) or SIGTERM sets; a later one (more than a second
/// after it) ends the process at once with exit code 130. Pass it to [`train_with`] to stop
/// training with a checkpoint.
pub fn stop_on_signals() -> Result<Arc<AtomicBool>, RlError> {
    let stop = Arc::new(AtomicBool::new(false));
    // Nanoseconds after `origin` of the first signal (0: none yet).
    let first = Arc::new(std::sync::atomic::AtomicU64::new(0));
    let origin = std::time::Instant::now();
    for signal in [signal_hook::consts::SIGINT, signal_hook::consts::SIGTERM] {
        let (stop, first) = (Arc::clone(&stop), Arc::clone(&first));
        let handler = move || {
            let now = (origin.elapsed().as_nanos() as u64).max(1);
            if on_signal(&first, &stop, now) {
                signal_hook::low_level::exit(130)
            }
        };
        // SAFETY: the handler only reads the monotonic clock (clock_gettime), uses atomics and
        // calls `_exit`, all async-signal-safe; it allocates and locks nothing.
        unsafe { signal_hook::low_level::register(signal, handler) }
            .map_err(|e| RlError::Device(format!("installing a signal handler: {e}")))?;
    }
    Ok(stop)
}

/// What a stop signal at `now` (nanoseconds, > 0) does: the first sets `stop` and is recorded
/// in `first`; one within [`SIGNAL_GRACE`] of it does nothing; a later one asks for an exit
/// (returns true). Only atomics: it runs in a signal handler.
fn on_signal(first: &std::sync::atomic::AtomicU64, stop: &AtomicBool, now: u64) -> bool {
    use std::sync::atomic::Ordering::SeqCst;
    match first.compare_exchange(0, now, SeqCst, SeqCst) {
        Ok(_) => {
            stop.store(true, SeqCst);
            false
        }
        Err(at) => now.saturating_sub(at) > SIGNAL_GRACE.as_nanos() as u64,
    }
}

/// [`train`], stopping with a checkpoint ([`RlError::Interrupted`]) once `stop` is set.
pub fn train_with(
    args: &TrainArgs,
    show_progress: bool,
    stop: Option<Arc<AtomicBool>>,
) -> Result<OnPolicyRunner<Box<dyn VecEnv>>, Box<dyn std::error::Error>> {
    let run = resolve(args)?;
    let cfg = run.agent.clone();
    let resume_from = if args.resume {
        Some(find_checkpoint(
            &args.log_root.join(&cfg.experiment_name),
            &args.load_run,
            args.checkpoint.as_deref(),
        )?)
    } else {
        None
    };
    let env_doc = orbit_managers::load_env_config(&run.configs.env, &run.env_overrides)?;
    if let Some(n) = orbit_core::config::node_at(&env_doc, "num_envs") {
        let n: usize = orbit_core::config::from_node(n)?;
        cfg.validate_batch(n, &agent_file(&run.configs)?.display().to_string())?;
    }
    // Only once the configs and the checkpoint to resume are known to be good.
    let dir = create_run_dir(&args.log_root, &cfg.experiment_name, &cfg.run_name)?;
    let mut runner = match start_runner(
        args,
        &run,
        &env_doc,
        &dir,
        resume_from.as_deref(),
        show_progress,
    ) {
        Ok(runner) => runner,
        Err(e) => {
            // The directory holds only what this run just wrote: leave no run without a
            // checkpoint behind.
            let _ = std::fs::remove_dir_all(&dir);
            return Err(e);
        }
    };
    runner.show_progress = show_progress;
    runner.stop = stop;
    runner.learn(cfg.max_iterations)?;
    if let Some(dir) = runner.log_dir() {
        // A resumed run's curves continue those of the run it resumed from.
        let history = match &resume_from {
            Some(base) => orbit_rl::logger::resumed_history(base, &runner.history),
            None => runner.history.clone(),
        };
        orbit_rl::plot::write_training_curves(dir, &history, runner.cfg.success_metric.is_some())?;
    }
    Ok(runner)
}

/// Writes the run's `params/`, builds its env and a runner logging into `dir`, and loads the
/// checkpoint to resume from.
fn start_runner(
    args: &TrainArgs,
    run: &ResolvedRun,
    env_doc: &Node,
    dir: &Path,
    resume_from: Option<&Path>,
    show_progress: bool,
) -> Result<OnPolicyRunner<Box<dyn VecEnv>>, Box<dyn std::error::Error>> {
    write_params(dir, run, env_doc)?;
    let video = args.video.video.then(|| VideoCfg {
        dir: dir.join("videos").join("train"),
        length: args.video.video_length,
        interval: Some(args.video_interval),
    });
    if show_progress {
        println!("{}: building the env…", run.configs.name);
    }
    let build_start = std::time::Instant::now();
    let (vec_env, _) = crate::make_vec_env(
        &run.configs,
        &run.env_overrides,
        &run.black_box_overrides,
        video,
    )?;
    let cfg = run.agent.clone();
    println!(
        "{}: {} envs × {} steps per iteration, {} iterations (env built in {:.1} s); run \
         directory {}",
        run.configs.name,
        vec_env.num_envs(),
        cfg.num_steps_per_env,
        cfg.max_iterations,
        build_start.elapsed().as_secs_f64(),
        dir.display()
    );
    let device = crate::learner::learner_device(cfg.device)?;
    let mut runner = OnPolicyRunner::new(vec_env, cfg, Some(dir.to_path_buf()), device)?;
    if let Some(base) = resume_from {
        println!("resuming from {}", base.display());
        runner.load_checkpoint(base)?;
    }
    Ok(runner)
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
    let configs = crate::RunConfigs::resolve(
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
    let policy = Policy::load(&base, Device::flex())?;
    let e = &args.env;
    let mut env_overrides =
        crate::run_overrides(e.num_envs, e.seed, e.backend.as_deref(), &overrides.env);
    let backend = crate::choose_run_backend(&configs.env, &env_overrides)?;
    env_overrides.push(format!("sim.backend={:?}", backend.name));
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

    /// The first signal requests the stop; a repeat within a second (a wrapper's second
    /// delivery) is the same request; one after that aborts.
    #[test]
    fn a_second_signal_aborts_only_after_the_grace_time() {
        let (first, stop) = (std::sync::atomic::AtomicU64::new(0), AtomicBool::new(false));
        let second = 1_000_000_000u64;
        assert!(!on_signal(&first, &stop, 5 * second));
        assert!(stop.load(std::sync::atomic::Ordering::SeqCst));
        assert!(!on_signal(&first, &stop, 5 * second + second / 10));
        assert!(on_signal(&first, &stop, 6 * second + second / 10));
    }

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
