//! The action manager.

use std::collections::BTreeMap;

use orbit_core::config::Node;
use orbit_core::parallel::MIN_ENVS_PER_COPY_TASK;
use rayon::prelude::*;

use super::{Manager, ResetContext, context};
use crate::cfg::EnvCfg;
use crate::error::EnvError;
use crate::scene::Scene;
use crate::term::{ActionTerm, JointActionMap, build_action};

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

    /// Every term's name and, for joint terms, how it maps raw actions onto joints (in action
    /// order: a term's values follow the previous term's).
    pub fn joint_maps(&self) -> impl Iterator<Item = (&str, Option<JointActionMap<'_>>)> {
        self.terms.iter().map(|(n, t)| (n.as_str(), t.joint_map()))
    }

    /// Each action value's raw range beyond which it acts the same (see
    /// [`ActionTerm::bounds`]), in action order.
    pub fn bounds(&self) -> Vec<(f32, f32)> {
        self.terms.iter().flat_map(|(_, t)| t.bounds()).collect()
    }

    /// The processed actions of a term by name.
    pub fn processed(&self, name: &str) -> Option<&[f32]> {
        self.terms
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, t)| t.processed())
    }
}

impl Manager for ActionManager {
    fn active_terms(&self) -> Vec<String> {
        self.terms.iter().map(|(n, _)| n.clone()).collect()
    }

    /// Zeroes the envs' current and previous actions and resets every term; logs nothing.
    fn reset(&mut self, env_ids: &[usize], _: &mut ResetContext<'_>) -> BTreeMap<String, f32> {
        for &e in env_ids {
            self.action[e * self.dim..(e + 1) * self.dim].fill(0.0);
            self.prev_action[e * self.dim..(e + 1) * self.dim].fill(0.0);
        }
        for (_, term) in &mut self.terms {
            term.reset(env_ids);
        }
        BTreeMap::new()
    }
}
