//! The termination manager.

use std::collections::BTreeMap;

use orbit_core::config::Node;

use super::{ActionManager, CommandManager, Manager, ResetContext, context_after};
use crate::base_env::EnvView;
use crate::cfg::{EnvCfg, TerminationTermCfg, Terms};
use crate::error::EnvError;
use crate::scene::Scene;
use crate::term::{TerminationTerm, build_termination};

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
}

impl Manager for TerminationManager {
    fn active_terms(&self) -> Vec<String> {
        self.terms.iter().map(|t| t.name.clone()).collect()
    }

    /// Logs `Episode Termination/<term>`: how many of the envs that term flagged in the last
    /// step. Nothing is cleared (the next step recomputes every flag).
    fn reset(&mut self, env_ids: &[usize], _: &mut ResetContext<'_>) -> BTreeMap<String, f32> {
        let mut log = BTreeMap::new();
        for entry in &self.terms {
            let count = env_ids.iter().filter(|&&e| entry.values[e]).count();
            log.insert(format!("Episode Termination/{}", entry.name), count as f32);
        }
        log
    }
}
