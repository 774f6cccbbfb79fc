use glam::Vec3;
use orbit_managers::{EnvError, ManagerBasedRlEnv, make};
use orbit_physics_rapier as _;
use orbit_task_box_to_spot as _;

const TASK: &str = "BoxToSpot-JointPos-Franka-v0";

fn env(overrides: &[&str]) -> ManagerBasedRlEnv {
    let o: Vec<String> = overrides.iter().map(|s| s.to_string()).collect();
    make(TASK, &o).unwrap_or_else(|e| panic!("{e}"))
}

/// One zero-action step from the default box pose: reward = −50 · step_dt · ‖p_box − spot‖.
#[test]
fn distance_reward_matches_hand_computation() {
    let mut env = env(&[
        "num_envs=1",
        "events.box_pose.params=(asset: \"box\")", // zero offsets: box at (0.4, 0.3, -0.01)
        "rewards.joint_vel.weight=0.0",
        "rewards.action_rate.weight=0.0",
    ]);
    env.reset().unwrap();
    let zero = vec![0.0; env.action_dim()];
    let r = env.step(&zero).unwrap().reward[0];
    let b = env.scene().rigid_object("test", "box").unwrap();
    let d = (env.scene().backend.rigid_object(b).pos[0] - Vec3::new(0.5, 0.0, -0.01)).length();
    assert!((d - 0.1f32.sqrt()).abs() < 1e-3, "box moved: d = {d}");
    assert!(
        (r - d * -50.0 * env.step_dt()).abs() < 1e-6,
        "reward {r}, d {d}"
    );
}

#[test]
fn episode_times_out_after_150_steps() {
    let mut env = env(&["num_envs=2"]);
    assert_eq!(env.max_episode_length(), 150); // 3 s / (0.002 s × 10)
    env.reset().unwrap();
    let zero = vec![0.0; 2 * env.action_dim()];
    for step in 1..=150 {
        let r = env.step(&zero).unwrap();
        assert_eq!(
            (r.time_outs[0], r.terminated[0]),
            (step == 150, false),
            "step {step}"
        );
    }
    assert_eq!(env.episode_length(), &[0u32, 0], "both envs were reset");
}

#[test]
fn misspelt_param_names_field_and_key() {
    let bad = ["rewards.box_to_spot.params=(pointt: (0.5, 0.0, 0.0))".to_string()];
    let Err(EnvError::InvalidTerm { field, message }) = make(TASK, &bad) else {
        panic!("expected EnvError::InvalidTerm");
    };
    assert_eq!(field, "rewards.box_to_spot.params");
    assert!(message.contains("pointt"), "{message}");
}
