//! The event manager.

use std::collections::BTreeMap;

use orbit_core::config::Node;

use super::{Manager, ResetContext, context};
use crate::base_env::EnvRngs;
use crate::cfg::{EnvCfg, EventMode};
use crate::error::EnvError;
use crate::scene::Scene;
use crate::term::{EventTerm, build_event};

/// An event term with its mode and per-env interval timers.
struct EventEntry {
    name: String,
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
                name: name.clone(),
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

impl Manager for EventManager {
    fn active_terms(&self) -> Vec<String> {
        self.terms.iter().map(|t| t.name.clone()).collect()
    }

    /// Does nothing and logs nothing: the env applies `Reset` events itself, before the other
    /// managers reset, and interval timers run on across episodes.
    fn reset(&mut self, _: &[usize], _: &mut ResetContext<'_>) -> BTreeMap<String, f32> {
        BTreeMap::new()
    }
}
