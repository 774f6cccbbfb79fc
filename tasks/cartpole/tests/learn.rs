//! PPO balances the cart-pole on the CPU within the CI budget: Isaac Lab's training config as
//! registered (150 iterations of 16 steps), 512 envs on rapier (≈ 1.2 M transitions). An
//! episode is 5 s and the alive reward is 1 per second, so a pole swung up and kept upright with
//! the cart on its rail earns just under 5. Over one episode in each of 64 fresh envs, the
//! trained mean-action policy earns more than 4.5 on average and in at least 60 envs (a pole
//! that starts at 45° and falling takes a while to right, and may drive the cart off its
//! rail); the untrained policy earns under 2.

use orbit_envs::RlVecEnv;
use orbit_managers::make;
use orbit_physics_rapier as _;
use orbit_rl::burn::tensor::Device;
use orbit_rl::{OnPolicyRunner, Policy, RunnerCfg, VecEnv};
use orbit_task_cartpole::TASK_ID;

fn env(num_envs: usize, seed: u64) -> RlVecEnv {
    let o = [
        format!("num_envs={num_envs}"),
        format!("seed={seed}"),
        "sim.backend=\"rapier\"".to_string(),
    ];
    RlVecEnv::new(make(TASK_ID, &o).unwrap_or_else(|e| panic!("{e}"))).unwrap()
}

/// Each of 64 envs' return over one episode of the policy's mean actions, and how many envs
/// ended their episode early (the cart off its rail).
fn evaluate(policy: &Policy) -> (Vec<f32>, usize) {
    let mut env = env(64, 1234);
    let mut returns = vec![0.0f32; 64];
    let mut done = [false; 64];
    let mut terminated = 0;
    while !done.iter().all(|&d| d) {
        let actions = policy.act(env.observations());
        let step = env.step(&actions).unwrap();
        for e in 0..64 {
            if !done[e] {
                returns[e] += step.rewards[e];
                done[e] = step.dones[e];
                terminated += usize::from(step.dones[e] && !step.time_outs[e]);
            }
        }
    }
    (returns, terminated)
}

#[test]
fn ppo_balances_the_pole() {
    let def = orbit_managers::task(TASK_ID).unwrap();
    let agent = def.agent.expect("cart-pole has a PPO config");
    let cfg = RunnerCfg::load(&agent, &[]).unwrap_or_else(|e| panic!("{e}"));
    let iterations = cfg.max_iterations;
    let mut runner = OnPolicyRunner::new(env(512, 0), cfg, None, Device::flex()).unwrap();
    let (before, _) = evaluate(&runner.inference_policy());
    runner.learn(iterations).unwrap();
    let (after, terminated) = evaluate(&runner.inference_policy());
    let mean = |r: &[f32]| r.iter().sum::<f32>() / r.len() as f32;
    let balanced = after.iter().filter(|&&r| r > 4.5).count();
    println!(
        "return: untrained mean {:.3}, trained mean {:.3}, {balanced} of 64 envs above 4.5, \
         {terminated} off the rail",
        mean(&before),
        mean(&after)
    );
    assert!(mean(&before) < 2.0, "untrained return {}", mean(&before));
    assert!(mean(&after) > 4.5, "trained returns {after:?}");
    assert!(balanced >= 60, "trained returns {after:?}");
    assert!(
        terminated <= 64 - balanced,
        "{terminated} carts left the rail"
    );
}
