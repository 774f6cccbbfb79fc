//! The reward manager.

use std::collections::BTreeMap;

use orbit_core::config::Node;
use orbit_core::parallel::MIN_ENVS_PER_COPY_TASK;
use rayon::prelude::*;

use super::{
    ActionManager, CommandManager, Manager, ResetContext, before_concurrent_terms, context_after,
    mean_over,
};
use crate::base_env::EnvView;
use crate::cfg::{EnvCfg, RewardTermCfg, Terms};
use crate::error::EnvError;
use crate::scene::Scene;
use crate::term::{RewardTerm, build_reward};

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
}

impl Manager for RewardManager {
    fn active_terms(&self) -> Vec<String> {
        self.terms.iter().map(|(n, ..)| n.clone()).collect()
    }

    /// Logs `Episode Reward/<term>` (the mean of the envs' episode sums divided by
    /// `ctx.episode_length_s`), then clears those sums.
    fn reset(&mut self, env_ids: &[usize], ctx: &mut ResetContext<'_>) -> BTreeMap<String, f32> {
        let num_terms = self.terms.len();
        let mut log = BTreeMap::new();
        for (k, (name, _, _)) in self.terms.iter().enumerate() {
            let mean = mean_over(env_ids, |e| self.episode_sums[e * num_terms + k]);
            log.insert(
                format!("Episode Reward/{name}"),
                mean / ctx.episode_length_s,
            );
        }
        for &e in env_ids {
            self.episode_sums[e * num_terms..(e + 1) * num_terms].fill(0.0);
        }
        for (_, _, term) in &mut self.terms {
            term.reset(ctx.scene, env_ids);
        }
        log
    }
}
