//! `ManagerBasedRlEnv`: Isaac Lab's construction, step and reset order over a
//! [`ManagerBasedEnv`], kept as a tested contract (see `tests/step_order.rs`).
//!
//! `step(action)`: process actions → `decimation` × (apply actions, physics step) → episode
//! counters += 1 → terminations → rewards (× `step_dt`, on the terminal state) → command
//! metrics on the terminal state → reset of finished envs (curriculum, reset events, logs,
//! command resampling) → command timers → interval events → observations (a reset env's
//! observation belongs to its new episode).

use std::collections::BTreeMap;
use std::ops::Deref;
use std::time::Instant;

use orbit_core::config::Node;

use crate::base_env::{EnvView, ManagerBasedEnv, StepTimings, lap, view};
use crate::cfg::RlEnvCfg;
use crate::error::EnvError;
use crate::managers::*;
use crate::scene::Scene;

/// Extra information of the last step.
#[derive(Clone, Debug, Default)]
pub struct Extras {
    /// Per-term episode statistics of the envs reset in the last step (Isaac Lab's
    /// `extras["log"]`): `Episode Reward/<term>` (mean episodic sum / episode seconds),
    /// `Episode Termination/<term>` (count), `Metrics/<command>/<metric>`, `Curriculum/<term>`.
    pub log: BTreeMap<String, f32>,
}

/// Called at the end of every [`ManagerBasedRlEnv::step`], with the env as the step left it
/// (finished envs already reset): e.g. a video recorder, like the `RecordVideo` wrapper Isaac
/// Lab puts around its envs. A black-box env's inner steps are env steps too, so it sees them.
pub trait StepObserver: Send {
    /// Looks at the env after a step.
    fn after_step(&mut self, env: &ManagerBasedRlEnv) -> Result<(), EnvError>;
}

/// A manager-based RL environment over a batch of envs.
pub struct ManagerBasedRlEnv {
    /// The config it was built from.
    pub cfg: RlEnvCfg,
    base: ManagerBasedEnv,
    rewards: RewardManager,
    terminations: TerminationManager,
    curriculum: CurriculumManager,
    reward: Vec<f32>,
    terminated: Vec<bool>,
    time_outs: Vec<bool>,
    reset_ids: Vec<usize>,
    extras: Extras,
    observer: Option<Box<dyn StepObserver>>,
    /// Each group's last observations of the episodes that ended, when kept.
    final_obs: Option<Vec<Vec<f32>>>,
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

/// An RL env is its base env plus rewards, terminations and curricula (Isaac Lab's
/// `ManagerBasedRLEnv` subclasses `ManagerBasedEnv`), so the base's accessors (`scene`,
/// `num_envs`, `action_dim`, `step_dt`, `episode_length`, `observation`, `commands`, `actions`,
/// `timings`) work on it too. There is no `DerefMut`: the base's `step`, `reset` and `reset_idx`
/// would skip rewards, terminations and logs, so mutable access goes through
/// [`ManagerBasedRlEnv::scene_mut`] and [`ManagerBasedRlEnv::timings_mut`].
impl Deref for ManagerBasedRlEnv {
    type Target = ManagerBasedEnv;

    fn deref(&self) -> &ManagerBasedEnv {
        &self.base
    }
}

impl ManagerBasedRlEnv {
    /// Builds the env from a config document (see [`RlEnvCfg`]).
    pub fn from_document(doc: &Node) -> Result<Self, EnvError> {
        let doc = &orbit_assets::compose_env_scene(doc)?;
        let cfg: RlEnvCfg = orbit_core::config::from_node(doc)?;
        crate::ranges::check_env_cfg(doc, &cfg.base)?;
        let step_dt = cfg.base.sim.dt * cfg.base.decimation as f32;
        crate::ranges::check_episode_length(doc, cfg.episode_length_s, step_dt)?;
        let max_episode_length = (cfg.episode_length_s / step_dt - 1e-4).ceil() as u32;
        // Isaac Lab's order: command, action, observation, event (the base env), then
        // termination, reward, curriculum; startup events once every manager exists.
        let base = ManagerBasedEnv::build(doc, cfg.base.clone(), max_episode_length)?;
        let (scene, actions, commands) = (&base.scene, &base.actions, &base.commands);
        let terminations =
            TerminationManager::new(doc, scene, &base.cfg, &cfg.terminations, actions, commands)?;
        let rewards = RewardManager::new(doc, scene, &base.cfg, &cfg.rewards, actions, commands)?;
        let curriculum = CurriculumManager::new(doc, scene, &base.cfg, &cfg.curriculum)?;
        let n = base.num_envs();
        let mut env = Self {
            cfg,
            base,
            rewards,
            terminations,
            curriculum,
            reward: vec![0.0; n],
            terminated: vec![false; n],
            time_outs: vec![false; n],
            reset_ids: Vec::with_capacity(n),
            extras: Extras::default(),
            observer: None,
            final_obs: None,
        };
        env.base.apply_startup_events()?;
        Ok(env)
    }

    /// Builds the env from RON text (e.g. a bundled task config) with overrides.
    pub fn from_ron(text: &str, file_name: &str, overrides: &[String]) -> Result<Self, EnvError> {
        let doc = orbit_core::config::parse_document(text, file_name, overrides)?;
        Self::from_document(&doc)
    }

    /// The base env (scene, actions, observations, events, commands).
    pub fn base(&self) -> &ManagerBasedEnv {
        &self.base
    }

    /// The scene, mutably (for scripted state changes between steps).
    pub fn scene_mut(&mut self) -> &mut Scene {
        &mut self.base.scene
    }

    /// Episode length in env steps.
    pub fn max_episode_length(&self) -> u32 {
        self.base.max_episode_length
    }

    /// Sets the step counters of the running episodes, e.g. to random values so that
    /// time-outs spread out (RSL-RL's `init_at_random_ep_len`). Every value must be below
    /// [`max_episode_length`](Self::max_episode_length); on error nothing changes.
    pub fn set_episode_length(&mut self, lengths: &[u32]) -> Result<(), EnvError> {
        let max = self.base.max_episode_length;
        if lengths.len() != self.num_envs() || lengths.iter().any(|&l| l >= max) {
            return Err(EnvError::InvalidState(format!(
                "episode lengths: expected {} values below the maximum episode length {max}",
                self.num_envs()
            )));
        }
        self.base.episode_length.copy_from_slice(lengths);
        Ok(())
    }

    /// Installs (or, with `None`, removes) the observer called after every step; returns the
    /// previous one.
    pub fn set_step_observer(
        &mut self,
        observer: Option<Box<dyn StepObserver>>,
    ) -> Option<Box<dyn StepObserver>> {
        std::mem::replace(&mut self.observer, observer)
    }

    /// What rendered frames of env `env` should show besides the scene: every command term's
    /// debug markers (e.g. the target pose).
    pub fn debug_markers(&self, env: usize) -> Vec<orbit_core::scene::Marker> {
        let mut out = Vec::new();
        self.base
            .commands
            .debug_markers(&self.base.scene, env, &mut out);
        out
    }

    /// Mutable access to the phase timings (to clear them after a warm-up).
    pub fn timings_mut(&mut self) -> &mut StepTimings {
        &mut self.base.timings
    }

    /// Every reward term's unweighted per-env value on the current state (without `step_dt`),
    /// in config order: for inspecting a reward and testing terms on prepared states.
    pub fn evaluate_reward_terms(&mut self) -> Vec<(String, Vec<f32>)> {
        let base = &self.base;
        let view = view!(base);
        self.rewards.evaluate_terms(&view)
    }

    /// Resets every env and computes the first observations.
    pub fn reset(&mut self) -> Result<(), EnvError> {
        let all: Vec<usize> = (0..self.num_envs()).collect();
        self.reset_envs(&all)
    }

    /// Resets the listed envs between steps and computes the observations (a partial reset
    /// from outside a step, as gymnasium's `reset_mask` asks).
    pub fn reset_envs(&mut self, env_ids: &[usize]) -> Result<(), EnvError> {
        self.reset_idx(env_ids)?;
        self.base.compute_observations();
        Ok(())
    }

    /// Resets the listed envs (Isaac Lab `_reset_idx`): curriculum, reset events, observation
    /// histories, actions, commands, episode counters, then the logs of rewards, terminations
    /// and curriculum (with the commands' metrics, they replace `extras.log`).
    pub fn reset_idx(&mut self, env_ids: &[usize]) -> Result<(), EnvError> {
        orbit_core::physics::check_env_ids(env_ids, self.num_envs())?;
        self.curriculum
            .compute(env_ids, self.base.common_step_counter, &mut self.rewards)?;
        let mut log = self.base.reset_managers(env_ids)?;
        let mut ctx = ResetContext {
            scene: &self.base.scene,
            command_rngs: &mut self.base.command_rngs,
            episode_length_s: self.cfg.episode_length_s,
        };
        for manager in [
            &mut self.rewards as &mut dyn Manager,
            &mut self.terminations,
            &mut self.curriculum,
        ] {
            log.extend(manager.reset(env_ids, &mut ctx));
        }
        self.extras.log = log;
        Ok(())
    }

    /// Keeps, from the next step on, the last observations of each episode that ends (see
    /// [`Self::final_observation`]), or stops keeping them. Off by default: it costs an
    /// observation pass on every step in which an episode ends.
    pub fn keep_final_observations(&mut self, keep: bool) {
        self.final_obs = keep.then(|| self.base.observation_buffers());
    }

    /// The observation group `name` as the episodes that ended in the last step left it,
    /// before their reset (what [`Self::observation`] returns for them is their new episode's
    /// first): `(values num_envs × dim, dim)`, where only the rows of envs that were
    /// terminated or timed out in the last step are that step's. The terms' clip and scale
    /// apply, their noise does not. `None` unless [`Self::keep_final_observations`] is on or
    /// for an unknown group.
    pub fn final_observation(&self, name: &str) -> Option<(&[f32], usize)> {
        let (group, dim) = self.base.observation_group(name)?;
        Some((self.final_obs.as_ref()?[group].as_slice(), dim))
    }

    /// Advances every env by one env step (see the module docs for the order).
    pub fn step(&mut self, action: &[f32]) -> Result<StepResult<'_>, EnvError> {
        let mut clock = Instant::now();
        self.base.simulate(action, &mut clock)?;
        {
            let base = &self.base;
            let view = view!(base);
            self.terminations
                .compute(&view, &mut self.terminated, &mut self.time_outs);
            lap(&mut self.base.timings.terminations, &mut clock);
        }
        {
            let base = &self.base;
            let view = view!(base, &self.terminated);
            self.rewards.compute(&view, base.step_dt, &mut self.reward);
        }
        lap(&mut self.base.timings.rewards, &mut clock);
        self.base.commands.update_metrics(&self.base.scene);
        let (terminated, time_outs) = (&self.terminated, &self.time_outs);
        self.reset_ids.clear();
        self.reset_ids
            .extend((0..terminated.len()).filter(|&e| terminated[e] || time_outs[e]));
        if !self.reset_ids.is_empty() {
            let ids = std::mem::take(&mut self.reset_ids);
            if let Some(out) = &mut self.final_obs {
                self.base.compute_final_observations(&ids, out);
            }
            let result = self.reset_idx(&ids);
            self.reset_ids = ids;
            result?;
        }
        lap(&mut self.base.timings.resets, &mut clock);
        self.base.finish_step(&mut clock)?;
        if let Some(mut observer) = self.observer.take() {
            let result = observer.after_step(self);
            self.observer = Some(observer);
            result?;
        }
        Ok(StepResult {
            reward: &self.reward,
            terminated: &self.terminated,
            time_outs: &self.time_outs,
            extras: &self.extras,
        })
    }
}
