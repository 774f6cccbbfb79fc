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
