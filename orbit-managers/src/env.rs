//! `ManagerBasedRlEnv`: Isaac Lab's construction, step and reset order, kept as a tested
//! contract (see `tests/step_order.rs`).
//!
//! `step(action)`: process actions → `decimation` × (apply actions, physics step) → episode
//! counters += 1 → terminations → rewards (× `step_dt`, on the terminal state) → reset of
//! command metrics on the terminal state → reset of finished envs (reset events, logs, command
//! resampling) → command timers → interval events →
//! observations (a reset env's observation belongs to its new episode).

use std::collections::BTreeMap;

use orbit_core::config::Node;
use orbit_core::physics::build_backend;
use orbit_core::rng::{EnvRng, streams};

use crate::cfg::{EventMode, RlEnvCfg};
use crate::error::EnvError;
use crate::managers::*;
use crate::scene::Scene;

/// Per-env random streams of one consumer (`stream` id), keyed by `(seed, env, stream)`.
pub struct EnvRngs {
    rngs: Vec<EnvRng>,
}

impl EnvRngs {
    /// Streams of `num_envs` envs.
    pub fn new(seed: u64, num_envs: usize, stream: u32) -> Self {
        Self {
            rngs: (0..num_envs as u32)
                .map(|e| EnvRng::new(seed, e, stream))
                .collect(),
        }
    }

    /// The stream of env `e`.
    pub fn get(&mut self, e: usize) -> &mut EnvRng {
        &mut self.rngs[e]
    }
}

/// What terms read: the scene and the managers' public state.
pub struct EnvView<'a> {
    /// The scene (backend state and defaults).
    pub scene: &'a Scene,
    /// Current policy actions, `num_envs × action_dim`.
    pub action: &'a [f32],
    /// Previous policy actions.
    pub prev_action: &'a [f32],
    /// Action dimension.
    pub action_dim: usize,
    /// The action manager (processed actions by term).
    pub actions: &'a ActionManager,
    /// The command manager.
    pub commands: &'a CommandManager,
    /// Steps taken in each env's episode.
    pub episode_length: &'a [u32],
    /// Episode length in steps.
    pub max_episode_length: u32,
    /// Env step duration.
    pub step_dt: f32,
    /// Env steps since construction.
    pub common_step_counter: u64,
}

/// The terms' view of an env, borrowing only the fields it names (so the manager being run can
/// be borrowed mutably at the same time).
macro_rules! view {
    ($env:expr) => {
        EnvView {
            scene: &$env.scene,
            action: &$env.actions.action,
            prev_action: &$env.actions.prev_action,
            action_dim: $env.actions.dim,
            actions: &$env.actions,
            commands: &$env.commands,
            episode_length: &$env.episode_length,
            max_episode_length: $env.max_episode_length,
            step_dt: $env.step_dt,
            common_step_counter: $env.common_step_counter,
        }
    };
}

/// Extra information of the last step.
#[derive(Clone, Debug, Default)]
pub struct Extras {
    /// Per-term episode statistics of the envs reset in the last step (Isaac Lab's
    /// `extras["log"]`): `Episode Reward/<term>` (mean episodic sum / episode seconds),
    /// `Episode Termination/<term>` (count).
    pub log: BTreeMap<String, f32>,
}

/// A manager-based RL environment over a batch of envs.
pub struct ManagerBasedRlEnv {
    /// The config it was built from.
    pub cfg: RlEnvCfg,
    /// The scene.
    pub scene: Scene,
    actions: ActionManager,
    observations: ObservationManager,
    rewards: RewardManager,
    terminations: TerminationManager,
    events: EventManager,
    commands: CommandManager,
    curriculum: CurriculumManager,
    episode_length: Vec<u32>,
    max_episode_length: u32,
    common_step_counter: u64,
    step_dt: f32,
    reward: Vec<f32>,
    terminated: Vec<bool>,
    time_outs: Vec<bool>,
    reset_ids: Vec<usize>,
    extras: Extras,
    event_rngs: EnvRngs,
    command_rngs: EnvRngs,
    noise_rngs: EnvRngs,
    interval_rngs: EnvRngs,
}

/// The result of a step: views into the env's buffers.
pub struct StepResult<'a> {
    /// Rewards, one per env.
    pub reward: &'a [f32],
    /// Terminated (not time-out), one per env.
    pub terminated: &'a [bool],
    /// Truncated by a time-out, one per env.
    pub time_outs: &'a [bool],
    /// Extras.
    pub extras: &'a Extras,
}

impl ManagerBasedRlEnv {
    /// Builds the env from a config document (see `crate::cfg::RlEnvCfg`).
    pub fn from_document(doc: &Node) -> Result<Self, EnvError> {
        let cfg: RlEnvCfg = orbit_core::config::from_node(doc)?;
        if cfg.decimation == 0 {
            return Err(EnvError::InvalidTerm {
                field: "decimation".into(),
                message: "expected at least 1 physics step per env step".into(),
            });
        }
        if !(cfg.episode_length_s.is_finite() && cfg.episode_length_s > 0.0) {
            return Err(EnvError::InvalidTerm {
                field: "episode_length_s".into(),
                message: format!("expected a positive duration, got {}", cfg.episode_length_s),
            });
        }
        let desc = orbit_assets::bundled_scene(&cfg.scene.bundled, &cfg.scene.overrides)?;
        let backend = build_backend(&desc, cfg.num_envs, &cfg.sim)?;
        let scene = Scene::new(backend, desc);
        let n = scene.num_envs();
        let step_dt = cfg.sim.dt * cfg.decimation as f32;
        let max_episode_length = (cfg.episode_length_s / step_dt - 1e-4).ceil() as u32;
        // Manager construction order as in Isaac Lab: command, action, observation, event,
        // termination, reward.
        let commands = CommandManager::new(doc, &scene, &cfg)?;
        let actions = ActionManager::new(doc, &scene, &cfg)?;
        let observations = ObservationManager::new(doc, &scene, &cfg, &actions, &commands)?;
        let events = EventManager::new(doc, &scene, &cfg)?;
        let terminations = TerminationManager::new(doc, &scene, &cfg, &actions, &commands)?;
        let rewards = RewardManager::new(doc, &scene, &cfg, &actions, &commands)?;
        let curriculum = CurriculumManager::new(doc, &scene, &cfg)?;
        let seed = cfg.seed;
        let mut env = Self {
            scene,
            actions,
            observations,
            rewards,
            terminations,
            events,
            commands,
            curriculum,
            episode_length: vec![0; n],
            max_episode_length,
            common_step_counter: 0,
            step_dt,
            reward: vec![0.0; n],
            terminated: vec![false; n],
            time_outs: vec![false; n],
            reset_ids: Vec::with_capacity(n),
            extras: Extras::default(),
            event_rngs: EnvRngs::new(seed, n, streams::RESET),
            command_rngs: EnvRngs::new(seed, n, streams::COMMAND),
            noise_rngs: EnvRngs::new(seed, n, streams::NOISE),
            interval_rngs: EnvRngs::new(seed, n, streams::INTERVAL),
            cfg,
        };
        let all: Vec<usize> = (0..n).collect();
        let mut startup = EnvRngs::new(seed, n, streams::STARTUP);
        env.events
            .apply(EventMode::Startup, &mut env.scene, &all, &mut startup)?;
        env.events.init_intervals(&mut env.interval_rngs);
        Ok(env)
    }

    /// Builds the env from RON text (e.g. a bundled task config) with overrides.
    pub fn from_ron(text: &str, file_name: &str, overrides: &[String]) -> Result<Self, EnvError> {
        let doc = orbit_core::config::parse_document(text, file_name, overrides)?;
        Self::from_document(&doc)
    }

    /// Number of envs.
    pub fn num_envs(&self) -> usize {
        self.scene.num_envs()
    }

    /// Total action dimension.
    pub fn action_dim(&self) -> usize {
        self.actions.dim()
    }

    /// Episode length in env steps.
    pub fn max_episode_length(&self) -> u32 {
        self.max_episode_length
    }

    /// Env step duration in seconds.
    pub fn step_dt(&self) -> f32 {
        self.step_dt
    }

    /// Steps taken in each env's current episode.
    pub fn episode_length(&self) -> &[u32] {
        &self.episode_length
    }

    /// The observation group `name`: `(values num_envs × dim, dim)`.
    pub fn observation(&self, name: &str) -> Option<(&[f32], usize)> {
        self.observations
            .groups
            .iter()
            .find(|g| g.name == name)
            .map(|g| (g.values.as_slice(), g.dim))
    }

    /// The command manager.
    pub fn commands(&self) -> &CommandManager {
        &self.commands
    }

    /// The action manager.
    pub fn actions(&self) -> &ActionManager {
        &self.actions
    }

    fn compute_observations(&mut self) {
        let view = view!(self);
        self.observations.compute(&view, &mut self.noise_rngs);
    }

    /// Resets every env and computes the first observations.
    pub fn reset(&mut self) -> Result<(), EnvError> {
        let all: Vec<usize> = (0..self.num_envs()).collect();
        self.reset_idx(&all)?;
        self.compute_observations();
        Ok(())
    }

    /// Resets the listed envs (Isaac Lab `_reset_idx`): curriculum, reset events, observation
    /// histories, logs (rewards, commands, terminations), episode counters.
    pub fn reset_idx(&mut self, env_ids: &[usize]) -> Result<(), EnvError> {
        orbit_core::physics::check_env_ids(env_ids, self.num_envs())?;
        let mut log = BTreeMap::new();
        self.curriculum.compute(
            env_ids,
            self.common_step_counter,
            &mut self.rewards,
            &mut log,
        )?;
        self.events.apply(
            EventMode::Reset,
            &mut self.scene,
            env_ids,
            &mut self.event_rngs,
        )?;
        self.observations.reset(env_ids);
        self.actions.reset(env_ids);
        self.rewards
            .reset(env_ids, self.cfg.episode_length_s, &mut log);
        self.commands
            .reset(&self.scene, env_ids, &mut self.command_rngs, &mut log);
        self.terminations.reset(env_ids, &mut log);
        self.extras.log = log;
        for &e in env_ids {
            self.episode_length[e] = 0;
        }
        Ok(())
    }

    /// Advances every env by one env step (see the module docs for the order).
    pub fn step(&mut self, action: &[f32]) -> Result<StepResult<'_>, EnvError> {
        self.actions.process(&self.scene, action)?;
        for _ in 0..self.cfg.decimation {
            self.actions.apply(&mut self.scene)?;
            self.scene.backend.step()?;
        }
        for l in &mut self.episode_length {
            *l += 1;
        }
        self.common_step_counter += 1;
        let mut terminated = std::mem::take(&mut self.terminated);
        let mut time_outs = std::mem::take(&mut self.time_outs);
        let mut reward = std::mem::take(&mut self.reward);
        {
            let view = view!(self);
            self.terminations
                .compute(&view, &mut terminated, &mut time_outs);
            self.rewards.compute(&view, self.step_dt, &mut reward);
        }
        self.terminated = terminated;
        self.time_outs = time_outs;
        self.reward = reward;
        self.commands.update_metrics(&self.scene);
        self.reset_ids.clear();
        self.reset_ids
            .extend((0..self.num_envs()).filter(|&e| self.terminated[e] || self.time_outs[e]));
        if !self.reset_ids.is_empty() {
            let ids = std::mem::take(&mut self.reset_ids);
            let result = self.reset_idx(&ids);
            self.reset_ids = ids;
            result?;
        }
        self.commands
            .compute(&self.scene, self.step_dt, &mut self.command_rngs);
        self.events
            .apply_interval(&mut self.scene, self.step_dt, &mut self.interval_rngs)?;
        self.compute_observations();
        Ok(StepResult {
            reward: &self.reward,
            terminated: &self.terminated,
            time_outs: &self.time_outs,
            extras: &self.extras,
        })
    }
}
