//! The `train` workflow (Isaac Lab's `rsl_rl/train.py`): resolve the task's env and agent
//! configs with overrides, make the run directory, train.

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::AtomicBool;

use clap::Parser;
use orbit_core::config::Node;
use orbit_render::VideoCfg;
use orbit_rl::run_dir::{ENV_CONFIG_FILE, PARAMS_DIR, create_run_dir, find_checkpoint};
use orbit_rl::{OnPolicyRunner, RlError, RunnerCfg, VecEnv};

mod ranks;
mod warm_up;
pub use ranks::{AUTO_MIN_ENVS_PER_RANK, AUTO_RANKS_MAX, RankCount, thread_ranks};

/// The training config in a run's `params/` (`--agent-config` takes it back).
pub const AGENT_CONFIG_FILE: &str = "agent.ron";
/// The black-box config in a run's `params/` (`--bb-config` takes it back).
pub const BLACK_BOX_CONFIG_FILE: &str = "black_box.ron";
/// The model files a run loaded, in its `params/`: each path, where it was loaded from and the
/// SHA-256 of its bytes.
pub const ASSETS_FILE: &str = "assets.ron";

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
    /// Continue from a checkpoint (see `--load-run`, `--checkpoint`), with the env, agent and
    /// black-box configs of the run that wrote it (its `params/`), unless
    /// `--registered-config` or a config file is given.
    #[arg(long)]
    pub resume: bool,
    /// With `--resume`: build from the task's registered configs, not the run's `params/`.
    #[arg(long)]
    pub registered_config: bool,
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
    /// Train data-parallel as one rank of an MPI job, one process per GPU (Isaac Lab's
    /// `--distributed`): `mpiexec -n <GPUs> train --distributed …`. Each rank steps its own
    /// `num_envs` envs seeded `seed + rank` on its host's GPU `local rank`; only rank 0 logs
    /// and checkpoints. Needs a build with `--features distributed`.
    #[arg(long)]
    pub distributed: bool,
    /// Train data-parallel as K threads of this process (`auto`: one per core, at most 8 and
    /// with at least 64 envs each, when the physics and the learner both run on the CPU; else
    /// 1). The run's `num_envs` envs are
    /// shared out, each rank stepping its share (seeded `seed + rank`) and updating a replica
    /// of the learner on it: the CPU learner's update, which uses about one core in one
    /// process, runs on K. Results depend on K.
    #[arg(long, default_value = "auto")]
    pub ranks: RankCount,
    /// Config overrides: `env.<path>=<value>` for the env, `agent.<path>=<value>` for the runner,
    /// `bb.<path>=<value>` for a black-box task's wrapper (e.g. `env.episode_length_s=4.0
    /// agent.algorithm.learning_rate=3e-4 bb.trajectory[0].weights_scale=0.5`).
    pub overrides: Vec<String>,
}

/// The resolved configs of a run.
#[derive(Clone)]
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
    /// Whether the physics runs on the CPU (rapier, or the wgpu kernel on a CPU adapter).
    pub physics_on_cpu: bool,
    /// The physics backend's name.
    pub backend: String,
    /// The checkpoint a `--resume` run continues from.
    pub resume_from: Option<PathBuf>,
}

/// Config overrides sorted by target.
#[derive(Default)]
pub(crate) struct Overrides {
    pub(crate) env: Vec<String>,
    pub(crate) agent: Vec<String>,
    pub(crate) black_box: Vec<String>,
}

/// Splits `env.`/`agent.`/`bb.` overrides (a token without prefix is an env override).
pub(crate) fn split_overrides(tokens: &[String]) -> Overrides {
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
///
/// A `--resume` run finds its checkpoint with the task's agent config, then builds from the
/// configs in that run's `params/` (those not given as files), unless `--registered-config`.
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
    if !args.resume {
        return resolve_configs(args, configs, false);
    }
    let first = resolve_configs(args, configs.clone(), true)?;
    let checkpoint = find_checkpoint(
        &args.log_root.join(&first.agent.experiment_name),
        &args.load_run,
        args.checkpoint.as_deref(),
    )?;
    let given = crate::run_params::GivenFiles {
        registered: args.registered_config,
        env: e.task_config.is_some(),
        agent: args.agent_config.is_some(),
        black_box: args.bb_config.is_some(),
    };
    println!(
        "{}",
        crate::run_params::choose_configs(&mut configs, &checkpoint, given)
    );
    let mut run = resolve_configs(args, configs, false)?;
    run.resume_from = Some(checkpoint);
    Ok(run)
}

/// [`resolve`] with the config files chosen (`quiet`: print nothing; a first pass).
fn resolve_configs(
    args: &TrainArgs,
    mut configs: crate::RunConfigs,
    quiet: bool,
) -> Result<ResolvedRun, RlError> {
    let Overrides {
        env: user_env,
        agent: mut agent_overrides,
        black_box: black_box_overrides,
    } = split_overrides(&args.overrides);
    // The backend is fixed before the agent config is chosen: physics on the CPU trains with
    // the task's config sized for CPUs, if it has one.
    let mut probe = crate::run_overrides(None, None, args.env.backend.as_deref(), &user_env);
    let backend = if quiet {
        crate::pick_run_backend(&configs.env, &mut probe)?
    } else {
        crate::choose_run_backend(&configs.env, &mut probe)?
    };
    if backend.probe.kind.is_cpu()
        && let Some(cpu_agent) = configs.cpu_agent.take()
    {
        if !quiet {
            println!(
                "training config: {} (the physics runs on the CPU; --agent-config {} trains with \
             the GPU-sized one)",
                cpu_agent.display(),
                configs
                    .agent
                    .as_ref()
                    .map_or(String::new(), |a| a.display().to_string())
            );
        }
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
        .map_err(|err| RlError::AgentConfig(err.to_string()))?;
    let agent: RunnerCfg = orbit_core::config::from_node(&agent_doc)
        .map_err(|err| RlError::AgentConfig(err.to_string()))?;
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
        physics_on_cpu: backend.probe.kind.is_cpu(),
        backend: backend.name,
        resume_from: None,
    })
}

/// Fails with the trainable tasks listed when `task` is given and not registered.
pub(crate) fn check_task(task: Option<&str>) -> Result<(), RlError> {
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
pub(crate) fn check_black_box_overrides(
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
pub(crate) fn agent_file(configs: &crate::RunConfigs) -> Result<PathBuf, RlError> {
    configs.agent.clone().ok_or_else(|| {
        RlError::AgentConfig(format!(
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
/// overrides applied) that `--task-config`, `--agent-config` and `--bb-config` take back;
/// `assets.ron`, the model files loaded; for a resumed run, the checkpoint it continued.
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
        (ASSETS_FILE, orbit_assets::asset_record(env_doc)),
    ];
    if let Some(bb) = &run.configs.black_box {
        let doc = orbit_managers::load_config(bb, &run.black_box_overrides)?;
        files.push((BLACK_BOX_CONFIG_FILE, doc.to_ron()));
    }
    if let Some(checkpoint) = &run.resume_from {
        let text = crate::run_params::resumed_from_text(checkpoint);
        files.push((crate::run_params::RESUMED_FROM_FILE, text));
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

/// [`train`], stopping with a checkpoint ([`RlError::Interrupted`]) once `stop` is set.
pub fn train_with(
    args: &TrainArgs,
    show_progress: bool,
    stop: Option<Arc<AtomicBool>>,
) -> Result<OnPolicyRunner<Box<dyn VecEnv>>, Box<dyn std::error::Error>> {
    if args.distributed {
        return ranks::train_in_mpi_job(args, show_progress, stop);
    }
    let run = resolve(args)?;
    let total_envs = ranks::run_num_envs(&run)?;
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    match ranks::thread_ranks(args.ranks, &run, total_envs, cores)? {
        1 => train_rank(args, run, show_progress, stop, None, 1),
        k => ranks::train_in_threads(args, run, show_progress, stop, k, total_envs),
    }
}

/// [`train_with`] of the resolved `run` as one rank of a data-parallel run (`rank`), or
/// alone; `share`: the number of thread ranks the run's envs are shared out to (1: this rank
/// steps them all).
fn train_rank(
    args: &TrainArgs,
    mut run: ResolvedRun,
    show_progress: bool,
    stop: Option<Arc<AtomicBool>>,
    rank: Option<&crate::distributed::Rank>,
    share: usize,
) -> Result<OnPolicyRunner<Box<dyn VecEnv>>, Box<dyn std::error::Error>> {
    if let Some(r) = rank {
        let env_settings: Vec<&str> = (run.env_overrides.iter())
            .filter(|o| !o.starts_with("seed="))
            .map(String::as_str)
            .collect();
        r.check_same_settings(&format!(
            "{}\n{}",
            run.agent_doc.to_ron(),
            env_settings.join("\n")
        ))?;
        // Each rank's envs differ (Isaac Lab seeds them by rank); the learner's seed is shared.
        run.env_overrides
            .push(format!("seed={}", run.agent.seed + r.rank() as u64));
    }
    let cfg = run.agent.clone();
    let resume_from = run.resume_from.clone();
    // `params/env.ron` holds the run's envs, all of them: it repeats the run.
    let env_doc = orbit_managers::load_env_config(&run.configs.env, &run.env_overrides)?;
    if let Some(n) = orbit_core::config::node_at(&env_doc, "num_envs") {
        let n = orbit_core::config::from_node::<usize>(n)? / share;
        if n == 0 {
            return Err(RlError::InvalidConfig {
                file: run.configs.env.display().to_string(),
                field: "num_envs".into(),
                message: format!(
                    "a run needs at least one env{}: raise --num-envs (or `env.num_envs`)",
                    if share > 1 {
                        format!(" per rank ({share} ranks)")
                    } else {
                        String::new()
                    }
                ),
            }
            .into());
        }
        cfg.validate_batch(n, &agent_file(&run.configs)?.display().to_string())?;
        if share > 1 {
            run.env_overrides.push(format!("num_envs={n}"));
        }
    }
    // Only once the configs and the checkpoint to resume are known to be good; only rank 0
    // of a data-parallel run logs.
    let dir = match rank {
        Some(r) if r.rank() > 0 => None,
        _ => Some(create_run_dir(
            &args.log_root,
            &cfg.experiment_name,
            &cfg.run_name,
        )?),
    };
    // The warm-up, if any, may still be compiling: it ends (is joined) when this returns.
    let (mut runner, _warm_up) = match start_runner(
        args,
        &run,
        &env_doc,
        dir.as_deref(),
        resume_from.as_deref(),
        show_progress,
        (share, rank.map_or(1, |r| r.world_size())),
    ) {
        Ok(runner) => runner,
        Err(e) => {
            // The directory holds only what this run just wrote: leave no run without a
            // checkpoint behind.
            if let Some(dir) = &dir {
                let _ = std::fs::remove_dir_all(dir);
            }
            return Err(e);
        }
    };
    runner.show_progress = show_progress;
    runner.stop = stop;
    if let Some(r) = rank {
        runner.distribute(r.collective.clone());
    }
    if let Err(e) = runner.learn(cfg.max_iterations) {
        // A run that failed before finishing an iteration holds no checkpoint, no curve and
        // only the configs it was given: leave no such directory behind.
        if runner.history.is_empty()
            && !matches!(e, RlError::Interrupted { .. })
            && let Some(dir) = runner.log_dir()
        {
            let _ = std::fs::remove_dir_all(dir);
        }
        return Err(e.into());
    }
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

/// A run's runner.
type Runner = OnPolicyRunner<Box<dyn VecEnv>>;

/// Writes the run's `params/`, builds its env and a runner logging into `dir` (none: a rank
/// of a data-parallel run that does not log), and loads the checkpoint to resume from; with
/// it, the learner's warm-up, which may still be running. `share`: the thread ranks the envs
/// are shared out to; `replicas`: the ranks of the run.
fn start_runner(
    args: &TrainArgs,
    run: &ResolvedRun,
    env_doc: &Node,
    dir: Option<&Path>,
    resume_from: Option<&Path>,
    show_progress: bool,
    (share, replicas): (usize, usize),
) -> Result<(Runner, warm_up::WarmUp), Box<dyn std::error::Error>> {
    if let Some(dir) = dir {
        write_params(dir, run, env_doc)?;
    }
    let video = dir.filter(|_| args.video.video).map(|dir| VideoCfg {
        dir: dir.join("videos").join("train"),
        length: args.video.video_length,
        interval: Some(args.video_interval),
    });
    if show_progress {
        println!("{}: building the env…", run.configs.name);
    }
    let build_start = std::time::Instant::now();
    let cfg = run.agent.clone();
    let device = crate::learner::learner_device(&cfg, replicas)?;
    // A single-process GPU learner compiles its kernels while the env builds its physics
    // kernel on a GPU. Where the physics runs on the CPU (rapier, or the kernel on a CPU
    // adapter) the two would share the CPU's cores, and the warm-up's iteration only adds
    // work (docs/experiments/learner-warm-up.md).
    let num_envs = orbit_core::config::node_at(env_doc, "num_envs")
        .and_then(|n| orbit_core::config::from_node::<usize>(n).ok());
    let warm_up = match num_envs {
        Some(n)
            if share == 1
                && cfg.device == orbit_rl::LearnerDevice::Gpu
                && cfg.gpu_update == orbit_rl::GpuUpdate::Burn
                && !run.physics_on_cpu =>
        {
            warm_up::WarmUp::spawn(run, n, cfg.clone(), device.clone())
        }
        _ => warm_up::WarmUp::none(),
    };
    let (vec_env, _) = crate::make_vec_env(
        &run.configs,
        &run.env_overrides,
        &run.black_box_overrides,
        video,
    )?;
    if let Some(dir) = dir {
        println!(
            "{}: {} envs × {} steps per iteration, {} iterations (env built in {:.1} s); run \
             directory {}",
            run.configs.name,
            vec_env.num_envs() * share,
            cfg.num_steps_per_env,
            cfg.max_iterations,
            build_start.elapsed().as_secs_f64(),
            dir.display()
        );
    }
    let learner_start = std::time::Instant::now();
    let mut runner = OnPolicyRunner::new(vec_env, cfg, dir.map(Path::to_path_buf), device)?;
    let seconds = learner_start.elapsed().as_secs_f64();
    tracing::info!(seconds, "created the run's learner");
    if let Some(base) = resume_from {
        if dir.is_some() {
            println!("resuming from {}", base.display());
        }
        runner.load_checkpoint(base)?;
    }
    Ok((runner, warm_up))
}
