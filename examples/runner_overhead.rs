//! The on-policy runner's own work per env step, apart from the env and the policy: the runner
//! trains a tiny policy on a null env (observations that change every step, no physics) and
//! prints, per env count, the collection time split into env, policy and the rest, which is
//! the runner's copying, checking and normalising of the observations and its bookkeeping.
//!
//! ```text
//! cargo run --release --example runner_overhead -- --num-envs 4096,65536
//! ```
//!
//! The sizes default to box pushing's (35 observations, 7 actions, 24 steps per iteration).
//! The policy runs on the CPU learner; its time is reported but is not what this measures.

use std::collections::BTreeMap;

use clap::Parser;
use orbit::envs::VecEnvError;
use orbit::rl::burn::tensor::Device;
use orbit::rl::{OnPolicyRunner, RunnerCfg, VecEnv, VecEnvStep};

#[derive(Parser)]
#[command(about = "The on-policy runner's own work per env step, on a null env")]
struct Args {
    /// Comma-separated env counts.
    #[arg(long, value_delimiter = ',', default_value = "4096,65536")]
    num_envs: Vec<usize>,
    /// Observations per env.
    #[arg(long, default_value_t = 35)]
    num_obs: usize,
    /// Actions per env.
    #[arg(long, default_value_t = 7)]
    num_actions: usize,
    /// Measured iterations per env count (after one warm-up iteration).
    #[arg(long, default_value_t = 3)]
    iterations: usize,
}

/// Observations that change every step, constant rewards, and every env ending its episode
/// once in 100 steps (staggered), so the runner's episode bookkeeping runs too.
struct NullEnv {
    obs: Vec<f32>,
    num_actions: usize,
    rewards: Vec<f32>,
    dones: Vec<bool>,
    time_outs: Vec<bool>,
    log: BTreeMap<String, f32>,
    step: u32,
}

impl NullEnv {
    fn new(num_envs: usize, num_obs: usize, num_actions: usize) -> Self {
        Self {
            obs: vec![0.0; num_envs * num_obs],
            num_actions,
            rewards: vec![-1.0; num_envs],
            dones: vec![false; num_envs],
            time_outs: vec![false; num_envs],
            log: (0..10)
                .map(|k| (format!("Episode Reward/term_{k}"), 0.5))
                .collect(),
            step: 0,
        }
    }
}

impl VecEnv for NullEnv {
    fn num_envs(&self) -> usize {
        self.rewards.len()
    }
    fn num_actions(&self) -> usize {
        self.num_actions
    }
    fn num_obs(&self) -> usize {
        self.obs.len() / self.rewards.len()
    }
    fn num_critic_obs(&self) -> usize {
        self.num_obs()
    }
    fn max_episode_length(&self) -> u32 {
        100
    }
    fn observations(&self) -> &[f32] {
        &self.obs
    }
    fn critic_observations(&self) -> &[f32] {
        &self.obs
    }
    fn step(&mut self, _actions: &[f32]) -> Result<VecEnvStep<'_>, VecEnvError> {
        self.step += 1;
        for (i, o) in self.obs.iter_mut().enumerate() {
            *o = ((i as u32 ^ self.step) % 97) as f32 * 0.01;
        }
        for (e, d) in self.dones.iter_mut().enumerate() {
            *d = (e as u32 + self.step).is_multiple_of(100);
        }
        Ok(VecEnvStep {
            rewards: &self.rewards,
            dones: &self.dones,
            // Time-outs never happen here: every end is a termination.
            terminated: &self.dones,
            time_outs: &self.time_outs,
            log: &self.log,
            interactions: 1,
        })
    }
    fn reset(&mut self) -> Result<(), VecEnvError> {
        self.dones.fill(false);
        Ok(())
    }
    fn randomize_episode_lengths(&mut self, _seed: u64) -> Result<(), VecEnvError> {
        Ok(())
    }
}

/// Observation and value normalisation on, as in the box-pushing config; a one-layer policy
/// and one epoch keep the policy and the update short.
const CFG: &str = r#"(
    num_steps_per_env: 24,
    max_iterations: 1,
    experiment_name: "runner_overhead",
    empirical_normalization: true,
    policy: (init_noise_std: 1.0, actor_hidden_dims: [8], critic_hidden_dims: [8], activation: Elu),
    algorithm: (
        value_loss_coef: 1.0, use_clipped_value_loss: true, clip_param: 0.2, entropy_coef: 0.0,
        num_learning_epochs: 1, num_mini_batches: 4, learning_rate: 1e-3, schedule: Adaptive,
        gamma: 0.99, lam: 0.95, desired_kl: 0.01, max_grad_norm: 1.0, normalize_value: true,
    ),
)"#;

// Errors are printed as their messages, not as debug structs.
fn main() -> std::process::ExitCode {
    orbit::init_logging();
    orbit::exit_code(run())
}

fn run() -> Result<(), Box<dyn std::error::Error>> {
    let args = Args::parse();
    println!(
        "{} observations, {} actions, 24 steps per iteration, {} cores; ms per env step (median of {} iterations)",
        args.num_obs,
        args.num_actions,
        std::thread::available_parallelism().map_or(1, |n| n.get()),
        args.iterations
    );
    println!("| envs | collection | env | policy | runner's own work |");
    println!("|-----:|-----:|-----:|-----:|-----:|");
    for &n in &args.num_envs {
        let env = NullEnv::new(n, args.num_obs, args.num_actions);
        let cfg = RunnerCfg::from_ron(CFG, "runner_overhead.ron", &[])?;
        let mut runner = OnPolicyRunner::new(env, cfg, None, Device::flex())?;
        runner.learn(1 + args.iterations)?;
        let per_step = |f: &dyn Fn(&orbit::rl::IterationLog) -> f64| {
            let mut v: Vec<f64> = runner.history[1..].iter().map(f).collect();
            v.sort_by(f64::total_cmp);
            1e3 * v[v.len() / 2] / 24.0
        };
        println!(
            "| {n} | {:.2} | {:.2} | {:.2} | {:.2} |",
            per_step(&|h| h.collection_time),
            per_step(&|h| h.env_time),
            per_step(&|h| h.policy_time),
            per_step(&|h| h.collection_time - h.env_time - h.policy_time),
        );
    }
    Ok(())
}
