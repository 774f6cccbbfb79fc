//! The on-policy runner (RSL-RL's `OnPolicyRunner`): collect a rollout, compute
//! returns, update, log, checkpoint.

use std::collections::{BTreeMap, VecDeque};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

use crate::RlError;
use crate::cfg::{GpuUpdate, LearnerDevice, RunnerCfg};
pub use crate::checkpoint::{CheckpointState, read_state};
use crate::collective::{self, Collective};
use crate::logger::ScalarLog;
use crate::model::ActorCritic;
use crate::normalizer::EmpiricalNormalizer;
use crate::policy::Policy;
use crate::ppo::{LossStats, Ppo, values};
use burn::module::Module;
use burn::tensor::Device;
use orbit_envs::VecEnv;

/// `sum / count`, if anything was counted.
fn mean((sum, count): (f64, usize)) -> Option<f32> {
    (count > 0).then(|| (sum / count as f64) as f32)
}

/// Rows after which the observation statistics freeze (RSL-RL's `until`).
const NORMALIZER_UNTIL: u64 = 100_000_000;

/// Completed episodes kept for the running means (RSL-RL's 100-long deques).
const EPISODE_WINDOW: usize = 100;

/// What one iteration measured.
#[derive(Clone, Debug, PartialEq)]
pub struct IterationLog {
    /// 0-based iteration.
    pub iteration: usize,
    /// Env interactions (simulated env steps) so far, all envs, all iterations, this one
    /// included; a black-box step counts the env steps of its trajectory.
    pub env_steps: u64,
    /// Wall-clock seconds since training started (collection + learning, summed over
    /// iterations of this and resumed runs).
    pub wall_time: f64,
    /// Mean undiscounted return of the last ≤ 100 completed episodes (of each rank, in a
    /// data-parallel run).
    pub mean_return: Option<f32>,
    /// Mean length (steps) of the last ≤ 100 completed episodes (of each rank).
    pub mean_episode_length: Option<f32>,
    /// Mean of the runner config's `success_metric` over this iteration's finished episodes
    /// (every rank's).
    pub success_rate: Option<f32>,
    /// PPO losses.
    pub losses: LossStats,
    /// Learning rate after the update.
    pub learning_rate: f64,
    /// Mean action-noise standard deviation.
    pub mean_noise_std: f32,
    /// Env interactions per second of this iteration (collection and learning).
    pub fps: f64,
    /// Seconds spent collecting.
    pub collection_time: f64,
    /// Seconds of the collection spent inside the env's `step` (physics and managers); the
    /// rest is the policy's forward pass and the runner's bookkeeping.
    pub env_time: f64,
    /// Seconds of `env_time` spent in the physics backend (stepping, and reading the state
    /// back); 0 when the env does not report its phases.
    pub physics_time: f64,
    /// Seconds of `env_time` spent in each of the env's other phases, by name (`actions`,
    /// `terminations`, `rewards`, `resets`, `commands`, `events`, `observations`; see
    /// `orbit_managers::StepTimings`); empty when the env does not report its phases.
    pub env_phase_times: BTreeMap<String, f64>,
    /// Seconds of the collection spent in the policy: its forward pass, the action sampling and
    /// storing the transition.
    pub policy_time: f64,
    /// Seconds spent learning.
    pub learning_time: f64,
    /// Per-key means of the env's episode logs over this iteration.
    pub episode: BTreeMap<String, f32>,
}

/// Trains a policy on a [`VecEnv`] with PPO.
pub struct OnPolicyRunner<E: VecEnv> {
    /// The environment.
    pub env: E,
    /// The runner config.
    pub cfg: RunnerCfg,
    /// The learner.
    pub alg: Ppo,
    obs_normalizer: Option<EmpiricalNormalizer>,
    critic_normalizer: Option<EmpiricalNormalizer>,
    /// The current (normalised) observations of the actor and the critic.
    obs: Vec<f32>,
    critic_obs: Vec<f32>,
    /// The env's critic observations are its actor observations (no `critic` group): the
    /// critic then reads `obs`, normalised by the actor's statistics, which are the critic
    /// normaliser's too (the same values folded in the same order), and `critic_obs` is unused.
    critic_is_actor: bool,
    log_dir: Option<PathBuf>,
    scalars: Option<ScalarLog>,
    /// Iterations done (the next iteration's index).
    pub iteration: usize,
    env_steps: u64,
    wall_time: f64,
    /// Every iteration's log, in order.
    pub history: Vec<IterationLog>,
    returns: VecDeque<f32>,
    lengths: VecDeque<f32>,
    current_return: Vec<f32>,
    current_length: Vec<u32>,
    /// Show a progress bar on the terminal while learning.
    pub show_progress: bool,
    /// A stop request (set by a signal handler): [`learn`](Self::learn) then stops at the next
    /// env step, saves a checkpoint of the last finished iteration and returns
    /// [`RlError::Interrupted`].
    pub stop: Option<Arc<AtomicBool>>,
    device: Device,
}

impl<E: VecEnv> OnPolicyRunner<E> {
    /// A runner with a freshly initialised network on `device`, logging into `log_dir` (none
    /// for no files).
    pub fn new(
        env: E,
        cfg: RunnerCfg,
        log_dir: Option<PathBuf>,
        device: Device,
    ) -> Result<Self, RlError> {
        let (n, no, nc, na) = (
            env.num_envs(),
            env.num_obs(),
            env.num_critic_obs(),
            env.num_actions(),
        );
        cfg.validate_batch(n, "the runner config")?;
        let model = ActorCritic::new(
            &cfg.policy,
            no,
            nc,
            na,
            cfg.seed,
            &device.clone().autodiff(),
        );
        let mut alg = Ppo::new(
            cfg.algorithm.clone(),
            model,
            n,
            cfg.num_steps_per_env,
            (no, nc, na),
            cfg.seed,
            device.clone().autodiff(),
        );
        if cfg.device == LearnerDevice::Gpu && cfg.gpu_update == GpuUpdate::Fused {
            alg.use_fused_update()?;
        }
        let normalizers = cfg.empirical_normalization;
        let scalars = match &log_dir {
            Some(dir) => {
                std::fs::create_dir_all(dir).map_err(RlError::io(dir))?;
                Some(ScalarLog::create(dir)?)
            }
            None => None,
        };
        Ok(Self {
            obs_normalizer: normalizers.then(|| EmpiricalNormalizer::new(no, NORMALIZER_UNTIL)),
            critic_normalizer: normalizers.then(|| EmpiricalNormalizer::new(nc, NORMALIZER_UNTIL)),
            obs: vec![0.0; n * no],
            critic_obs: vec![0.0; n * nc],
            critic_is_actor: false,
            env,
            cfg,
            alg,
            log_dir,
            scalars,
            iteration: 0,
            env_steps: 0,
            wall_time: 0.0,
            history: Vec::new(),
            returns: VecDeque::with_capacity(EPISODE_WINDOW),
            lengths: VecDeque::with_capacity(EPISODE_WINDOW),
            current_return: vec![0.0; n],
            current_length: vec![0; n],
            show_progress: false,
            stop: None,
            device,
        })
    }

    /// Makes this runner one rank of a data-parallel run (RSL-RL's multi-GPU training): the
    /// learner takes rank 0's parameters and averages its gradients with the other ranks
    /// (see [`Ppo::distribute`]), the observation statistics pool every rank's observations,
    /// and a stop request on any rank stops all. Call it on every rank, after loading a
    /// checkpoint to resume. Each rank steps its own envs (seed them apart); only the rank
    /// given a log directory writes logs and checkpoints. Logged env steps count every rank's.
    pub fn distribute(&mut self, c: Arc<dyn Collective>) {
        self.alg.distribute(c);
    }

    /// The run directory, if logging to files.
    pub fn log_dir(&self) -> Option<&Path> {
        self.log_dir.as_deref()
    }

    /// Copies the env's current observations into `obs`/`critic_obs`, normalised (and, in
    /// training, folded into the statistics). Non-finite observations are an error that
    /// changes nothing.
    fn observe(&mut self, update: bool) -> Result<(), RlError> {
        let (actor, critic) = (self.env.observations(), self.env.critic_observations());
        let critic_is_actor = !actor.is_empty()
            && std::ptr::eq(actor, critic)
            && self.obs_normalizer.is_some() == self.critic_normalizer.is_some();
        let env = &self.env;
        let source = |critic: bool| move |i: usize| env.observation_source(critic, i);
        check_finite("policy observation", actor, env.num_obs(), source(false))?;
        if !critic_is_actor {
            let dim = env.num_critic_obs();
            check_finite("critic observation", critic, dim, source(true))?;
        }
        self.critic_is_actor = critic_is_actor;
        let critic = (!critic_is_actor).then_some((
            &mut self.critic_normalizer,
            critic,
            &mut self.critic_obs,
        ));
        let actor = (&mut self.obs_normalizer, actor, &mut self.obs);
        // Read from the env's buffers and written once, normalised: no separate copy.
        for (norm, x, out) in std::iter::once(actor).chain(critic) {
            match norm {
                Some(n) => {
                    if update {
                        n.update_across(self.alg.collective(), x);
                    }
                    n.normalize_into(x, out);
                }
                None => orbit_core::parallel::copy(x, out),
            }
        }
        Ok(())
    }

    /// The critic's observation normaliser as a checkpoint stores it (the actor's when they
    /// observe the same values).
    fn saved_critic_normalizer(&self) -> &Option<EmpiricalNormalizer> {
        if self.critic_is_actor {
            &self.obs_normalizer
        } else {
            &self.critic_normalizer
        }
    }

    /// Runs `num_iterations` iterations (continuing the numbering of a resumed run), saving a
    /// checkpoint every `save_interval` iterations and after the last.
    pub fn learn(&mut self, num_iterations: usize) -> Result<(), RlError> {
        let (rank, ranks) = self
            .alg
            .collective()
            .map_or((0, 1), |c| (c.rank(), c.world_size()));
        if self.iteration == 0 && self.cfg.init_at_random_ep_len {
            self.env
                .randomize_episode_lengths(self.cfg.seed + rank as u64)?;
        }
        let (n, na) = (self.env.num_envs(), self.env.num_actions());
        let t_steps = self.cfg.num_steps_per_env;
        let progress = self
            .show_progress
            .then(|| crate::progress::Progress::new(self.iteration, num_iterations));
        let first_iteration = self.iteration;
        let mut actions = vec![0.0f32; n * na];
        self.observe(true)?;
        let end = self.iteration + num_iterations;
        while self.iteration < end {
            let it = self.iteration;
            let start = Instant::now();
            let mut success = (0.0f64, 0usize);
            let mut episode: BTreeMap<String, (f64, usize)> = BTreeMap::new();
            let mut interactions = 0u64;
            let mut env_time = 0.0;
            let mut policy_time = 0.0;
            let timings_before = self.env.step_timings();
            if let Some(p) = progress.as_ref().filter(|_| it == first_iteration) {
                p.phase(&format!(
                    "iteration {}: collecting {t_steps} steps × {n} envs (a first run on a GPU \
                     backend compiles its kernels first)",
                    it + 1
                ));
            }
            for _ in 0..t_steps {
                if self.stop_requested() {
                    if let Some(p) = &progress {
                        p.finish();
                    }
                    let stopped = self.stop_with_checkpoint()?;
                    if let Some(c) = self.alg.collective() {
                        // No rank ends (and lets the launcher end the job) before rank 0 has
                        // written its checkpoint.
                        collective::any(c, false);
                    }
                    return Err(stopped);
                }
                let policy_start = Instant::now();
                let critic_obs = critic_view(self.critic_is_actor, &self.obs, &self.critic_obs);
                self.alg.act(&self.obs, critic_obs, &mut actions)?;
                policy_time += policy_start.elapsed().as_secs_f64();
                let env_start = Instant::now();
                let step = self.env.step(&actions)?;
                env_time += env_start.elapsed().as_secs_f64();
                interactions += (n * ranks) as u64 * u64::from(step.interactions);
                self.alg
                    .process_env_step(step.rewards, step.dones, step.time_outs);
                for (key, &v) in step.log {
                    let e = episode.entry(key.clone()).or_default();
                    e.0 += f64::from(v);
                    e.1 += 1;
                }
                if let Some(v) = self
                    .cfg
                    .success_metric
                    .as_ref()
                    .and_then(|k| step.log.get(k))
                {
                    success.0 += f64::from(*v);
                    success.1 += 1;
                }
                check_finite("reward", step.rewards, 1, |_| None)?;
                for e in 0..n {
                    self.current_return[e] += step.rewards[e];
                    self.current_length[e] += 1;
                    if step.dones[e] {
                        if self.returns.len() == EPISODE_WINDOW {
                            self.returns.pop_front();
                            self.lengths.pop_front();
                        }
                        self.returns.push_back(self.current_return[e]);
                        self.lengths.push_back(self.current_length[e] as f32);
                        self.current_return[e] = 0.0;
                        self.current_length[e] = 0;
                    }
                }
                self.observe(true)?;
            }
            self.alg.compute_returns(critic_view(
                self.critic_is_actor,
                &self.obs,
                &self.critic_obs,
            ));
            let (physics_time, env_phase_times) = match (timings_before, self.env.step_timings()) {
                (Some(before), Some(after)) => {
                    let spent = after.since(&before);
                    let others = spent.phases().into_iter().filter(|(p, _)| *p != "physics");
                    let others = others.map(|(p, t)| (p.to_string(), t.as_secs_f64()));
                    (spent.physics.as_secs_f64(), others.collect())
                }
                _ => (0.0, BTreeMap::new()),
            };
            let collection_time = start.elapsed().as_secs_f64();
            if let Some(p) = progress.as_ref().filter(|_| it == first_iteration) {
                p.phase(&format!(
                    "iteration {}: collected in {collection_time:.1} s; first update (a GPU \
                     learner compiles its kernels first)",
                    it + 1
                ));
            }
            let learn_start = Instant::now();
            let losses = self.alg.update()?;
            let learning_time = learn_start.elapsed().as_secs_f64();
            self.env_steps += interactions;
            self.wall_time += collection_time + learning_time;
            let (success, episode, returns, lengths) = self.pooled(success, episode);
            let noise = values(self.alg.model.action_std());
            let log = IterationLog {
                iteration: it,
                env_steps: self.env_steps,
                wall_time: self.wall_time,
                mean_return: mean(returns),
                mean_episode_length: mean(lengths),
                success_rate: mean(success),
                losses,
                learning_rate: self.alg.learning_rate(),
                mean_noise_std: noise.iter().sum::<f32>() / noise.len() as f32,
                fps: interactions as f64 / (collection_time + learning_time),
                collection_time,
                env_time,
                physics_time,
                env_phase_times,
                policy_time,
                learning_time,
                episode: episode
                    .into_iter()
                    .filter_map(|(k, sum)| Some((k, mean(sum)?)))
                    .collect(),
            };
            if let Some(s) = &mut self.scalars {
                s.write(&log)?;
            }
            if let Some(p) = &progress {
                p.update(&log);
            }
            tracing::debug!(iteration = it, ?log.mean_return, ?log.success_rate, "iteration");
            self.history.push(log);
            self.iteration += 1;
            if self.iteration.is_multiple_of(self.cfg.save_interval.max(1)) || self.iteration == end
            {
                self.save_checkpoint()?;
            }
        }
        if let Some(p) = progress {
            p.finish();
        }
        Ok(())
    }

    /// This iteration's success and episode-term sums with their counts, and the episode
    /// window's return and length sums with theirs: this runner's, or in a data-parallel run
    /// every rank's added up, so that the log describes all envs.
    #[allow(clippy::type_complexity)]
    fn pooled(
        &self,
        success: (f64, usize),
        mut episode: BTreeMap<String, (f64, usize)>,
    ) -> (
        (f64, usize),
        BTreeMap<String, (f64, usize)>,
        (f64, usize),
        (f64, usize),
    ) {
        let window = |q: &VecDeque<f32>| (q.iter().map(|&v| f64::from(v)).sum(), q.len());
        // Names no logged term has (a term name is printable).
        const SUCCESS: &str = "\0success";
        const RETURNS: &str = "\0returns";
        const LENGTHS: &str = "\0lengths";
        episode.insert(SUCCESS.into(), success);
        episode.insert(RETURNS.into(), window(&self.returns));
        episode.insert(LENGTHS.into(), window(&self.lengths));
        if let Some(c) = self.alg.collective() {
            episode = collective::sum_named(c, &episode);
        }
        let mut take = |name| episode.remove(name).unwrap_or_default();
        let (success, returns, lengths) = (take(SUCCESS), take(RETURNS), take(LENGTHS));
        (success, episode, returns, lengths)
    }

    /// Whether [`stop`](Self::stop) was set (on any rank of a data-parallel run).
    fn stop_requested(&self) -> bool {
        let local = self
            .stop
            .as_ref()
            .is_some_and(|s| s.load(Ordering::Relaxed));
        match self.alg.collective() {
            Some(c) => collective::any(c, local),
            None => local,
        }
    }

    /// Saves the last finished iteration's checkpoint, unless it was saved already or no
    /// iteration finished, and returns the [`RlError::Interrupted`] that names it. The
    /// unfinished iteration's transitions are dropped (its observations are already in the
    /// normaliser's statistics).
    fn stop_with_checkpoint(&self) -> Result<RlError, RlError> {
        let checkpoint = match (&self.log_dir, self.iteration) {
            (Some(dir), it) if it > 0 => {
                let base = dir.join(format!("model_{}", it - 1));
                if !base.with_extension("json").exists() {
                    tracing::warn!(
                        "stopping: saving a checkpoint (a third Ctrl-C aborts without it)"
                    );
                    self.save_checkpoint()?;
                }
                Some(base)
            }
            _ => None,
        };
        Ok(RlError::Interrupted {
            iterations: self.iteration,
            checkpoint,
        })
    }

    /// The current policy for inference (mean actions, current normaliser).
    pub fn inference_policy(&self) -> Policy {
        Policy::new(
            self.alg.model.valid(),
            self.obs_normalizer.clone(),
            self.device.clone(),
            self.env.num_obs(),
            self.env.num_actions(),
        )
    }

    /// Writes `model_<it>.{bpk,adam.bpk,json}` into the run directory (`it` = the last
    /// finished iteration), if there is one.
    pub fn save_checkpoint(&self) -> Result<(), RlError> {
        let Some(dir) = &self.log_dir else {
            return Ok(());
        };
        let base = dir.join(format!("model_{}", self.iteration.saturating_sub(1)));
        let state = CheckpointState {
            iteration: self.iteration,
            learning_rate: self.alg.learning_rate(),
            env_steps: self.env_steps,
            wall_time: self.wall_time,
            num_obs: self.env.num_obs(),
            num_critic_obs: self.env.num_critic_obs(),
            num_actions: self.env.num_actions(),
            policy: self.cfg.policy.clone(),
            obs_normalizer: self.obs_normalizer.clone(),
            critic_obs_normalizer: self.saved_critic_normalizer().clone(),
            value_normalizer: self.alg.value_normalizer.clone(),
        };
        crate::checkpoint::write_checkpoint(&base, &self.alg, &state)
    }

    /// Restores weights, optimiser, normalisers, learning rate and iteration count from a
    /// checkpoint written by [`save_checkpoint`](Self::save_checkpoint) (`base` without
    /// extension, e.g. `logs/x/2026-…/model_49`).
    pub fn load_checkpoint(&mut self, base: &Path) -> Result<(), RlError> {
        let state = read_state(base)?;
        let dims = (
            self.env.num_obs(),
            self.env.num_critic_obs(),
            self.env.num_actions(),
        );
        if (state.num_obs, state.num_critic_obs, state.num_actions) != dims {
            return Err(RlError::checkpoint(
                base.with_extension("json"),
                format!(
                    "trained for (obs, critic obs, actions) = {:?}, this env has {dims:?}: \
                     resume with the env config of the checkpoint's run ({}), or train anew",
                    (state.num_obs, state.num_critic_obs, state.num_actions),
                    crate::run_dir::checkpoint_env_config(base).display()
                ),
            ));
        }
        self.alg.load(base, true)?;
        self.alg.set_learning_rate(state.learning_rate);
        self.obs_normalizer = state.obs_normalizer;
        self.critic_normalizer = state.critic_obs_normalizer;
        if let Some(part) = (self.critic_normalizer.as_ref()).and_then(|n| n.first_non_finite()) {
            return Err(RlError::NonFinite(format!(
                "{}: the critic's observation normaliser's {part} is not finite",
                base.with_extension("json").display()
            )));
        }
        self.inference_policy().check_finite(base)?;
        if self.alg.cfg.normalize_value {
            // A checkpoint trained without value normalisation starts fresh statistics.
            self.alg.value_normalizer = Some(
                state
                    .value_normalizer
                    .unwrap_or_else(|| EmpiricalNormalizer::new(1, u64::MAX)),
            );
        }
        self.iteration = state.iteration;
        self.env_steps = state.env_steps;
        self.wall_time = state.wall_time;
        Ok(())
    }
}

/// The critic's current observations: the actor's when the env gives both the same values.
fn critic_view<'a>(critic_is_actor: bool, obs: &'a [f32], critic_obs: &'a [f32]) -> &'a [f32] {
    if critic_is_actor { obs } else { critic_obs }
}

/// An error naming the env (and, for rows wider than 1, the entry and what `source` says
/// wrote it) of the first non-finite value in `values` (`[num_envs × dim]`): the env made it,
/// not the learner.
fn check_finite(
    what: &str,
    values: &[f32],
    dim: usize,
    source: impl Fn(usize) -> Option<String>,
) -> Result<(), RlError> {
    let Some(i) = orbit_core::parallel::first_non_finite(values) else {
        return Ok(());
    };
    let entry = if dim > 1 {
        format!(" {}", i % dim)
    } else {
        String::new()
    };
    let from = source(i % dim).map_or(String::new(), |s| format!(", from the {s}"));
    Err(RlError::NonFinite(format!(
        "env {}'s {what}{entry} is {}{from}: the env produced it before the learner saw it; \
         check that term's inputs, scale and clip, and the physics",
        i / dim,
        values[i]
    )))
}
