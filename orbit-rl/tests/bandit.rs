//! PPO on a contextual bandit with a known optimum: the observation is a random context
//! `c ∈ [−1, 1]²`, the reward `−‖a − c‖²`, every episode one step long. The best policy outputs
//! `a = c` with zero noise (return 0); the untrained one earns about −(‖c‖² + 2σ²) ≈ −2.67.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

use orbit_core::rng::EnvRng;
use orbit_envs::VecEnvError;
use orbit_rl::burn::tensor::Device;
use orbit_rl::{OnPolicyRunner, RlError, RunnerCfg, VecEnv, VecEnvStep};

struct Bandit {
    rng: EnvRng,
    obs: Vec<f32>,
    /// A copy of `obs` in memory of its own, given as the critic's observations (else the
    /// critic is given `obs` itself).
    critic: Option<Vec<f32>>,
    rewards: Vec<f32>,
    dones: Vec<bool>,
    time_outs: Vec<bool>,
    log: BTreeMap<String, f32>,
    /// Steps taken, and the step after which env 1's first observation is NaN.
    steps: usize,
    nan_after: Option<usize>,
    /// A flag this env sets after a given step, as a signal handler would mid-iteration.
    stop_after: Option<(usize, Arc<AtomicBool>)>,
}

impl Bandit {
    fn new(n: usize) -> Self {
        let mut b = Self {
            rng: EnvRng::new(9, 0, 1),
            obs: vec![0.0; 2 * n],
            critic: None,
            rewards: vec![0.0; n],
            dones: vec![true; n],
            time_outs: vec![false; n],
            log: BTreeMap::new(),
            steps: 0,
            nan_after: None,
            stop_after: None,
        };
        b.draw();
        b
    }

    fn with_separate_critic(mut self) -> Self {
        self.critic = Some(self.obs.clone());
        self
    }

    fn draw(&mut self) {
        for o in &mut self.obs {
            *o = self.rng.uniform_range(-1.0, 1.0);
        }
        if let Some(c) = &mut self.critic {
            c.copy_from_slice(&self.obs);
        }
    }
}

impl VecEnv for Bandit {
    fn num_envs(&self) -> usize {
        self.rewards.len()
    }
    fn num_actions(&self) -> usize {
        2
    }
    fn num_obs(&self) -> usize {
        2
    }
    fn num_critic_obs(&self) -> usize {
        2
    }
    fn max_episode_length(&self) -> u32 {
        1
    }
    fn observations(&self) -> &[f32] {
        &self.obs
    }
    fn critic_observations(&self) -> &[f32] {
        self.critic.as_deref().unwrap_or(&self.obs)
    }
    fn step(&mut self, actions: &[f32]) -> Result<VecEnvStep<'_>, VecEnvError> {
        for (e, r) in self.rewards.iter_mut().enumerate() {
            *r = -(0..2)
                .map(|i| (actions[2 * e + i] - self.obs[2 * e + i]).powi(2))
                .sum::<f32>();
        }
        self.draw();
        self.steps += 1;
        if self.nan_after == Some(self.steps) {
            self.obs[2] = f32::NAN;
        }
        if let Some((step, flag)) = &self.stop_after
            && *step == self.steps
        {
            flag.store(true, Ordering::Relaxed);
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

const CFG: &str = r#"(
    num_steps_per_env: 8,
    max_iterations: 40,
    experiment_name: "bandit",
    policy: (init_noise_std: 1.0, actor_hidden_dims: [32, 32], critic_hidden_dims: [32, 32], activation: Elu),
    algorithm: (
        value_loss_coef: 1.0, use_clipped_value_loss: true, clip_param: 0.2, entropy_coef: 0.0,
        num_learning_epochs: 5, num_mini_batches: 4, learning_rate: 1e-3, schedule: Adaptive,
        gamma: 0.99, lam: 0.95, desired_kl: 0.01, max_grad_norm: 1.0,
    ),
)"#;

#[test]
fn ppo_solves_a_contextual_bandit() {
    let cfg = RunnerCfg::from_ron(CFG, "bandit.ron", &[]).unwrap();
    let mut runner = OnPolicyRunner::new(Bandit::new(64), cfg, None, Device::flex()).unwrap();
    runner.learn(40).unwrap();
    let returns: Vec<f32> = runner
        .history
        .iter()
        .map(|h| h.mean_return.unwrap())
        .collect();
    println!("{returns:?}");
    // The policy's mean must track the context: check it on fresh contexts.
    let policy = runner.inference_policy();
    let ctx = [0.5f32, -0.5, -0.8, 0.3];
    let a = policy.act(&ctx);
    let err: f32 = a
        .iter()
        .zip(&ctx)
        .map(|(a, c)| (a - c).powi(2))
        .sum::<f32>()
        / 2.0;
    assert!(returns[0] < -2.0, "untrained return {}", returns[0]);
    assert!(err < 0.02, "mean actions {a:?} for contexts {ctx:?}");
}

/// An env that gives the critic its actor observations (no `critic` group) lets the runner
/// normalise and upload them once; training must be exactly what separate copies of the same
/// values give, normalisers included.
#[test]
fn a_critic_sharing_the_actor_observations_trains_the_same() {
    let train = |env: Bandit| {
        let cfg = RunnerCfg::from_ron(CFG, "bandit.ron", &["empirical_normalization=true".into()])
            .unwrap();
        let mut runner = OnPolicyRunner::new(env, cfg, None, Device::flex()).unwrap();
        runner.learn(4).unwrap();
        runner
            .history
            .iter()
            .map(|h| {
                let l = &h.losses;
                [l.value, l.surrogate, h.mean_return.unwrap()].map(f32::to_bits)
            })
            .collect::<Vec<_>>()
    };
    let shared = train(Bandit::new(64));
    let separate = train(Bandit::new(64).with_separate_critic());
    assert_eq!(shared, separate);
}

/// A NaN observation stops training with an error that names the env and the entry.
#[test]
fn a_nan_observation_is_an_error_naming_env_and_entry() {
    let cfg =
        RunnerCfg::from_ron(CFG, "bandit.ron", &["empirical_normalization=true".into()]).unwrap();
    let mut env = Bandit::new(4);
    env.nan_after = Some(3);
    let mut runner = OnPolicyRunner::new(env, cfg, None, Device::flex()).unwrap();
    match runner.learn(1) {
        Err(RlError::NonFinite(msg)) => {
            assert!(msg.contains("env 1's policy observation 0"), "{msg}")
        }
        other => panic!("expected a NonFinite error, got {other:?}"),
    }
}

/// A checkpoint whose observation statistics are not finite (1e39 overflows an f32) is refused
/// when loaded, naming the file and the statistic, by `play`'s policy and by a resuming
/// runner alike, instead of surfacing later as a diverged update.
#[test]
fn a_checkpoint_with_non_finite_statistics_is_refused_naming_them() {
    let dir = run_dir("non-finite-checkpoint");
    let cfg =
        RunnerCfg::from_ron(CFG, "bandit.ron", &["empirical_normalization=true".into()]).unwrap();
    let mut runner = OnPolicyRunner::new(
        Bandit::new(8),
        cfg.clone(),
        Some(dir.clone()),
        Device::flex(),
    )
    .unwrap();
    runner.learn(1).unwrap();
    let base = dir.join("model_0");
    let json = base.with_extension("json");
    let mut state: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&json).unwrap()).unwrap();
    state["obs_normalizer"]["mean"][1] = serde_json::json!(1e39);
    std::fs::write(&json, serde_json::to_string(&state).unwrap()).unwrap();
    let e = orbit_rl::Policy::load(&base, Device::flex())
        .err()
        .expect("refused")
        .to_string();
    assert!(
        e.contains("model_0.json") && e.contains("mean[1] (inf) is not finite"),
        "{e}"
    );
    let mut resumed = OnPolicyRunner::new(Bandit::new(8), cfg, None, Device::flex()).unwrap();
    let e = resumed.load_checkpoint(&base).unwrap_err().to_string();
    assert!(e.contains("mean[1] (inf) is not finite"), "{e}");
    assert!(!e.contains("learning rate"), "{e}");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A fresh, empty directory for a test's run files.
fn run_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("orbit-bandit-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

/// The bytes of a checkpoint's three files.
fn checkpoint_bytes(base: &Path) -> Vec<Vec<u8>> {
    ["bpk", "adam.bpk", "json"]
        .map(|ext| std::fs::read(base.with_extension(ext)).unwrap())
        .to_vec()
}

/// A checkpoint write that fails (here a directory stands where its last file is staged, as a
/// full disk would fail it) is an error at once naming the file; it leaves no part of the new
/// checkpoint behind and the previous checkpoint byte for byte as it was, still loadable.
#[test]
fn a_failed_checkpoint_write_is_reported_and_keeps_the_previous_one() {
    let dir = run_dir("failed-write");
    let cfg = RunnerCfg::from_ron(CFG, "bandit.ron", &[]).unwrap();
    let mut runner =
        OnPolicyRunner::new(Bandit::new(8), cfg, Some(dir.clone()), Device::flex()).unwrap();
    runner.learn(1).unwrap();
    let previous = dir.join("model_0");
    let before = checkpoint_bytes(&previous);
    std::fs::create_dir(dir.join("model_1.json.partial")).unwrap();
    match runner.learn(1) {
        Err(RlError::Io { path, .. }) => assert!(path.ends_with("model_1.json.partial")),
        other => panic!("expected the failed write as an error, got {other:?}"),
    }
    for name in [
        "model_1.bpk",
        "model_1.adam.bpk",
        "model_1.json",
        "model_1.bpk.partial",
    ] {
        assert!(!dir.join(name).exists(), "{name} was left behind");
    }
    assert_eq!(checkpoint_bytes(&previous), before);
    orbit_rl::Policy::load(&previous, Device::flex()).unwrap();
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A stop request in the middle of an iteration ends `learn` at the next step with a
/// checkpoint of the last finished iteration (saved now: the save interval is far off), and a
/// runner resuming from it continues with the next iteration.
#[test]
fn a_stop_request_saves_a_checkpoint_that_resumes() {
    let dir = run_dir("stop");
    let cfg = RunnerCfg::from_ron(CFG, "bandit.ron", &["save_interval=100".into()]).unwrap();
    let stop = Arc::new(AtomicBool::new(false));
    let mut env = Bandit::new(8);
    // 8 steps per iteration: step 28 is in the middle of the fourth iteration (index 3).
    env.stop_after = Some((28, Arc::clone(&stop)));
    let mut runner =
        OnPolicyRunner::new(env, cfg.clone(), Some(dir.clone()), Device::flex()).unwrap();
    runner.stop = Some(stop);
    let checkpoint = match runner.learn(40) {
        Err(RlError::Interrupted {
            iterations: 3,
            checkpoint: Some(base),
        }) => base,
        other => panic!("expected a stop after 3 iterations, got {other:?}"),
    };
    assert_eq!(checkpoint, dir.join("model_2"));
    assert_eq!(
        orbit_rl::runner::read_state(&checkpoint).unwrap().iteration,
        3
    );

    let resumed_dir = run_dir("stop-resumed");
    let mut resumed = OnPolicyRunner::new(
        Bandit::new(8),
        cfg,
        Some(resumed_dir.clone()),
        Device::flex(),
    )
    .unwrap();
    resumed.load_checkpoint(&checkpoint).unwrap();
    resumed.learn(1).unwrap();
    assert_eq!(resumed.history[0].iteration, 3);
    assert!(resumed_dir.join("model_3.json").exists());
    for d in [dir, resumed_dir] {
        std::fs::remove_dir_all(d).unwrap();
    }
}
