//! The base-state terms on a floating base in free fall: the Ant released 1 m above the
//! ground, rolled 30° about x, falls for four physics steps of 1/120 s (two env steps) without
//! touching it. Semi-implicit Euler gives the speed `g h n` exactly and a height between what
//! explicit and semi-implicit Euler give; in base axes the fall points along
//! `(0, −sin 30°, −cos 30°)`, the direction `projected_gravity` reports. The episode ends when
//! the base sinks below `minimum_height` (0.99 m here), in the third env step.

use orbit_managers::ManagerBasedRlEnv;
use orbit_physics_rapier as _;

const CFG: &str = r#"(
    num_envs: 1,
    decimation: 2,
    episode_length_s: 10.0,
    sim: (dt: 0.008333333, backend: "rapier"),
    scene: (
        env_spacing: 5.0,
        articulations: {"robot": (asset: "ant", init_state: (pos: (0.0, 0.0, 1.0), rot: (0.9659258, 0.258819, 0.0, 0.0)))},
        static_objects: {"ground": (asset: "ground_plane")},
    ),
    actions: {"effort": (func: "joint_effort", params: (joint_names: [".*"]))},
    observations: {"policy": (terms: {
        "a_height": (func: "base_pos_z"),
        "b_lin_vel": (func: "base_lin_vel"),
        "c_ang_vel": (func: "base_ang_vel"),
        "d_gravity": (func: "projected_gravity"),
    })},
    terminations: {
        "low": (func: "root_height_below_minimum", params: (minimum_height: 0.99)),
        "time_out": (func: "time_out", time_out: true),
    },
)"#;

#[test]
fn a_falling_base_reports_its_height_velocity_and_gravity_in_base_axes() {
    let mut env = ManagerBasedRlEnv::from_ron(CFG, "base_state.ron", &[]).unwrap();
    env.reset().unwrap();
    let zero = vec![0.0; env.action_dim()];
    for _ in 0..2 {
        let r = env.step(&zero).unwrap();
        assert!(!r.terminated[0], "the base is still above 0.99 m");
    }
    let (obs, dim) = env.observation("policy").unwrap();
    assert_eq!(dim, 10);
    let (g, h, n) = (9.81f32, 0.008333333f32, 4.0f32);
    let (lo, hi) = (
        1.0 - g * h * h * n * (n + 1.0) / 2.0,
        1.0 - g * h * h * n * (n - 1.0) / 2.0,
    );
    assert!(
        (lo - 1e-5..=hi + 1e-5).contains(&obs[0]),
        "height {} outside [{lo}, {hi}]",
        obs[0]
    );
    let speed = g * h * n;
    let (s, c) = (0.5f32, 0.75f32.sqrt());
    let expected = [0.0, -s * speed, -c * speed, 0.0, 0.0, 0.0, 0.0, -s, -c];
    for (k, (&got, want)) in obs[1..].iter().zip(expected).enumerate() {
        assert!(
            (got - want).abs() < 1e-4,
            "value {k}: {got} instead of {want} ({obs:?})"
        );
    }
    let r = env.step(&zero).unwrap();
    assert!(
        r.terminated[0] && !r.time_outs[0],
        "below 0.99 m the episode ends"
    );
}
