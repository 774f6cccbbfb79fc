//! The reward manager's arithmetic with several terms: each env's reward is `Σ wₖ·rₖ·dt`, and
//! the episode sums kept per env and term give `Episode Reward/<term>` at a reset.

use orbit_managers::ManagerBasedRlEnv;
use orbit_managers::term::*;
use orbit_physics_rapier as _;

/// Env `e`'s value is `e + 1`.
struct EnvIndex;
impl RewardTerm for EnvIndex {
    fn compute(&mut self, _: &orbit_managers::EnvView<'_>, out: &mut [f32]) {
        for (e, o) in out.iter_mut().enumerate() {
            *o = (e + 1) as f32;
        }
    }
}

/// 1 everywhere.
struct One;
impl RewardTerm for One {
    fn compute(&mut self, _: &orbit_managers::EnvView<'_>, out: &mut [f32]) {
        out.fill(1.0);
    }
}

inventory::submit! { RewardTermDef { name: "reward_sums_env_index", build: |_| Ok(Box::new(EnvIndex)) } }
inventory::submit! { RewardTermDef { name: "reward_sums_one", build: |_| Ok(Box::new(One)) } }

/// Four envs, 30 ms steps, 3-step episodes (0.09 s); terms `index` (weight 2), `one`
/// (weight −0.5) and `off` (weight 0).
const CFG: &str = r#"(
    num_envs: 4,
    decimation: 3,
    sim: (dt: 0.01),
    scene: (env_spacing: 2.5, articulations: {"robot": (asset: "franka_panda_rod")}, rigid_objects: {"box": (asset: "push_box")}, static_objects: {"table": (asset: "lab_table"), "robot_mount": (asset: "franka_mount")}),
    actions: {"arm": (func: "joint_effort", params: {"asset": "robot", "joint_names": ["panda_joint.*"]})},
    observations: {"policy": (terms: {"q": (func: "joint_pos")})},
    episode_length_s: 0.09,
    rewards: {
        "index": (func: "reward_sums_env_index", weight: 2.0),
        "one": (func: "reward_sums_one", weight: -0.5),
        "off": (func: "reward_sums_env_index", weight: 0.0),
    },
    terminations: {"time_out": (func: "time_out", time_out: true)},
)"#;

#[test]
fn rewards_and_episode_sums_follow_each_term_and_env() {
    let mut env = ManagerBasedRlEnv::from_ron(CFG, "reward_sums.ron", &[]).unwrap();
    env.reset().unwrap();
    let dt = 0.03f32;
    let actions = vec![0.0; 4 * env.action_dim()];
    for step in 1..=3 {
        let r = env.step(&actions).unwrap();
        for e in 0..4 {
            let expected = (2.0 * (e + 1) as f32 - 0.5) * dt;
            assert!(
                (r.reward[e] - expected).abs() < 1e-6,
                "step {step}, env {e}: reward {} instead of {expected}",
                r.reward[e]
            );
        }
        if step < 3 {
            continue;
        }
        // All four time out: the mean episodic sum over the envs, per second of episode.
        assert!(r.time_outs.iter().all(|&t| t));
        let log = &r.extras.log;
        let episode_s = 3.0 * dt;
        let index = (1..=4).map(|i| 3.0 * 2.0 * i as f32 * dt).sum::<f32>() / 4.0 / episode_s;
        assert!(
            (log["Episode Reward/index"] - index).abs() < 1e-4,
            "{log:?}"
        );
        assert!((log["Episode Reward/one"] + 0.5).abs() < 1e-5, "{log:?}");
        assert_eq!(log["Episode Reward/off"], 0.0);
    }
    // The sums start again from zero: one more episode logs the same values.
    for _ in 0..3 {
        let r = env.step(&actions).unwrap();
        if r.time_outs[0] {
            assert!((r.extras.log["Episode Reward/one"] + 0.5).abs() < 1e-5);
        }
    }
}
