//! The curriculum manager.

use std::collections::BTreeMap;

use orbit_core::config::Node;

use super::{Manager, ResetContext, RewardManager, context};
use crate::cfg::{EnvCfg, FuncTermCfg, Terms};
use crate::error::EnvError;
use crate::scene::Scene;
use crate::term::{CurriculumTerm, build_curriculum};

/// Runs curriculum terms when envs reset and logs their state.
pub struct CurriculumManager {
    terms: Vec<(String, Box<dyn CurriculumTerm>)>,
    /// What each term returned from its last [`compute`](Self::compute), logged by `reset`.
    state: Vec<Option<f32>>,
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
        Ok(Self {
            state: vec![None; terms.len()],
            terms,
        })
    }

    /// Runs every term for the envs about to reset (before anything else of the reset) and
    /// keeps what they return for [`Manager::reset`] to log.
    pub(crate) fn compute(
        &mut self,
        env_ids: &[usize],
        common_step_counter: u64,
        rewards: &mut RewardManager,
    ) -> Result<(), EnvError> {
        for ((_, term), state) in self.terms.iter_mut().zip(&mut self.state) {
            *state = term.compute(env_ids, common_step_counter, rewards)?;
        }
        Ok(())
    }
}

impl Manager for CurriculumManager {
    fn active_terms(&self) -> Vec<String> {
        self.terms.iter().map(|(n, _)| n.clone()).collect()
    }

    /// Logs `Curriculum/<term>` for every term whose last `compute` returned a value.
    fn reset(&mut self, _: &[usize], _: &mut ResetContext<'_>) -> BTreeMap<String, f32> {
        let mut log = BTreeMap::new();
        for ((name, _), state) in self.terms.iter().zip(&self.state) {
            if let Some(v) = state {
                log.insert(format!("Curriculum/{name}"), *v);
            }
        }
        log
    }
}
