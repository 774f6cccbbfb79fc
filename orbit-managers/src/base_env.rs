//! `ManagerBasedEnv`: a scene driven by action, observation, event and command managers, with no
//! notion of reward or episode end (Isaac Lab `ManagerBasedEnv`, for scripted control,
//! teleoperation or data collection). [`crate::ManagerBasedRlEnv`] builds on it.
//!
//! `step(action)`: process actions → `decimation` × (apply actions, physics step) → step
//! counters += 1 → command timers → interval events → observations.

use std::collections::BTreeMap;
use std::time::{Duration, Instant};

use orbit_core::config::Node;
use orbit_core::physics::{StateSnapshot, build_backend};
use orbit_core::rng::{EnvRng, streams};

use crate::cfg::{EnvCfg, EventMode};
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

    /// Every env's stream, in env order (for loops over envs in parallel).
    pub fn streams_mut(&mut self) -> &mut [EnvRng] {
        &mut self.rngs
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
    /// Steps taken in each env's episode (since its last reset).
    pub episode_length: &'a [u32],
    /// Episode length in steps (`u32::MAX` for a base env, whose episodes do not end).
    pub max_episode_length: u32,
    /// Env step duration.
    pub step_dt: f32,
    /// Env steps since construction.
    pub common_step_counter: u64,
    /// Per env, whether this step's termination terms (not time-outs) ended its episode; empty
    /// before the terminations are computed (reward terms see them, as in Isaac Lab).
    pub terminated: &'a [bool],
}

/// The terms' view of a base env, borrowing only the fields it names (so a manager of the RL env
/// can be borrowed mutably at the same time).
macro_rules! view {
    ($env:expr) => {
        view!($env, &[])
    };
    ($env:expr, $terminated:expr) => {
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
            terminated: $terminated,
        }
    };
}
pub(crate) use view;

/// Wall-clock time spent in each phase of `step`, summed since construction or the last
/// [`StepTimings::clear`] (for benchmarks: the managers' cost against the physics).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct StepTimings {
    /// Env steps measured.
    pub steps: u64,
    /// Action processing and per-substep application.
    pub actions: Duration,
    /// Physics substeps (`backend.step`).
    pub physics: Duration,
    /// Termination terms.
    pub terminations: Duration,
    /// Reward terms.
    pub rewards: Duration,
    /// Resets of finished envs (curriculum, reset events, logs, command resampling).
    pub resets: Duration,
    /// Command timers and resampling.
    pub commands: Duration,
    /// Interval events.
    pub events: Duration,
    /// Observation terms, noise and history.
    pub observations: Duration,
}

impl StepTimings {
    /// Everything but the physics.
    pub fn managers(&self) -> Duration {
        self.actions
            + self.terminations
            + self.rewards
            + self.resets
            + self.commands
            + self.events
            + self.observations
    }

    /// The time spent in each phase (and the steps taken) between `earlier`, a reading of the
    /// same env, and this one.
    pub fn since(&self, earlier: &StepTimings) -> StepTimings {
        StepTimings {
            steps: self.steps.saturating_sub(earlier.steps),
            actions: self.actions.saturating_sub(earlier.actions),
            physics: self.physics.saturating_sub(earlier.physics),
            terminations: self.terminations.saturating_sub(earlier.terminations),
            rewards: self.rewards.saturating_sub(earlier.rewards),
            resets: self.resets.saturating_sub(earlier.resets),
            commands: self.commands.saturating_sub(earlier.commands),
            events: self.events.saturating_sub(earlier.events),
            observations: self.observations.saturating_sub(earlier.observations),
        }
    }

    /// Phases by name, in step order.
    pub fn phases(&self) -> [(&'static str, Duration); 8] {
        [
            ("actions", self.actions),
            ("physics", self.physics),
            ("terminations", self.terminations),
            ("rewards", self.rewards),
            ("resets", self.resets),
            ("commands", self.commands),
            ("events", self.events),
            ("observations", self.observations),
        ]
    }

    /// Resets every sum to zero.
    pub fn clear(&mut self) {
        *self = Self::default();
    }
}

/// Adds the time since `*since` to `slot` and restarts the clock.
pub(crate) fn lap(slot: &mut Duration, since: &mut Instant) {
    let now = Instant::now();
    *slot += now - *since;
    *since = now;
}

/// A manager-based environment over a batch of envs (no rewards, terminations or time-outs).
pub struct ManagerBasedEnv {
    /// The config it was built from.
    pub cfg: EnvCfg,
    /// The scene.
    pub scene: Scene,
    pub(crate) actions: ActionManager,
    pub(crate) observations: ObservationManager,
    pub(crate) events: EventManager,
    pub(crate) commands: CommandManager,
    pub(crate) episode_length: Vec<u32>,
    pub(crate) max_episode_length: u32,
    pub(crate) common_step_counter: u64,
    pub(crate) step_dt: f32,
    pub(crate) timings: StepTimings,
    pub(crate) event_rngs: EnvRngs,
    pub(crate) command_rngs: EnvRngs,
    noise_rngs: EnvRngs,
    interval_rngs: EnvRngs,
    /// Every env's state before the current step, when `sim.keep_pre_step_state` asks.
    pre_step: Option<StateSnapshot>,
}

/// Where the value at `field` of `doc` was written (`file:line:col`, or the override), or the
/// nearest enclosing value that was written.
fn written_at(doc: &Node, field: &str) -> String {
    let mut path = field;
    loop {
        if let Some(node) = orbit_core::config::node_at(doc, path) {
            return node.span.location();
        }
        match path.rfind(['.', '[']) {
            Some(cut) => path = &path[..cut],
            None => return doc.span.location(),
        }
    }
}

impl ManagerBasedEnv {
    /// Builds the env from a config document (see [`EnvCfg`]).
    pub fn from_document(doc: &Node) -> Result<Self, EnvError> {
        let doc = &orbit_assets::compose_env_scene(doc)?;
        let cfg: EnvCfg = orbit_core::config::from_node(doc)?;
        crate::ranges::check_env_cfg(doc, &cfg)?;
        let mut env = Self::build(doc, cfg, u32::MAX)?;
        env.apply_startup_events()?;
        Ok(env)
    }

    /// Builds the env from RON text with overrides.
    pub fn from_ron(text: &str, file_name: &str, overrides: &[String]) -> Result<Self, EnvError> {
        let doc = orbit_core::config::parse_document(text, file_name, overrides)?;
        Self::from_document(&doc)
    }

    /// Builds scene and managers in Isaac Lab's order (command, action, observation, event);
    /// startup events are left to the caller, which may add managers first. The caller has
    /// checked the config's ranges (`ranges::check_env_cfg`).
    pub(crate) fn build(
        doc: &Node,
        cfg: EnvCfg,
        max_episode_length: u32,
    ) -> Result<Self, EnvError> {
        let file = doc.span.file.display().to_string();
        let desc = orbit_assets::resolve_scene(&cfg.scene, &file, None).map_err(|e| match e {
            // Blame the file (an include, an override) and line that wrote the field, the
            // nearest enclosing one where the field is a default.
            orbit_assets::AssetError::Scene { source, .. } => orbit_assets::AssetError::Scene {
                file: written_at(doc, source.field()),
                source,
            },
            other => other,
        })?;
        let backend = build_backend(&desc, cfg.num_envs, &cfg.sim)?;
        let scene = Scene::new(backend, desc);
        let n = scene.num_envs();
        let commands = CommandManager::new(doc, &scene, &cfg)?;
        let actions = ActionManager::new(doc, &scene, &cfg)?;
        let observations = ObservationManager::new(doc, &scene, &cfg, &actions, &commands)?;
        let events = EventManager::new(doc, &scene, &cfg)?;
        let seed = cfg.seed;
        Ok(Self {
            scene,
            actions,
            observations,
            events,
            commands,
            episode_length: vec![0; n],
            max_episode_length,
            common_step_counter: 0,
            step_dt: cfg.sim.dt * cfg.decimation as f32,
            timings: StepTimings::default(),
            event_rngs: EnvRngs::new(seed, n, streams::RESET),
            command_rngs: EnvRngs::new(seed, n, streams::COMMAND),
            noise_rngs: EnvRngs::new(seed, n, streams::NOISE),
            interval_rngs: EnvRngs::new(seed, n, streams::INTERVAL),
            pre_step: cfg.sim.keep_pre_step_state.then(StateSnapshot::default),
            cfg,
        })
    }

    /// Applies startup events to every env and draws the first interval-event times.
    pub(crate) fn apply_startup_events(&mut self) -> Result<(), EnvError> {
        let n = self.num_envs();
        let all: Vec<usize> = (0..n).collect();
        let mut startup = EnvRngs::new(self.cfg.seed, n, streams::STARTUP);
        self.events
            .apply(EventMode::Startup, &mut self.scene, &all, &mut startup)?;
        self.events.init_intervals(&mut self.interval_rngs);
        Ok(())
    }

    /// The scene.
    pub fn scene(&self) -> &Scene {
        &self.scene
    }

    /// Number of envs.
    pub fn num_envs(&self) -> usize {
        self.scene.num_envs()
    }

    /// Total action dimension.
    pub fn action_dim(&self) -> usize {
        self.actions.dim()
    }

    /// Env step duration in seconds.
    pub fn step_dt(&self) -> f32 {
        self.step_dt
    }

    /// Steps taken in each env since its last reset.
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

    /// The term of observation group `group` that writes value `index` of a row, as
    /// `<term>[k]`.
    pub fn observation_term_at(&self, group: &str, index: usize) -> Option<String> {
        let g = self.observations.groups.iter().find(|g| g.name == group)?;
        g.term_at(index)
    }

    /// The command manager.
    pub fn commands(&self) -> &CommandManager {
        &self.commands
    }

    /// The action manager.
    pub fn actions(&self) -> &ActionManager {
        &self.actions
    }

    /// Time spent per step phase since construction or the last `timings_mut().clear()`.
    pub fn timings(&self) -> &StepTimings {
        &self.timings
    }

    /// Mutable access to the phase timings (to clear them after a warm-up).
    pub fn timings_mut(&mut self) -> &mut StepTimings {
        &mut self.timings
    }

    /// Resets every env and computes the first observations.
    pub fn reset(&mut self) -> Result<(), EnvError> {
        let all: Vec<usize> = (0..self.num_envs()).collect();
        self.reset_idx(&all)?;
        self.compute_observations();
        Ok(())
    }

    /// Resets the listed envs: reset events, observation histories, actions, commands and step
    /// counters (a base env keeps no episode log).
    pub fn reset_idx(&mut self, env_ids: &[usize]) -> Result<(), EnvError> {
        orbit_core::physics::check_env_ids(env_ids, self.num_envs())?;
        self.reset_managers(env_ids)?;
        Ok(())
    }

    /// The reset of the listed (already checked) envs: `Reset` events, the observation, action
    /// and command managers, step counters; returns the managers' episode log (command metrics).
    pub(crate) fn reset_managers(
        &mut self,
        env_ids: &[usize],
    ) -> Result<BTreeMap<String, f32>, EnvError> {
        self.events.apply(
            EventMode::Reset,
            &mut self.scene,
            env_ids,
            &mut self.event_rngs,
        )?;
        let mut ctx = ResetContext {
            scene: &self.scene,
            command_rngs: &mut self.command_rngs,
            episode_length_s: f32::INFINITY,
        };
        let mut log = BTreeMap::new();
        for manager in [
            &mut self.observations as &mut dyn Manager,
            &mut self.actions,
            &mut self.commands,
        ] {
            log.extend(manager.reset(env_ids, &mut ctx));
        }
        for &e in env_ids {
            self.episode_length[e] = 0;
        }
        Ok(log)
    }

    /// Advances every env by one env step; read the result with [`Self::observation`].
    pub fn step(&mut self, action: &[f32]) -> Result<(), EnvError> {
        let mut clock = Instant::now();
        self.simulate(action, &mut clock)?;
        self.finish_step(&mut clock)
    }

    /// First half of a step: actions, the decimation loop (one fused call when the actions
    /// allow it), counters.
    pub(crate) fn simulate(&mut self, action: &[f32], clock: &mut Instant) -> Result<(), EnvError> {
        if let Some(snapshot) = &mut self.pre_step {
            snapshot.capture(self.scene.backend.as_ref());
        }
        self.actions.process(&self.scene, action)?;
        lap(&mut self.timings.actions, clock);
        if self.actions.substep_invariant() {
            // Inputs fixed for the whole env step: one call, which a GPU backend fuses.
            self.actions.apply(&mut self.scene)?;
            lap(&mut self.timings.actions, clock);
            self.scene.backend.step_n(self.cfg.decimation)?;
            self.scene.backend.sync();
            lap(&mut self.timings.physics, clock);
        } else {
            for _ in 0..self.cfg.decimation {
                self.actions.apply(&mut self.scene)?;
                lap(&mut self.timings.actions, clock);
                self.scene.backend.step()?;
                self.scene.backend.sync();
                lap(&mut self.timings.physics, clock);
            }
        }
        self.common_step_counter += 1;
        if let Some(instability) = orbit_core::physics::check_state(self.scene.backend.as_ref()) {
            let backend = self.scene.backend.as_ref();
            let e = instability.env;
            tracing::error!("{}", orbit_core::physics::describe_env_state(backend, e));
            if let Some(snapshot) = &self.pre_step {
                let d = self.actions.dim();
                let failed = crate::FailedStep {
                    step: self.common_step_counter,
                    env: e,
                    action: action[e * d..(e + 1) * d].to_vec(),
                    state: snapshot.env_state(backend, e),
                };
                tracing::error!(
                    "env {e} before the failing step (replay it with the `replay_step` \
                     example): {}",
                    failed.to_ron()
                );
            }
            return Err(EnvError::Unstable {
                step: self.common_step_counter,
                substeps: self.cfg.decimation,
                dt: self.cfg.sim.dt,
                solver_iterations: self.cfg.sim.solver_iterations,
                instability,
            });
        }
        for l in &mut self.episode_length {
            *l += 1;
        }
        self.timings.steps += 1;
        Ok(())
    }

    /// Last part of a step: command timers, interval events, observations.
    pub(crate) fn finish_step(&mut self, clock: &mut Instant) -> Result<(), EnvError> {
        self.commands
            .compute(&self.scene, self.step_dt, &mut self.command_rngs);
        lap(&mut self.timings.commands, clock);
        self.events
            .apply_interval(&mut self.scene, self.step_dt, &mut self.interval_rngs)?;
        lap(&mut self.timings.events, clock);
        self.compute_observations();
        lap(&mut self.timings.observations, clock);
        Ok(())
    }

    pub(crate) fn compute_observations(&mut self) {
        let view = view!(self);
        self.observations.compute(&view, &mut self.noise_rngs);
    }

    /// Every observation group's values of the listed envs as their episodes leave them,
    /// into their rows of `out` (a buffer per group, in group order; see
    /// [`ObservationManager::compute_final`]).
    pub(crate) fn compute_final_observations(&mut self, env_ids: &[usize], out: &mut [Vec<f32>]) {
        let view = view!(self);
        self.observations.compute_final(&view, env_ids, out);
    }

    /// The index of observation group `name` and its width.
    pub(crate) fn observation_group(&self, name: &str) -> Option<(usize, usize)> {
        let mut groups = self.observations.groups.iter().enumerate();
        groups
            .find(|(_, g)| g.name == name)
            .map(|(i, g)| (i, g.dim))
    }

    /// A zeroed buffer per observation group, `num_envs × dim` each.
    pub(crate) fn observation_buffers(&self) -> Vec<Vec<f32>> {
        let n = self.num_envs();
        let groups = &self.observations.groups;
        groups.iter().map(|g| vec![0.0; n * g.dim]).collect()
    }
}
