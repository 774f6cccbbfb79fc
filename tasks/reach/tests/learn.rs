//! PPO learns on the CPU within the CI budget. The test trains a fixed-target variant of the
//! reach task (2 s episodes, position reward only, 64 envs, 80 iterations ≈ 123 k transitions):
//! Isaac Lab's full reach task needs ~10⁷ transitions, far beyond a CI run. Afterwards the
//! mean-action policy ends its episodes much closer to the target than the untrained one.

use orbit_envs::RlVecEnv;
use orbit_managers::make;
use orbit_physics_rapier as _;
use orbit_rl::burn::tensor::Device;
use orbit_rl::{OnPolicyRunner, Policy, RunnerCfg, VecEnv};
use orbit_task_reach::TASK_ID;

/// The fixed-target variant: target (0.5, 0.1, 0.3) m in the robot's base frame.
const ENV: &[&str] = &[
    "episode_length_s=2.0",
    "rewards.end_effector_orientation_tracking.weight=0.0",
    "commands.ee_pose.params.ranges.pos_x=(0.5, 0.5)",
    "commands.ee_pose.params.ranges.pos_y=(0.1, 0.1)",
    "commands.ee_pose.params.ranges.pos_z=(0.3, 0.3)",
];

/// Smaller exploration noise and a fixed learning rate suit 1.5 k-transition iterations.
const AGENT: &[&str] = &[
    "max_iterations=80",
    "empirical_normalization=true",
    "policy.init_noise_std=0.5",
    "algorithm.schedule=Fixed",
    "algorithm.learning_rate=5e-4",
    "algorithm.num_learning_epochs=5",
];

fn env(num_envs: usize, seed: u64) -> RlVecEnv {
    let mut o = vec![format!("num_envs={num_envs}"), format!("seed={seed}")];
    o.extend(ENV.iter().map(|s| s.to_string()));
    RlVecEnv::new(make(TASK_ID, &o).unwrap_or_else(|e| panic!("{e}"))).unwrap()
}

/// Mean final tcp–target distance (m) and mean return of the policy's mean actions over one
/// episode in each of 64 envs.
fn evaluate(policy: &Policy) -> (f32, f32) {
    let mut env = env(64, 1234);
    let mut ret = 0.0f32;
    loop {
        let actions = policy.act(env.observations());
        let step = env.step(&actions).unwrap();
        ret += step.rewards.iter().sum::<f32>() / 64.0;
        if step.dones.iter().all(|&d| d) {
            return (step.log["Metrics/ee_pose/position_error"], ret);
        }
    }
}

#[test]
fn ppo_learns_to_reach() {
    let def = orbit_managers::task(TASK_ID).unwrap();
    let o: Vec<String> = AGENT.iter().map(|s| s.to_string()).collect();
    let agent = def.agent.expect("reach has a PPO config");
    let cfg = RunnerCfg::load(&agent, &o).unwrap_or_else(|e| panic!("{e}"));
    let iterations = cfg.max_iterations;
    let mut runner = OnPolicyRunner::new(env(64, 0), cfg, None, Device::flex()).unwrap();
    let (d0, r0) = evaluate(&runner.inference_policy());
    runner.learn(iterations).unwrap();
    let (d1, r1) = evaluate(&runner.inference_policy());
    println!("final distance {d0:.4} m -> {d1:.4} m, return {r0:.4} -> {r1:.4}");
    assert!(
        d1 < 0.7 * d0,
        "final distance: untrained {d0} m, trained {d1} m"
    );
    assert!(r1 > r0 + 0.05, "return: untrained {r0}, trained {r1}");
}
