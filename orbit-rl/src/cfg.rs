//! Runner, policy and PPO configs (RSL-RL's `RslRlOnPolicyRunnerCfg`, `RslRlPpoActorCriticCfg`
//! and `RslRlPpoAlgorithmCfg`), loaded from RON files that live beside each task.

use serde::{Deserialize, Serialize};

/// The on-policy runner's config (one RON file per task and workflow).
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct RunnerCfg {
    /// Seed of the learner (network initialisation, action noise, minibatch shuffles) and, as
    /// in Isaac Lab's training script, of the env.
    #[serde(default = "default_seed")]
    pub seed: u64,
    /// Where the network is evaluated and trained (RSL-RL's `device`).
    #[serde(default)]
    pub device: LearnerDevice,
    /// What runs the PPO update on the GPU (`device: Gpu`): kernels of orbit-rs's own for
    /// MLP actor-critics, in every build (`Fused`, the default), or burn's wgpu backend, in a
    /// build with the `gpu-learner` feature (`Burn`).
    #[serde(default)]
    pub gpu_update: GpuUpdate,
    /// Env steps per env collected per iteration.
    pub num_steps_per_env: usize,
    /// Iterations of `learn`.
    pub max_iterations: usize,
    /// A checkpoint every this many iterations (and one after the last).
    #[serde(default = "default_save_interval")]
    pub save_interval: usize,
    /// Name of the directory under `logs/` holding this experiment's runs.
    pub experiment_name: String,
    /// Suffix of the run directory name (`<timestamp>_<run_name>`), empty for none.
    #[serde(default)]
    pub run_name: String,
    /// Normalise observations with running statistics (RSL-RL's `EmpiricalNormalization`).
    #[serde(default)]
    pub empirical_normalization: bool,
    /// Start every env at a random point of its episode, so time-outs are spread out.
    #[serde(default = "default_true")]
    pub init_at_random_ep_len: bool,
    /// The `extras.log` key whose per-iteration mean is reported as the success rate (e.g.
    /// `Metrics/target/success`), if the task has one.
    #[serde(default)]
    pub success_metric: Option<String>,
    /// Overrides applied to the env config before it is built (`key.path=value`), e.g. the
    /// number of envs the published settings use.
    #[serde(default)]
    pub env_overrides: Vec<String>,
    /// The actor-critic network.
    pub policy: PolicyCfg,
    /// The PPO algorithm.
    pub algorithm: PpoCfg,
}

/// Where the learner runs.
#[derive(Clone, Copy, Debug, Default, Serialize, Deserialize, PartialEq, Eq)]
pub enum LearnerDevice {
    /// burn's pure-Rust CPU backend (flex), multi-threaded.
    #[default]
    Cpu,
    /// burn's wgpu backend, on the same Vulkan device as the wgpu physics backend (needs a
    /// build with the `gpu-learner` feature).
    Gpu,
}

/// What runs a GPU learner's PPO update.
#[derive(Clone, Copy, Debug, Default, Serialize, Deserialize, PartialEq, Eq)]
pub enum GpuUpdate {
    /// Kernels of `orbit-mlp-wgpu` (forward, backward, Adam and the adaptive learning rate
    /// for a whole update in one submission) on the physics' Vulkan device; the network's
    /// copy for checkpoints and inference stays on the CPU.
    #[default]
    Fused,
    /// burn's wgpu backend (the `gpu-learner` build feature).
    Burn,
}

/// Actor-critic network config (RSL-RL's `ActorCritic`).
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct PolicyCfg {
    /// Initial standard deviation of the Gaussian action noise.
    pub init_noise_std: f32,
    /// Hidden layer widths of the actor.
    pub actor_hidden_dims: Vec<usize>,
    /// Hidden layer widths of the critic.
    pub critic_hidden_dims: Vec<usize>,
    /// Activation between hidden layers.
    pub activation: Activation,
    /// How the noise parameter is stored: the standard deviation itself (RSL-RL's default) or
    /// its logarithm.
    #[serde(default)]
    pub noise_std_type: NoiseStdType,
}

/// Activation functions RSL-RL offers.
#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq, Eq)]
pub enum Activation {
    /// `x` if `x > 0`, else `exp(x) − 1`.
    Elu,
    /// Scaled ELU.
    Selu,
    /// `max(x, 0)`.
    Relu,
    /// Leaky ReLU with slope 0.01.
    Lrelu,
    /// Hyperbolic tangent.
    Tanh,
    /// Logistic sigmoid.
    Sigmoid,
}

/// Parameterisation of the state-independent action noise.
#[derive(Clone, Copy, Debug, Default, Serialize, Deserialize, PartialEq, Eq)]
pub enum NoiseStdType {
    /// The parameter is the standard deviation (`std`).
    #[default]
    Scalar,
    /// The parameter is its logarithm (`log_std`).
    Log,
}

/// PPO config (RSL-RL's `PPO` constructor arguments).
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct PpoCfg {
    /// Weight of the value loss.
    pub value_loss_coef: f32,
    /// Clip the value loss around the old values with `clip_param`.
    pub use_clipped_value_loss: bool,
    /// ε of the clipped surrogate (and of the value clipping).
    pub clip_param: f32,
    /// Weight of the entropy bonus.
    pub entropy_coef: f32,
    /// Passes over the rollout per iteration.
    pub num_learning_epochs: usize,
    /// Minibatches per pass.
    pub num_mini_batches: usize,
    /// Initial Adam learning rate.
    pub learning_rate: f64,
    /// `Fixed` learning rate or `Adaptive` (KL-driven).
    pub schedule: Schedule,
    /// Discount factor.
    pub gamma: f32,
    /// GAE λ.
    pub lam: f32,
    /// Target KL divergence of the adaptive schedule.
    pub desired_kl: f32,
    /// Gradient-norm clip (see `grad_clip` for what the norm is taken over).
    pub max_grad_norm: f32,
    /// Normalise advantages per minibatch instead of over the whole rollout.
    #[serde(default)]
    pub normalize_advantage_per_mini_batch: bool,
    /// Which gradients share one norm clip: all of them (RSL-RL 2.x, the default) or the
    /// actor's and the critic's separately (RSL-RL 5).
    #[serde(default)]
    pub grad_clip: GradClip,
    /// Train the critic on returns normalised by their running mean and standard deviation, and
    /// denormalise its output wherever a value is used (rl_games' `normalize_value`; not in
    /// RSL-RL). Helps when returns are far from the critic's initial output, e.g. the sums of
    /// a whole episode's rewards in black-box RL.
    #[serde(default)]
    pub normalize_value: bool,
}

/// How the gradient norm is clipped.
#[derive(Clone, Copy, Debug, Default, Serialize, Deserialize, PartialEq, Eq)]
pub enum GradClip {
    /// One norm over every parameter (`clip_grad_norm_(all params)`, RSL-RL 2.x): while the
    /// value loss is large, the critic's gradient sets the factor that scales the actor's.
    #[default]
    Global,
    /// The actor (with the noise parameter) and the critic each clipped to `max_grad_norm`
    /// (RSL-RL 5).
    PerNetwork,
}

/// Learning-rate schedule.
#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq, Eq)]
pub enum Schedule {
    /// Keep the configured rate.
    Fixed,
    /// Divide by 1.5 when the KL exceeds 2·desired, multiply by 1.5 below desired/2, clamped to
    /// [1e-5, 1e-2].
    Adaptive,
}

fn default_seed() -> u64 {
    42
}

fn default_save_interval() -> usize {
    50
}

fn default_true() -> bool {
    true
}

impl RunnerCfg {
    /// Loads a runner config from RON text (`file_name` is used in errors) with overrides.
    pub fn from_ron(
        text: &str,
        file_name: &str,
        overrides: &[String],
    ) -> Result<Self, crate::RlError> {
        let cfg: RunnerCfg = orbit_core::config::from_str(text, file_name, overrides)?;
        cfg.validate(file_name)?;
        Ok(cfg)
    }

    /// Loads a runner config file (on disk, or bundled: `<bundled>/…`) with its includes and
    /// `overrides` (`key.path=value`) applied.
    pub fn load(path: &std::path::Path, overrides: &[String]) -> Result<Self, crate::RlError> {
        let doc = orbit_managers::load_config(path, overrides)?;
        let cfg: RunnerCfg = orbit_core::config::from_node(&doc)?;
        cfg.validate(&path.display().to_string())?;
        Ok(cfg)
    }

    /// Checks the values serde cannot (positive sizes, probabilities in range).
    pub fn validate(&self, file_name: &str) -> Result<(), crate::RlError> {
        let bad = |field: &str, message: String| {
            Err(crate::RlError::InvalidConfig {
                file: file_name.to_string(),
                field: field.to_string(),
                message,
            })
        };
        let a = &self.algorithm;
        if let Err(message) = stays_below(&self.experiment_name) {
            return bad("experiment_name", message);
        }
        if self.run_name.contains(['/', '\\']) {
            return bad(
                "run_name",
                format!(
                    "{:?} is a suffix of the run directory's name: it may not contain `/` or `\\`",
                    self.run_name
                ),
            );
        }
        if self.max_iterations == 0 {
            return bad(
                "max_iterations",
                "must be at least 1 (a run of no iterations would train nothing)".into(),
            );
        }
        for (field, value, max) in [
            (
                "num_steps_per_env",
                self.num_steps_per_env,
                MAX_STEPS_PER_ENV,
            ),
            ("max_iterations", self.max_iterations, MAX_ITERATIONS),
            ("save_interval", self.save_interval, MAX_ITERATIONS),
            (
                "algorithm.num_learning_epochs",
                a.num_learning_epochs,
                MAX_EPOCHS,
            ),
            (
                "algorithm.num_mini_batches",
                a.num_mini_batches,
                MAX_MINI_BATCHES,
            ),
        ] {
            if !(1..=max).contains(&value) {
                return bad(
                    field,
                    format!("{value} is out of range: expected 1 to {max}"),
                );
            }
        }
        for (field, dims) in [
            ("policy.actor_hidden_dims", &self.policy.actor_hidden_dims),
            ("policy.critic_hidden_dims", &self.policy.critic_hidden_dims),
        ] {
            if let Some(w) = dims.iter().find(|w| !(1..=MAX_LAYER_WIDTH).contains(*w)) {
                return bad(
                    field,
                    format!("layer width {w} is out of range: expected 1 to {MAX_LAYER_WIDTH}"),
                );
            }
        }
        for (field, value) in [
            ("algorithm.value_loss_coef", a.value_loss_coef),
            ("algorithm.entropy_coef", a.entropy_coef),
        ] {
            if !(value.is_finite() && value >= 0.0) {
                return bad(field, format!("must be a finite number >= 0, got {value}"));
            }
        }
        let positive = |x: f32| x > 0.0 && x.is_finite();
        if !(positive(a.gamma) && a.gamma <= 1.0) {
            return bad(
                "algorithm.gamma",
                format!("must be in (0, 1], got {}", a.gamma),
            );
        }
        if !(0.0..=1.0).contains(&a.lam) {
            return bad("algorithm.lam", format!("must be in [0, 1], got {}", a.lam));
        }
        if !(a.learning_rate > 0.0 && a.learning_rate <= 1.0) {
            return bad(
                "algorithm.learning_rate",
                format!(
                    "{} is out of range: expected above 0, at most 1",
                    a.learning_rate
                ),
            );
        }
        for (field, value) in [
            ("algorithm.clip_param", a.clip_param),
            ("algorithm.max_grad_norm", a.max_grad_norm),
            ("algorithm.desired_kl", a.desired_kl),
        ] {
            if !positive(value) {
                return bad(field, format!("must be positive, got {value}"));
            }
        }
        if !positive(self.policy.init_noise_std) {
            return bad(
                "policy.init_noise_std",
                format!("must be positive, got {}", self.policy.init_noise_std),
            );
        }
        Ok(())
    }

    /// Checks that an iteration of `num_envs` envs collects enough transitions for the
    /// minibatches (before a run directory or a rollout is spent on a run that cannot update).
    pub fn validate_batch(&self, num_envs: usize, file_name: &str) -> Result<(), crate::RlError> {
        let transitions = num_envs * self.num_steps_per_env;
        let minibatches = self.algorithm.num_mini_batches;
        if minibatches > transitions {
            return Err(crate::RlError::InvalidConfig {
                file: file_name.to_string(),
                field: "algorithm.num_mini_batches".into(),
                message: format!(
                    "{minibatches} minibatches need at least as many transitions per \
                     iteration, and {num_envs} envs × {} steps collect {transitions}: lower \
                     it, or raise the envs or `num_steps_per_env`",
                    self.num_steps_per_env
                ),
            });
        }
        Ok(())
    }
}

/// Most iterations of a run (and the longest save interval): a billion iterations is beyond
/// any run's time, so more is a typo.
pub const MAX_ITERATIONS: usize = 1_000_000_000;
/// Most env steps per env and iteration.
pub const MAX_STEPS_PER_ENV: usize = 100_000;
/// Most epochs over an iteration's transitions.
pub const MAX_EPOCHS: usize = 1000;
/// Most minibatches per epoch.
pub const MAX_MINI_BATCHES: usize = 1_000_000;
/// Widest hidden layer.
pub const MAX_LAYER_WIDTH: usize = 65_536;

/// Whether `name` is a relative path that stays below the directory it is joined to (no
/// `..`, no root, not empty): an experiment's directory must lie under the log root.
fn stays_below(name: &str) -> Result<(), String> {
    use std::path::Component;
    let path = std::path::Path::new(name);
    let leaves = path
        .components()
        .any(|c| !matches!(c, Component::Normal(_) | Component::CurDir));
    if name.is_empty() || leaves || path.components().all(|c| c == Component::CurDir) {
        return Err(format!(
            "{name:?} must name a directory below the log root (no `..`, no absolute path, \
             not empty): use a plain name such as \"box_pushing\", or pass --log-root to write \
             elsewhere"
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    const CFG: &str = "(num_steps_per_env: 24, max_iterations: 10, experiment_name: \"t\",
        policy: (init_noise_std: 1.0, actor_hidden_dims: [8], critic_hidden_dims: [8], activation: Elu),
        algorithm: (value_loss_coef: 1.0, use_clipped_value_loss: true, clip_param: 0.2,
            entropy_coef: 0.0, num_learning_epochs: 5, num_mini_batches: 4, learning_rate: 1e-3,
            schedule: Adaptive, gamma: 0.99, lam: 0.95, desired_kl: 0.01, max_grad_norm: 1.0))";

    /// Each out-of-range value is blamed on its own field, with the value it had.
    #[test]
    fn validation_names_the_offending_field() {
        assert!(RunnerCfg::from_ron(CFG, "t.ron", &[]).is_ok());
        for (field, value) in [
            ("desired_kl", "-0.01"),
            ("max_grad_norm", "0.0"),
            ("clip_param", "-0.2"),
            ("lam", "1.5"),
            ("gamma", "0.0"),
            ("num_learning_epochs", "0"),
            ("num_mini_batches", "0"),
        ] {
            let o = [format!("algorithm.{field}={value}")];
            let message = RunnerCfg::from_ron(CFG, "t.ron", &o)
                .unwrap_err()
                .to_string();
            assert!(
                message.starts_with(&format!("t.ron: field `algorithm.{field}`: ")),
                "{field}: {message}"
            );
        }
        let o = ["max_iterations=0".to_string()];
        let message = RunnerCfg::from_ron(CFG, "t.ron", &o)
            .unwrap_err()
            .to_string();
        assert!(
            message.starts_with("t.ron: field `max_iterations`: "),
            "{message}"
        );
    }

    /// An experiment name may not lead out of the log root; a run name is a suffix of one
    /// directory's name.
    #[test]
    fn run_directories_stay_below_the_log_root() {
        for name in ["../../x", "/tmp/x", "a/../../x", "", "."] {
            let o = [format!("experiment_name={name:?}")];
            let message = RunnerCfg::from_ron(CFG, "t.ron", &o)
                .unwrap_err()
                .to_string();
            assert!(
                message.starts_with("t.ron: field `experiment_name`: "),
                "{name}: {message}"
            );
        }
        for name in ["box_pushing", "franka/box_pushing", "./x"] {
            let o = [format!("experiment_name={name:?}")];
            assert!(RunnerCfg::from_ron(CFG, "t.ron", &o).is_ok(), "{name}");
        }
        let o = ["run_name=\"../up\"".to_string()];
        let message = RunnerCfg::from_ron(CFG, "t.ron", &o)
            .unwrap_err()
            .to_string();
        assert!(message.contains("field `run_name`"), "{message}");
    }
}
