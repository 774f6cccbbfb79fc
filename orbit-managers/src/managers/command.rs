//! The command manager.

use std::collections::BTreeMap;

use orbit_core::config::Node;

use super::{Manager, ResetContext, context, mean_over};
use crate::base_env::EnvRngs;
use crate::cfg::EnvCfg;
use crate::error::EnvError;
use crate::scene::Scene;
use crate::term::{CommandTerm, build_command};

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

impl Manager for CommandManager {
    fn active_terms(&self) -> Vec<String> {
        self.names().map(str::to_owned).collect()
    }

    /// Term by term: logs `Metrics/<term>/<metric>` (the mean over the envs), then resamples
    /// the envs' commands and timers on `ctx.scene` from `ctx.command_rngs`.
    fn reset(&mut self, env_ids: &[usize], ctx: &mut ResetContext<'_>) -> BTreeMap<String, f32> {
        let mut log = BTreeMap::new();
        for t in &mut self.terms {
            for (metric, values) in t.term.metrics() {
                let mean = mean_over(env_ids, |e| values[e]);
                log.insert(format!("Metrics/{}/{metric}", t.name), mean);
            }
            Self::resample(
                t.range,
                &mut t.time_left,
                &mut *t.term,
                ctx.scene,
                env_ids,
                ctx.command_rngs,
            );
        }
        log
    }
}
