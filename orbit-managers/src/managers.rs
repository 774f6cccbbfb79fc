//! The managers: each owns its terms (built from the config in order) and their buffers.

use std::collections::BTreeMap;

use orbit_core::config::{Node, node_at};
use orbit_core::parallel::{MIN_ENVS_PER_COPY_TASK, MIN_ENVS_PER_TASK};
use orbit_core::rng::EnvRng;
use rayon::prelude::*;

use crate::base_env::{EnvRngs, EnvView};
use crate::cfg::{
    EnvCfg, EventMode, FuncTermCfg, NoiseCfg, RewardTermCfg, TerminationTermCfg, Terms,
};
use crate::error::EnvError;
use crate::scene::Scene;
use crate::term::*;

/// Builds the context of the term at `section.name` (its `params` node looked up in `doc`).
pub(crate) fn context<'a>(
    doc: &'a Node,
    scene: &'a Scene,
    cfg: &EnvCfg,
    field: String,
) -> TermContext<'a> {
    let params = node_at(doc, &format!("{field}.params"));
    TermContext {
        field,
        params,
        scene,
        decimation: cfg.decimation,
        step_dt: cfg.sim.dt * cfg.decimation as f32,
        action_dim: 0,
        action_terms: Vec::new(),
        command_dims: Vec::new(),
    }
}

/// A term context that also knows the action and command terms (for terms built after them).
pub(crate) fn context_after<'a>(
    doc: &'a Node,
    scene: &'a Scene,
    cfg: &EnvCfg,
    field: String,
    actions: &ActionManager,
    commands: &CommandManager,
) -> TermContext<'a> {
    let mut ctx = context(doc, scene, cfg, field);
    ctx.action_dim = actions.dim;
    ctx.action_terms = actions
        .terms
        .iter()
        .map(|(n, t)| (n.clone(), t.dim()))
        .collect();
    ctx.command_dims = commands
        .terms
        .iter()
        .map(|c| (c.name.clone(), c.term.dim()))
        .collect();
    ctx
}

/// Splits the policy action among action terms; keeps the current and previous actions.
pub struct ActionManager {
    pub(crate) terms: Vec<(String, Box<dyn ActionTerm>)>,
    pub(crate) dim: usize,
    pub(crate) action: Vec<f32>,
    pub(crate) prev_action: Vec<f32>,
    scratch: Vec<f32>,
}

impl ActionManager {
    pub(crate) fn new(doc: &Node, scene: &Scene, cfg: &EnvCfg) -> Result<Self, EnvError> {
        let mut terms = Vec::new();
        for (name, t) in &cfg.actions.0 {
            let ctx = context(doc, scene, cfg, format!("actions.{name}"));
            terms.push((name.clone(), build_action(&t.func, &ctx)?));
        }
        let dim = terms.iter().map(|(_, t)| t.dim()).sum();
        let n = scene.num_envs();
        Ok(Self {
            terms,
            dim,
            action: vec![0.0; n * dim],
            prev_action: vec![0.0; n * dim],
            scratch: Vec::new(),
        })
    }

    /// Total action dimension.
    pub fn dim(&self) -> usize {
        self.dim
    }

    pub(crate) fn process(&mut self, scene: &Scene, actions: &[f32]) -> Result<(), EnvError> {
        let n = scene.num_envs();
        if actions.len() != n * self.dim {
            return Err(EnvError::InvalidAction(format!(
                "expected {n} × {} = {} values, got {}",
                self.dim,
                n * self.dim,
                actions.len()
            )));
        }
        if let Some(i) = orbit_core::parallel::first_non_finite(actions) {
            return Err(EnvError::InvalidAction(format!(
                "value {} of env {} (action index {}) is not finite; nothing was applied",
                actions[i],
                i / self.dim,
                i % self.dim
            )));
        }
        std::mem::swap(&mut self.prev_action, &mut self.action);
        self.action.copy_from_slice(actions);
        let mut offset = 0;
        for (_, term) in &mut self.terms {
            let d = term.dim();
            self.scratch.resize(n * d, 0.0);
            self.scratch
                .par_chunks_mut(d.max(1))
                .with_min_len(MIN_ENVS_PER_COPY_TASK)
                .zip(actions.par_chunks(self.dim))
                .for_each(|(to, from)| to.copy_from_slice(&from[offset..offset + d]));
            term.process(scene, &self.scratch);
            offset += d;
        }
        Ok(())
    }

    pub(crate) fn apply(&mut self, scene: &mut Scene) -> Result<(), EnvError> {
        for (_, term) in &mut self.terms {
            term.apply(scene)?;
        }
        Ok(())
    }

    /// Whether every term's inputs stay fixed within an env step (see
    /// [`ActionTerm::substep_invariant`]).
    pub(crate) fn substep_invariant(&self) -> bool {
        self.terms.iter().all(|(_, t)| t.substep_invariant())
    }

    pub(crate) fn reset(&mut self, env_ids: &[usize]) {
        for &e in env_ids {
            self.action[e * self.dim..(e + 1) * self.dim].fill(0.0);
            self.prev_action[e * self.dim..(e + 1) * self.dim].fill(0.0);
        }
        for (_, term) in &mut self.terms {
            term.reset(env_ids);
        }
    }

    /// Every term's name and, for joint terms, how it maps raw actions onto joints (in action
    /// order: a term's values follow the previous term's).
    pub fn joint_maps(&self) -> impl Iterator<Item = (&str, Option<JointActionMap<'_>>)> {
        self.terms.iter().map(|(n, t)| (n.as_str(), t.joint_map()))
    }

    /// The processed actions of a term by name.
    pub fn processed(&self, name: &str) -> Option<&[f32]> {
        self.terms
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, t)| t.processed())
    }
}

struct ObsTerm {
    term: Box<dyn ObservationTerm>,
    noise: Option<NoiseCfg>,
    clip: Option<(f32, f32)>,
    scale: Option<f32>,
    buf: Vec<f32>,
    /// History slots (0 = none): per env `history × dim` values, oldest first.
    history: usize,
    hist: Vec<f32>,
    /// Envs whose next value fills the whole history (after a reset).
    fresh: Vec<bool>,
}

impl ObsTerm {
    /// Values per env in the group output.
    fn out_dim(&self) -> usize {
        self.term.dim() * self.history.max(1)
    }
}

/// One observation group: its terms and the concatenated output.
pub struct ObservationGroup {
    /// Group name.
    pub name: String,
    terms: Vec<ObsTerm>,
    /// Values per env.
    pub dim: usize,
    /// Concatenated observations, `num_envs × dim`.
    pub values: Vec<f32>,
}

/// Computes observation groups: per term `func`, then noise, clip, scale; concatenated.
pub struct ObservationManager {
    pub(crate) groups: Vec<ObservationGroup>,
}

impl ObservationManager {
    pub(crate) fn new(
        doc: &Node,
        scene: &Scene,
        cfg: &EnvCfg,
        actions: &ActionManager,
        commands: &CommandManager,
    ) -> Result<Self, EnvError> {
        let n = scene.num_envs();
        let mut groups = Vec::new();
        for (gname, g) in &cfg.observations.0 {
            let mut terms = Vec::new();
            for (tname, t) in &g.terms.0 {
                let ctx = context_after(
                    doc,
                    scene,
                    cfg,
                    format!("observations.{gname}.terms.{tname}"),
                    actions,
                    commands,
                );
                let term = build_observation(&t.func, &ctx)?;
                let d = term.dim();
                terms.push(ObsTerm {
                    term,
                    noise: if g.enable_corruption { t.noise } else { None },
                    clip: t.clip,
                    scale: t.scale,
                    buf: vec![0.0; n * d],
                    history: t.history_length,
                    hist: vec![0.0; n * d * t.history_length],
                    fresh: vec![true; n],
                });
            }
            let dim = terms.iter().map(|t| t.out_dim()).sum();
            groups.push(ObservationGroup {
                name: gname.clone(),
                terms,
                dim,
                values: vec![0.0; n * dim],
            });
        }
        Ok(Self { groups })
    }

    pub(crate) fn compute(&mut self, env: &EnvView<'_>, noise: &mut EnvRngs) {
        before_concurrent_terms(env);
        self.groups.par_iter_mut().for_each(|g| {
            g.terms
                .par_iter_mut()
                .for_each(|t| t.term.compute(env, &mut t.buf));
        });
        // Noise draws follow term order within each env's stream: the terms go in order.
        let streams = noise.streams_mut();
        for g in &mut self.groups {
            let (dim, terms) = (g.dim, &mut g.terms);
            let mut offset = 0;
            let mut first = 0;
            while first < terms.len() {
                if terms[first].history > 0 {
                    offset += terms[first].write_history(&mut g.values, dim, offset, streams);
                    first += 1;
                    continue;
                }
                // A run of terms without history: one pass over the envs writes them all.
                let end = terms[first..]
                    .iter()
                    .position(|t| t.history > 0)
                    .map_or(terms.len(), |k| first + k);
                let run = &terms[first..end];
                g.values
                    .par_chunks_mut(dim)
                    .zip(streams.par_iter_mut())
                    .enumerate()
                    .with_min_len(MIN_ENVS_PER_TASK)
                    .for_each(|(e, (out, rng))| {
                        let mut column = offset;
                        for t in run {
                            let d = t.term.dim();
                            let values = &mut out[column..column + d];
                            values.copy_from_slice(&t.buf[e * d..(e + 1) * d]);
                            corrupt(t.corruption(), rng, values);
                            column += d;
                        }
                    });
                offset += run.iter().map(ObsTerm::out_dim).sum::<usize>();
                first = end;
            }
        }
    }
}

impl ObsTerm {
    /// Noise, clip and scale, as [`corrupt`] takes them.
    fn corruption(&self) -> Corruption {
        (self.noise, self.clip, self.scale)
    }

    /// Corrupts this term's fresh values, shifts them into its history and writes the history
    /// (oldest first) into the group's columns from `offset`; returns the columns written.
    fn write_history(
        &mut self,
        values: &mut [f32],
        dim: usize,
        offset: usize,
        streams: &mut [EnvRng],
    ) -> usize {
        let (d, width, corruption) = (self.term.dim(), self.out_dim(), self.corruption());
        if d == 0 {
            return 0;
        }
        self.buf
            .par_chunks_mut(d)
            .zip(values.par_chunks_mut(dim))
            .zip(streams.par_iter_mut())
            .zip(self.hist.par_chunks_mut(width))
            .zip(self.fresh.par_iter_mut())
            .with_min_len(MIN_ENVS_PER_TASK)
            .for_each(|((((row, out), rng), hist), fresh)| {
                corrupt(corruption, rng, row);
                if std::mem::replace(fresh, false) {
                    hist.chunks_exact_mut(d)
                        .for_each(|slot| slot.copy_from_slice(row));
                } else {
                    hist.copy_within(d.., 0);
                    let last = hist.len() - d;
                    hist[last..].copy_from_slice(row);
                }
                out[offset..offset + width].copy_from_slice(hist);
            });
        width
    }
}

/// A term's noise, clip and scale.
type Corruption = (Option<NoiseCfg>, Option<(f32, f32)>, Option<f32>);

/// Prepares for computing a manager's terms concurrently (each reads only the env's state and
/// writes only its own buffer, so their own loops over envs share the pool instead of
/// following one another). The backend's state is made current first, on this thread: a
/// backend that refreshes it lazily on first look (the GPU backend's host mirror, a parallel
/// copy behind a `OnceLock`) must not do so inside the pool, where a worker waiting for the
/// copy could pick up another term that waits for the same refresh.
fn before_concurrent_terms(env: &EnvView<'_>) {
    env.scene.backend.sync();
}

/// Adds a term's noise to one env's row, then clips and scales it (Isaac Lab's order).
fn corrupt((noise, clip, scale): Corruption, rng: &mut EnvRng, row: &mut [f32]) {
    if noise.is_none() && clip.is_none() && scale.is_none() {
        return;
    }
    for v in row {
        *v += match noise {
            Some(NoiseCfg::Uniform { n_min, n_max }) => rng.uniform_range(n_min, n_max),
            Some(NoiseCfg::Gaussian { mean, std }) => mean + std * rng.normal(),
            None => 0.0,
        };
        if let Some((lo, hi)) = clip {
            *v = v.clamp(lo, hi);
        }
        if let Some(s) = scale {
            *v *= s;
        }
    }
}

impl ObservationManager {
    /// Marks the listed envs' histories to be refilled by their next value.
    pub(crate) fn reset(&mut self, env_ids: &[usize]) {
        for g in &mut self.groups {
            for t in &mut g.terms {
                for &e in env_ids {
                    t.fresh[e] = true;
                }
            }
        }
    }
}

/// Sums weighted reward terms times `step_dt`; keeps per-term episode sums.
pub struct RewardManager {
    terms: Vec<(String, f32, Box<dyn RewardTerm>)>,
    /// Each term's unweighted values of the last step, `[term][env]`.
    values: Vec<Vec<f32>>,
    /// Each env's weighted per-term sums over its current episode, `[env][term]`.
    episode_sums: Vec<f32>,
}

impl RewardManager {
    pub(crate) fn new(
        doc: &Node,
        scene: &Scene,
        cfg: &EnvCfg,
        reward_terms: &Terms<RewardTermCfg>,
        actions: &ActionManager,
        commands: &CommandManager,
    ) -> Result<Self, EnvError> {
        let mut terms = Vec::new();
        for (name, t) in &reward_terms.0 {
            if !t.weight.is_finite() {
                return Err(EnvError::InvalidTerm {
                    field: format!("rewards.{name}.weight"),
                    message: format!("expected a finite weight, got {}", t.weight),
                });
            }
            let ctx = context_after(
                doc,
                scene,
                cfg,
                format!("rewards.{name}"),
                actions,
                commands,
            );
            terms.push((name.clone(), t.weight, build_reward(&t.func, &ctx)?));
        }
        let n = scene.num_envs();
        Ok(Self {
            values: vec![vec![0.0; n]; terms.len()],
            episode_sums: vec![0.0; n * terms.len()],
            terms,
        })
    }

    /// Writes each env's reward `Σ wₖ·rₖ·dt` (terms added in order) and adds each weighted
    /// term to the env's episode sums.
    pub(crate) fn compute(&mut self, env: &EnvView<'_>, dt: f32, reward: &mut [f32]) {
        let num_terms = self.terms.len();
        if num_terms == 0 {
            reward.fill(0.0);
            return;
        }
        before_concurrent_terms(env);
        self.terms
            .par_iter_mut()
            .zip(self.values.par_iter_mut())
            .filter(|((_, weight, _), _)| *weight != 0.0)
            .for_each(|((_, _, term), values)| term.compute(env, values));
        let (terms, values) = (&self.terms, &self.values);
        reward
            .par_iter_mut()
            .zip(self.episode_sums.par_chunks_mut(num_terms))
            .enumerate()
            .with_min_len(MIN_ENVS_PER_COPY_TASK)
            .for_each(|(e, (r, sums))| {
                *r = 0.0;
                for (((_, weight, _), values), sum) in terms.iter().zip(values).zip(sums) {
                    if *weight != 0.0 {
                        let v = values[e] * weight * dt;
                        *r += v;
                        *sum += v;
                    }
                }
            });
    }

    /// The unweighted value of every term on the current state, weight-0 terms included
    /// (Isaac Lab's per-term inspection; `step` does not use it).
    pub(crate) fn evaluate_terms(&mut self, env: &EnvView<'_>) -> Vec<(String, Vec<f32>)> {
        self.terms
            .iter_mut()
            .zip(&mut self.values)
            .map(|((name, _, term), values)| {
                term.compute(env, values);
                (name.clone(), values.clone())
            })
            .collect()
    }

    /// The weight of a reward term.
    pub fn weight(&self, name: &str) -> Option<f32> {
        self.terms
            .iter()
            .find(|(n, ..)| n == name)
            .map(|(_, w, _)| *w)
    }

    /// Changes the weight of a reward term (curricula); 0 switches it off.
    pub fn set_weight(&mut self, name: &str, weight: f32) -> Result<(), EnvError> {
        let names: Vec<String> = self.terms.iter().map(|(n, ..)| n.clone()).collect();
        let term = self
            .terms
            .iter_mut()
            .find(|(n, ..)| n == name)
            .ok_or_else(|| EnvError::InvalidTerm {
                field: "rewards".into(),
                message: format!("no reward term `{name}`; terms: {names:?}"),
            })?;
        if !weight.is_finite() {
            return Err(EnvError::InvalidTerm {
                field: format!("rewards.{name}.weight"),
                message: format!("expected a finite weight, got {weight}"),
            });
        }
        term.1 = weight;
        Ok(())
    }

    pub(crate) fn reset(
        &mut self,
        env_ids: &[usize],
        episode_s: f32,
        log: &mut BTreeMap<String, f32>,
    ) {
        let num_terms = self.terms.len();
        for (k, (name, _, _)) in self.terms.iter().enumerate() {
            let mean = env_ids
                .iter()
                .map(|&e| self.episode_sums[e * num_terms + k])
                .sum::<f32>()
                / env_ids.len().max(1) as f32;
            log.insert(format!("Episode Reward/{name}"), mean / episode_s);
        }
        for &e in env_ids {
            self.episode_sums[e * num_terms..(e + 1) * num_terms].fill(0.0);
        }
    }
}

/// A termination term with its flags of the last step.
struct TerminationEntry {
    name: String,
    time_out: bool,
    term: Box<dyn TerminationTerm>,
    values: Vec<bool>,
}

/// Evaluates termination terms into terminated / time-out flags.
pub struct TerminationManager {
    terms: Vec<TerminationEntry>,
}

impl TerminationManager {
    pub(crate) fn new(
        doc: &Node,
        scene: &Scene,
        cfg: &EnvCfg,
        termination_terms: &Terms<TerminationTermCfg>,
        actions: &ActionManager,
        commands: &CommandManager,
    ) -> Result<Self, EnvError> {
        let n = scene.num_envs();
        let mut terms = Vec::new();
        for (name, t) in &termination_terms.0 {
            let ctx = context_after(
                doc,
                scene,
                cfg,
                format!("terminations.{name}"),
                actions,
                commands,
            );
            terms.push(TerminationEntry {
                name: name.clone(),
                time_out: t.time_out,
                term: build_termination(&t.func, &ctx)?,
                values: vec![false; n],
            });
        }
        Ok(Self { terms })
    }

    pub(crate) fn compute(
        &mut self,
        env: &EnvView<'_>,
        terminated: &mut [bool],
        time_outs: &mut [bool],
    ) {
        terminated.fill(false);
        time_outs.fill(false);
        for entry in &mut self.terms {
            entry.term.compute(env, &mut entry.values);
            let target = if entry.time_out {
                &mut *time_outs
            } else {
                &mut *terminated
            };
            for (t, v) in target.iter_mut().zip(entry.values.iter()) {
                *t |= *v;
            }
        }
    }

    pub(crate) fn reset(&self, env_ids: &[usize], log: &mut BTreeMap<String, f32>) {
        for entry in &self.terms {
            let count = env_ids.iter().filter(|&&e| entry.values[e]).count();
            log.insert(format!("Episode Termination/{}", entry.name), count as f32);
        }
    }
}

/// An event term with its mode and per-env interval timers.
struct EventEntry {
    mode: EventMode,
    interval: Option<(f32, f32)>,
    term: Box<dyn EventTerm>,
    time_left: Vec<f32>,
    /// Envs due this step (reused, so stepping does not allocate).
    due: Vec<usize>,
}

/// Applies event terms by mode.
pub struct EventManager {
    terms: Vec<EventEntry>,
}

impl EventManager {
    pub(crate) fn new(doc: &Node, scene: &Scene, cfg: &EnvCfg) -> Result<Self, EnvError> {
        let n = scene.num_envs();
        let mut terms = Vec::new();
        for (name, t) in &cfg.events.0 {
            let ctx = context(doc, scene, cfg, format!("events.{name}"));
            if t.mode == EventMode::Interval && t.interval_range_s.is_none() {
                return Err(ctx.error("interval events need `interval_range_s: Some((lo, hi))`"));
            }
            terms.push(EventEntry {
                mode: t.mode,
                interval: t.interval_range_s,
                term: build_event(&t.func, &ctx)?,
                time_left: vec![0.0; n],
                due: Vec::with_capacity(n),
            });
        }
        Ok(Self { terms })
    }

    pub(crate) fn apply(
        &mut self,
        mode: EventMode,
        scene: &mut Scene,
        env_ids: &[usize],
        rngs: &mut EnvRngs,
    ) -> Result<(), EnvError> {
        for entry in &mut self.terms {
            if entry.mode == mode {
                entry.term.apply(scene, env_ids, rngs)?;
            }
        }
        Ok(())
    }

    pub(crate) fn init_intervals(&mut self, rngs: &mut EnvRngs) {
        for entry in &mut self.terms {
            if let Some((lo, hi)) = entry.interval {
                for (e, t) in entry.time_left.iter_mut().enumerate() {
                    *t = rngs.get(e).uniform_range(lo, hi);
                }
            }
        }
    }

    pub(crate) fn apply_interval(
        &mut self,
        scene: &mut Scene,
        dt: f32,
        rngs: &mut EnvRngs,
    ) -> Result<(), EnvError> {
        for entry in &mut self.terms {
            let (EventMode::Interval, Some((lo, hi))) = (entry.mode, entry.interval) else {
                continue;
            };
            entry.due.clear();
            for (e, t) in entry.time_left.iter_mut().enumerate() {
                *t -= dt;
                if *t <= 0.0 {
                    *t = rngs.get(e).uniform_range(lo, hi);
                    entry.due.push(e);
                }
            }
            if !entry.due.is_empty() {
                entry.term.apply(scene, &entry.due, rngs)?;
            }
        }
        Ok(())
    }
}

/// A command term with its resampling range and per-env timers.
pub(crate) struct CommandEntry {
    pub(crate) name: String,
    range: (f32, f32),
    pub(crate) term: Box<dyn CommandTerm>,
    time_left: Vec<f32>,
    /// Envs due for resampling this step (reused, so stepping does not allocate).
    due: Vec<usize>,
}

/// Holds command terms and their resampling timers.
pub struct CommandManager {
    pub(crate) terms: Vec<CommandEntry>,
}

impl CommandManager {
    pub(crate) fn new(doc: &Node, scene: &Scene, cfg: &EnvCfg) -> Result<Self, EnvError> {
        let n = scene.num_envs();
        let mut terms = Vec::new();
        for (name, t) in &cfg.commands.0 {
            let ctx = context(doc, scene, cfg, format!("commands.{name}"));
            let (lo, hi) = t.resampling_time_range;
            if !(lo.is_finite() && hi.is_finite() && 0.0 < lo && lo <= hi) {
                return Err(ctx.error(format!(
                    "resampling_time_range must satisfy 0 < lo <= hi, got ({lo}, {hi})"
                )));
            }
            terms.push(CommandEntry {
                name: name.clone(),
                range: t.resampling_time_range,
                term: build_command(&t.func, &ctx)?,
                time_left: vec![0.0; n],
                due: Vec::with_capacity(n),
            });
        }
        Ok(Self { terms })
    }

    /// The command of a term by name (`num_envs × dim`) and its dim.
    pub fn command(&self, name: &str) -> Option<(&[f32], usize)> {
        self.terms
            .iter()
            .find(|c| c.name == name)
            .map(|c| (c.term.command(), c.term.dim()))
    }

    /// Term names.
    pub fn names(&self) -> impl Iterator<Item = &str> {
        self.terms.iter().map(|c| c.name.as_str())
    }

    /// Appends every term's debug markers for env `env` (e.g. a target pose) to `out`.
    pub fn debug_markers(
        &self,
        scene: &Scene,
        env: usize,
        out: &mut Vec<orbit_core::scene::Marker>,
    ) {
        for c in &self.terms {
            c.term.debug_markers(scene, env, out);
        }
    }

    fn resample(
        range: (f32, f32),
        time_left: &mut [f32],
        term: &mut dyn CommandTerm,
        scene: &Scene,
        env_ids: &[usize],
        rngs: &mut EnvRngs,
    ) {
        for &e in env_ids {
            time_left[e] = rngs.get(e).uniform_range(range.0, range.1);
        }
        term.resample(scene, env_ids, rngs);
    }

    pub(crate) fn update_metrics(&mut self, scene: &Scene) {
        for t in &mut self.terms {
            t.term.update_metrics(scene);
        }
    }

    pub(crate) fn reset(
        &mut self,
        scene: &Scene,
        env_ids: &[usize],
        rngs: &mut EnvRngs,
        log: &mut BTreeMap<String, f32>,
    ) {
        for t in &mut self.terms {
            for (metric, values) in t.term.metrics() {
                let mean =
                    env_ids.iter().map(|&e| values[e]).sum::<f32>() / env_ids.len().max(1) as f32;
                log.insert(format!("Metrics/{}/{metric}", t.name), mean);
            }
            Self::resample(
                t.range,
                &mut t.time_left,
                &mut *t.term,
                scene,
                env_ids,
                rngs,
            );
        }
    }

    pub(crate) fn compute(&mut self, scene: &Scene, dt: f32, rngs: &mut EnvRngs) {
        for t in &mut self.terms {
            t.due.clear();
            for (e, left) in t.time_left.iter_mut().enumerate() {
                *left -= dt;
                if *left <= 0.0 {
                    t.due.push(e);
                }
            }
            if !t.due.is_empty() {
                Self::resample(t.range, &mut t.time_left, &mut *t.term, scene, &t.due, rngs);
            }
        }
    }
}

/// Runs curriculum terms when envs reset and logs their state.
pub struct CurriculumManager {
    terms: Vec<(String, Box<dyn CurriculumTerm>)>,
}

impl CurriculumManager {
    pub(crate) fn new(
        doc: &Node,
        scene: &Scene,
        cfg: &EnvCfg,
        curriculum_terms: &Terms<FuncTermCfg>,
    ) -> Result<Self, EnvError> {
        let mut terms = Vec::new();
        for (name, t) in &curriculum_terms.0 {
            let ctx = context(doc, scene, cfg, format!("curriculum.{name}"));
            terms.push((name.clone(), build_curriculum(&t.func, &ctx)?));
        }
        Ok(Self { terms })
    }

    pub(crate) fn compute(
        &mut self,
        env_ids: &[usize],
        common_step_counter: u64,
        rewards: &mut RewardManager,
        log: &mut BTreeMap<String, f32>,
    ) -> Result<(), EnvError> {
        for (name, term) in &mut self.terms {
            if let Some(v) = term.compute(env_ids, common_step_counter, rewards)? {
                log.insert(format!("Curriculum/{name}"), v);
            }
        }
        Ok(())
    }
}
