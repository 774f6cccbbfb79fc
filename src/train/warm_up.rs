//! The GPU learner's kernels compiled while the env builds.
//!
//! A GPU learner compiles its kernels (the collection pass's, the update's) in its first
//! iteration, and building a wgpu env compiles the physics kernel: seconds each, one after the
//! other, on one thread each. Here a throwaway runner with the run's learner config trains one
//! iteration on an env of the run's shapes that returns zeros, on a thread of its own, from
//! before the real env builds: the kernels it compiles are the driver's and cubecl's to reuse,
//! and the run's own learner starts from its own parameters as before. The run does not wait
//! for it: where the env builds in a moment, the run's first iteration asks for the kernels
//! the warm-up is compiling.

use std::collections::BTreeMap;
use std::thread::JoinHandle;

use orbit_envs::{VecEnvError, VecEnvStep};
use orbit_rl::burn::tensor::Device;
use orbit_rl::{OnPolicyRunner, RlError, RunnerCfg, VecEnv};

use super::ResolvedRun;

/// An env with a run's shapes whose observations and rewards are zeros and whose episodes do
/// not end: what a learner needs to compile every kernel of an iteration.
pub(crate) struct ShapeOnlyEnv {
    num_actions: usize,
    num_obs: usize,
    num_critic_obs: usize,
    max_episode_length: u32,
    obs: Vec<f32>,
    critic_obs: Vec<f32>,
    rewards: Vec<f32>,
    flags: Vec<bool>,
    log: BTreeMap<String, f32>,
}

impl ShapeOnlyEnv {
    /// `num_envs` envs of `env`'s widths.
    pub(crate) fn like(env: &dyn VecEnv, num_envs: usize) -> Self {
        Self {
            num_actions: env.num_actions(),
            num_obs: env.num_obs(),
            num_critic_obs: env.num_critic_obs(),
            max_episode_length: env.max_episode_length(),
            obs: vec![0.0; num_envs * env.num_obs()],
            critic_obs: vec![0.0; num_envs * env.num_critic_obs()],
            rewards: vec![0.0; num_envs],
            flags: vec![false; num_envs],
            log: BTreeMap::new(),
        }
    }
}

impl VecEnv for ShapeOnlyEnv {
    fn num_envs(&self) -> usize {
        self.rewards.len()
    }

    fn num_actions(&self) -> usize {
        self.num_actions
    }

    fn num_obs(&self) -> usize {
        self.num_obs
    }

    fn num_critic_obs(&self) -> usize {
        self.num_critic_obs
    }

    fn max_episode_length(&self) -> u32 {
        self.max_episode_length
    }

    fn observations(&self) -> &[f32] {
        &self.obs
    }

    fn critic_observations(&self) -> &[f32] {
        &self.critic_obs
    }

    fn step(&mut self, _actions: &[f32]) -> Result<VecEnvStep<'_>, VecEnvError> {
        Ok(VecEnvStep {
            rewards: &self.rewards,
            dones: &self.flags,
            terminated: &self.flags,
            time_outs: &self.flags,
            log: &self.log,
            interactions: 1,
        })
    }

    fn reset(&mut self) -> Result<(), VecEnvError> {
        Ok(())
    }

    fn randomize_episode_lengths(&mut self, _seed: u64) -> Result<(), VecEnvError> {
        Ok(())
    }
}

/// A warm-up running on its own thread; dropping it waits for the thread, so that it ends
/// before the device it uses.
pub(crate) struct WarmUp(Option<JoinHandle<Result<(), RlError>>>);

impl Drop for WarmUp {
    fn drop(&mut self) {
        if let Err(e) = self.finish() {
            tracing::debug!(error = %e, "the learner's warm-up stopped");
        }
    }
}

impl WarmUp {
    /// No warm-up.
    pub(crate) fn none() -> Self {
        Self(None)
    }

    /// Starts one iteration of a throwaway runner with `cfg` on `device`, on `num_envs` envs
    /// of the run's shapes, which a one-env copy of the run's env on the CPU backend gives.
    /// Where that copy cannot be built there is no warm-up, and the run compiles its kernels
    /// in its first iteration.
    pub(crate) fn spawn(
        run: &ResolvedRun,
        num_envs: usize,
        cfg: RunnerCfg,
        device: Device,
    ) -> Self {
        let mut overrides = run.env_overrides.clone();
        overrides.extend([
            "num_envs=1".to_string(),
            "sim.backend=\"rapier\"".to_string(),
        ]);
        let shapes =
            match crate::make_vec_env(&run.configs, &overrides, &run.black_box_overrides, None) {
                Ok((env, _)) => ShapeOnlyEnv::like(&*env, num_envs),
                Err(e) => {
                    tracing::debug!(error = %e, "no learner warm-up: the env's shapes are unknown");
                    return Self::none();
                }
            };
        Self(Some(std::thread::spawn(move || {
            let start = std::time::Instant::now();
            OnPolicyRunner::new(shapes, cfg, None, device)?.learn(1)?;
            let seconds = start.elapsed().as_secs_f64();
            tracing::info!(seconds, "the learner's warm-up compiled its kernels");
            Ok(())
        })))
    }

    /// Waits for the warm-up's iteration; its error, if it stopped.
    pub(crate) fn finish(&mut self) -> Result<(), RlError> {
        match self.0.take().map(JoinHandle::join) {
            None => Ok(()),
            Some(Ok(result)) => result,
            Some(Err(_)) => Err(RlError::Device("the learner's warm-up panicked".into())),
        }
    }
}

#[cfg(test)]
mod tests {
    use clap::Parser;
    use orbit_rl::OnPolicyRunner;
    use orbit_rl::burn::tensor::Device;

    use super::WarmUp;
    use crate::train::{TrainArgs, resolve};

    /// Two iterations of the run's own learner (CPU learner, rapier physics): its parameters.
    fn trained(run: &crate::train::ResolvedRun) -> Vec<f32> {
        let (env, _) =
            crate::make_vec_env(&run.configs, &run.env_overrides, &[], None).expect("env");
        let mut runner =
            OnPolicyRunner::new(env, run.agent.clone(), None, Device::flex()).expect("runner");
        runner.learn(2).expect("learn");
        runner.alg.model.parameter_values()
    }

    /// The warm-up learns an iteration on the run's shapes, and a run trained after it ends with
    /// the same parameters, bit for bit, as one trained without it: it shares no state (random
    /// streams, normalisers) with the run.
    #[test]
    fn warm_up_leaves_the_run_unchanged() {
        let args = TrainArgs::parse_from([
            "train",
            "--task",
            "Isaac-Cartpole-v0",
            "--backend",
            "rapier",
            "--num-envs",
            "16",
            "--rl-device",
            "cpu",
            "agent.num_steps_per_env=8",
        ]);
        let run = resolve(&args).expect("the run resolves");
        let alone = trained(&run);
        let mut warm_up = WarmUp::spawn(&run, 16, run.agent.clone(), Device::flex());
        assert!(warm_up.0.is_some(), "the run's shapes are known");
        let after = trained(&run);
        warm_up.finish().expect("the warm-up learns an iteration");
        assert_eq!(alone, after);
    }
}
