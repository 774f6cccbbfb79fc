//! The learner's view of an environment (RSL-RL's `VecEnv`), and its implementation for
//! [`ManagerBasedRlEnv`] (Isaac Lab's `RslRlVecEnvWrapper`).

use std::collections::BTreeMap;

use orbit_core::rng::EnvRng;
use orbit_managers::{ManagerBasedRlEnv, StepTimings};

use orbit_core::rng::streams;

use crate::VecEnvError;

/// What one step of a vectorised env returns.
pub struct VecEnvStep<'a> {
    /// Rewards, one per env.
    pub rewards: &'a [f32],
    /// Episode ended (terminated or timed out), one per env.
    pub dones: &'a [bool],
    /// Episode ended by a termination term, one per env (a time-out may be set too).
    pub terminated: &'a [bool],
    /// Episode timed out, one per env (the learner bootstraps these).
    pub time_outs: &'a [bool],
    /// Episode statistics of the envs that finished in this step (empty if none did).
    pub log: &'a BTreeMap<String, f32>,
    /// Simulated env steps each env took for this step: 1 for a step-based env, the segment's
    /// length for a black-box env. Env interactions are counted in these.
    pub interactions: u32,
}

/// A batch of environments as the learner sees it. The env resets itself: finished envs come
/// back already reset, with the observation of their new episode.
pub trait VecEnv {
    /// Number of envs.
    fn num_envs(&self) -> usize;
    /// Width of one env's action.
    fn num_actions(&self) -> usize;
    /// Width of one env's actor observation.
    fn num_obs(&self) -> usize;
    /// Width of one env's critic observation.
    fn num_critic_obs(&self) -> usize;
    /// Each action value's raw range beyond which it acts the same (a clip, an effort limit);
    /// unbounded where nothing saturates it.
    fn action_bounds(&self) -> Vec<(f32, f32)> {
        vec![(f32::NEG_INFINITY, f32::INFINITY); self.num_actions()]
    }
    /// What writes value `index` of an actor (or, with `critic`, a critic) observation row:
    /// its term's name, if the env knows it.
    fn observation_source(&self, _critic: bool, _index: usize) -> Option<String> {
        None
    }
    /// Steps after which an episode times out.
    fn max_episode_length(&self) -> u32;
    /// Actor observations, `[num_envs, num_obs]`.
    fn observations(&self) -> &[f32];
    /// Critic observations, `[num_envs, num_critic_obs]` (the actor's unless the env has a
    /// `critic` group).
    fn critic_observations(&self) -> &[f32];
    /// Keeps, from the next step on, the observations each finished episode ended in (see
    /// [`Self::final_observations`]), or stops keeping them. Off by default: it costs an
    /// observation pass on every step in which an episode ends.
    fn keep_final_observations(&mut self, _keep: bool) {}
    /// Actor observations, `[num_envs, num_obs]`, as the episodes that ended in the last step
    /// left them, before their reset; only the rows of envs whose `dones` the step set are
    /// that step's. Terms' clip and scale apply, their noise does not. `None` unless kept, or
    /// if the env cannot keep them.
    fn final_observations(&self) -> Option<&[f32]> {
        None
    }
    /// Critic observations as [`Self::final_observations`] has the actor's.
    fn final_critic_observations(&self) -> Option<&[f32]> {
        None
    }
    /// Applies one action per env and advances one step.
    fn step(&mut self, actions: &[f32]) -> Result<VecEnvStep<'_>, VecEnvError>;
    /// Resets every env and computes the first observations of their new episodes.
    fn reset(&mut self) -> Result<(), VecEnvError>;
    /// Resets the listed envs alone (their new episodes' first observations; the others keep
    /// theirs).
    fn reset_envs(&mut self, _env_ids: &[usize]) -> Result<(), VecEnvError> {
        Err(VecEnvError::Mismatch(
            "this env resets all its envs together: reset them all".into(),
        ))
    }
    /// Steps each env has taken in its running episode.
    fn episode_lengths(&self) -> Result<&[u32], VecEnvError> {
        Err(VecEnvError::Mismatch(
            "this env does not expose its episode lengths".into(),
        ))
    }
    /// Moves each env to step `lengths[i]` of its episode (below the maximum length).
    fn set_episode_lengths(&mut self, _lengths: &[u32]) -> Result<(), VecEnvError> {
        Err(VecEnvError::Mismatch(
            "this env's episodes cannot be moved to another step".into(),
        ))
    }
    /// Moves every env to a random step of its episode (uniform in `[0, max_episode_length)`),
    /// drawn from `seed`, so that time-outs spread out.
    fn randomize_episode_lengths(&mut self, seed: u64) -> Result<(), VecEnvError>;
    /// Wall-clock time of each phase of the env's steps so far, if the env measures it.
    fn step_timings(&self) -> Option<StepTimings> {
        None
    }
}

/// A boxed env is an env: lets one runner type train step-based and black-box envs.
impl<E: VecEnv + ?Sized> VecEnv for Box<E> {
    fn num_envs(&self) -> usize {
        (**self).num_envs()
    }

    fn num_actions(&self) -> usize {
        (**self).num_actions()
    }

    fn num_obs(&self) -> usize {
        (**self).num_obs()
    }

    fn num_critic_obs(&self) -> usize {
        (**self).num_critic_obs()
    }

    fn action_bounds(&self) -> Vec<(f32, f32)> {
        (**self).action_bounds()
    }

    fn observation_source(&self, critic: bool, index: usize) -> Option<String> {
        (**self).observation_source(critic, index)
    }

    fn max_episode_length(&self) -> u32 {
        (**self).max_episode_length()
    }

    fn observations(&self) -> &[f32] {
        (**self).observations()
    }

    fn critic_observations(&self) -> &[f32] {
        (**self).critic_observations()
    }

    fn keep_final_observations(&mut self, keep: bool) {
        (**self).keep_final_observations(keep);
    }

    fn final_observations(&self) -> Option<&[f32]> {
        (**self).final_observations()
    }

    fn final_critic_observations(&self) -> Option<&[f32]> {
        (**self).final_critic_observations()
    }

    fn step(&mut self, actions: &[f32]) -> Result<VecEnvStep<'_>, VecEnvError> {
        (**self).step(actions)
    }

    fn reset(&mut self) -> Result<(), VecEnvError> {
        (**self).reset()
    }

    fn reset_envs(&mut self, env_ids: &[usize]) -> Result<(), VecEnvError> {
        (**self).reset_envs(env_ids)
    }

    fn episode_lengths(&self) -> Result<&[u32], VecEnvError> {
        (**self).episode_lengths()
    }

    fn set_episode_lengths(&mut self, lengths: &[u32]) -> Result<(), VecEnvError> {
        (**self).set_episode_lengths(lengths)
    }

    fn randomize_episode_lengths(&mut self, seed: u64) -> Result<(), VecEnvError> {
        (**self).randomize_episode_lengths(seed)
    }

    fn step_timings(&self) -> Option<StepTimings> {
        (**self).step_timings()
    }
}

/// A [`ManagerBasedRlEnv`] as a [`VecEnv`]: observation group `policy` for the actor, `critic`
/// (if present) for the critic. Resets the env once on construction.
pub struct RlVecEnv {
    env: ManagerBasedRlEnv,
    dones: Vec<bool>,
    num_obs: usize,
    num_critic_obs: usize,
    empty_log: BTreeMap<String, f32>,
}

impl RlVecEnv {
    /// Wraps and resets `env`.
    pub fn new(mut env: ManagerBasedRlEnv) -> Result<Self, VecEnvError> {
        env.reset()?;
        let num_obs = env.observation("policy").map(|(_, d)| d).ok_or_else(|| {
            VecEnvError::Mismatch("the env has no `policy` observation group".into())
        })?;
        let num_critic_obs = env.observation("critic").map_or(num_obs, |(_, d)| d);
        Ok(Self {
            dones: vec![false; env.num_envs()],
            env,
            num_obs,
            num_critic_obs,
            empty_log: BTreeMap::new(),
        })
    }

    /// The wrapped env.
    pub fn env(&self) -> &ManagerBasedRlEnv {
        &self.env
    }

    /// The wrapped env, mutably.
    pub fn env_mut(&mut self) -> &mut ManagerBasedRlEnv {
        &mut self.env
    }
}

impl VecEnv for RlVecEnv {
    fn num_envs(&self) -> usize {
        self.env.num_envs()
    }

    fn num_actions(&self) -> usize {
        self.env.action_dim()
    }

    fn num_obs(&self) -> usize {
        self.num_obs
    }

    fn num_critic_obs(&self) -> usize {
        self.num_critic_obs
    }

    fn action_bounds(&self) -> Vec<(f32, f32)> {
        self.env.actions().bounds()
    }

    fn observation_source(&self, critic: bool, index: usize) -> Option<String> {
        let group = match critic && self.env.observation("critic").is_some() {
            true => "critic",
            false => "policy",
        };
        let term = self.env.observation_term_at(group, index)?;
        Some(format!("observation term `{group}/{term}`"))
    }

    fn max_episode_length(&self) -> u32 {
        self.env.max_episode_length()
    }

    fn observations(&self) -> &[f32] {
        self.env.observation("policy").expect("checked in new").0
    }

    fn critic_observations(&self) -> &[f32] {
        self.env
            .observation("critic")
            .or_else(|| self.env.observation("policy"))
            .expect("checked in new")
            .0
    }

    fn keep_final_observations(&mut self, keep: bool) {
        self.env.keep_final_observations(keep);
    }

    fn final_observations(&self) -> Option<&[f32]> {
        self.env.final_observation("policy").map(|(v, _)| v)
    }

    fn final_critic_observations(&self) -> Option<&[f32]> {
        self.env
            .final_observation("critic")
            .or_else(|| self.env.final_observation("policy"))
            .map(|(v, _)| v)
    }

    fn step(&mut self, actions: &[f32]) -> Result<VecEnvStep<'_>, VecEnvError> {
        let r = self.env.step(actions)?;
        let mut any_done = false;
        for ((d, &t), &o) in self.dones.iter_mut().zip(r.terminated).zip(r.time_outs) {
            *d = t || o;
            any_done |= *d;
        }
        Ok(VecEnvStep {
            rewards: r.reward,
            dones: &self.dones,
            terminated: r.terminated,
            time_outs: r.time_outs,
            log: if any_done {
                &r.extras.log
            } else {
                &self.empty_log
            },
            interactions: 1,
        })
    }

    fn reset(&mut self) -> Result<(), VecEnvError> {
        self.dones.fill(false);
        Ok(self.env.reset()?)
    }

    fn reset_envs(&mut self, env_ids: &[usize]) -> Result<(), VecEnvError> {
        for &e in env_ids {
            if let Some(done) = self.dones.get_mut(e) {
                *done = false;
            }
        }
        Ok(self.env.reset_envs(env_ids)?)
    }

    fn episode_lengths(&self) -> Result<&[u32], VecEnvError> {
        Ok(self.env.episode_length())
    }

    fn set_episode_lengths(&mut self, lengths: &[u32]) -> Result<(), VecEnvError> {
        Ok(self.env.set_episode_length(lengths)?)
    }

    fn randomize_episode_lengths(&mut self, seed: u64) -> Result<(), VecEnvError> {
        let max = self.env.max_episode_length();
        let lengths: Vec<u32> = (0..self.num_envs())
            .map(|e| {
                let mut rng = EnvRng::new(seed, e as u32, streams::EPISODE_LENGTH);
                ((u64::from(rng.next_u32()) * u64::from(max)) >> 32) as u32
            })
            .collect();
        self.env.set_episode_length(&lengths)?;
        Ok(())
    }

    fn step_timings(&self) -> Option<StepTimings> {
        Some(*self.env.timings())
    }
}
