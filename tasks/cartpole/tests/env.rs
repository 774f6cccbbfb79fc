//! The cart-pole's terms on one step from rest with zero force (pole upright, cart still, so
//! every penalty but the terminating one is below 1e-6 per step): a cart inside ±3 m earns the
//! alive reward, `1 · dt` with dt = 1/60 s; a cart placed beyond 3 m ends its episode as
//! terminated (not timed out) and earns the terminating penalty, `−2 · dt`, instead.

use orbit_managers::make;
use orbit_physics_rapier as _;
use orbit_task_cartpole::TASK_ID;

/// Reward, terminated and timed out after one zero-force step from the cart at `cart_pos`.
fn one_step(cart_pos: f32) -> (f32, bool, bool) {
    let o = [
        "num_envs=1".to_string(),
        "sim.backend=\"rapier\"".to_string(),
        format!("events.reset_cart_position.params.position_range=({cart_pos}, {cart_pos})"),
        "events.reset_cart_position.params.velocity_range=(0.0, 0.0)".to_string(),
        "events.reset_pole_position.params.position_range=(0.0, 0.0)".to_string(),
        "events.reset_pole_position.params.velocity_range=(0.0, 0.0)".to_string(),
    ];
    let mut env = make(TASK_ID, &o).unwrap_or_else(|e| panic!("{e}"));
    env.reset().unwrap();
    let step = env.step(&[0.0]).unwrap();
    (step.reward[0], step.terminated[0], step.time_outs[0])
}

#[test]
fn a_cart_on_the_rail_earns_the_alive_reward() {
    let (reward, terminated, time_out) = one_step(0.5);
    assert!(!terminated && !time_out);
    assert!((reward - 1.0 / 60.0).abs() < 1e-5, "reward {reward}");
}

#[test]
fn a_cart_off_the_rail_is_terminated_with_the_penalty() {
    let (reward, terminated, time_out) = one_step(3.5);
    assert!(terminated && !time_out);
    assert!((reward + 2.0 / 60.0).abs() < 1e-5, "reward {reward}");
}

/// Each value of an observation row is traced to its term (what a non-finite observation's
/// error names): the cart-pole's 4 values are two joint positions, then two velocities.
#[test]
fn observation_values_are_traced_to_their_terms() {
    let o = [
        "num_envs=1".to_string(),
        "sim.backend=\"rapier\"".to_string(),
    ];
    let env = make(TASK_ID, &o).unwrap();
    let at = |i| env.observation_term_at("policy", i);
    assert_eq!(at(1).as_deref(), Some("joint_pos_rel[1]"));
    assert_eq!(at(2).as_deref(), Some("joint_vel_rel[0]"));
    assert_eq!(at(4), None);
    assert_eq!(env.observation_term_at("critic", 0), None);
}

/// A term's error names the file and line of the term's config (here the bundled file).
#[test]
fn a_term_error_names_the_file_and_line_of_the_term() {
    let o = [
        "sim.backend=\"rapier\"".to_string(),
        "actions.joint_effort.params.effort_clip=[1.0, 2.0]".to_string(),
    ];
    let message = make(TASK_ID, &o).err().expect("refused").to_string();
    assert!(
        message.starts_with("<bundled>/cartpole/env/cartpole.ron:17:")
            && message.contains("actions.joint_effort: effort_clip has 2 values for 1 joints"),
        "{message}"
    );
}

/// A scene error blames the override that wrote the value, not the task's bundled file.
#[test]
fn a_scene_error_names_the_override_that_caused_it() {
    let joint_pos = "scene.articulations.robot.init_state.joint_pos";
    let o = [
        "sim.backend=\"rapier\"".to_string(),
        format!("{joint_pos}={{\"slider_to_cart\": 99.0, \"cart_to_pole\": 0.0}}"),
    ];
    let message = make(TASK_ID, &o).err().expect("refused").to_string();
    assert!(
        message.starts_with(&format!("override `{joint_pos}=")),
        "{message}"
    );
    assert!(message.contains("init_state.joint_pos"), "{message}");
}

/// Numbers outside their ranges are refused when the env is built, each error naming the
/// field, the value and the range (they would hang a run or simulate something else).
#[test]
fn out_of_range_numbers_are_refused_with_field_value_and_range() {
    let cases = [
        (
            "decimation=0",
            "decimation: 0 is out of range: expected 1 to 1000",
        ),
        ("decimation=100000", "decimation: 100000 is out of range"),
        (
            "sim.dt=1e-9",
            "sim.dt: 0.000000001 is out of range: expected 0.000001 to 1 seconds",
        ),
        ("sim.dt=5.0", "sim.dt: 5 is out of range"),
        (
            "sim.solver_iterations=1000000",
            "sim.solver_iterations: 1000000 is out of range",
        ),
        (
            "episode_length_s=0.001",
            "episode_length_s: 0.001 is out of range: expected 0.016",
        ),
        (
            "episode_length_s=1e9",
            "episode_length_s: 1000000000 is out of range",
        ),
        (
            "num_envs=100000000",
            "num_envs: 100000000 is out of range: expected 1 to 16777216",
        ),
        (
            "sim.gravity=(0.0, 0.0, -1e5)",
            "sim.gravity: -100000 is out of range",
        ),
        (
            "observations.policy.terms.joint_pos_rel.history_length=100000",
            "history_length: 100000 is out of range",
        ),
        (
            "scene.articulations.robot.init_state.pos=(1e6, 0.0, 0.0)",
            "init_state.pos: 1000000 is out of range: expected -10000 to 10000 metres",
        ),
    ];
    for (o, expected) in cases {
        let overrides = [
            "num_envs=1".to_string(),
            "sim.backend=\"rapier\"".to_string(),
            o.into(),
        ];
        let message = match make(TASK_ID, &overrides) {
            Ok(_) => panic!("`{o}` was accepted"),
            Err(e) => e.to_string(),
        };
        assert!(
            message.contains(expected),
            "`{o}`: `{expected}` not in: {message}"
        );
    }
}
