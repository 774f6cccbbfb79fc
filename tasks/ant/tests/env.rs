//! The Ant task's observations and rewards on its first step, the Ant released upright from
//! Isaac Lab's start pose (joint offsets off) with zero torques: it falls freely for 1/60 s
//! (its feet start 2 cm above the ground), so every quantity has a closed form.

use orbit_managers::{ManagerBasedRlEnv, make};
use orbit_physics_rapier as _;
use orbit_task_ant::TASK_ID;

const DT: f32 = 1.0 / 60.0;
const G: f32 = 9.81;

/// The env after one zero-torque step from the start pose moving at `vx` m/s along x, and the
/// step's reward.
fn stepped(vx: f32) -> (ManagerBasedRlEnv, f32) {
    let o = [
        "num_envs=1".to_string(),
        "sim.backend=\"rapier\"".to_string(),
        "events.reset_robot_joints.params.position_range=(0.0, 0.0)".to_string(),
        "events.reset_robot_joints.params.velocity_range=(0.0, 0.0)".to_string(),
        format!("events.reset_base.params.lin_vel_range=(({vx}, {vx}), (0.0, 0.0), (0.0, 0.0))"),
    ];
    let mut env = make(TASK_ID, &o).unwrap_or_else(|e| panic!("{e}"));
    env.reset().unwrap();
    let reward = env.step(&[0.0; 8]).unwrap().reward[0];
    (env, reward)
}

/// [`stepped`]'s observation row and reward.
fn one_step(vx: f32) -> (Vec<f32>, f32) {
    let (env, reward) = stepped(vx);
    let (obs, dim) = env.observation("policy").expect("policy observations");
    assert_eq!(dim, 36, "Isaac Lab's 60 values less the 24 foot forces");
    (obs.to_vec(), reward)
}

/// The progress term after one step at 1 m/s, evaluated twice.
fn progress_twice() -> (f32, f32) {
    let (mut env, _) = stepped(1.0);
    let mut progress = || {
        let terms = env.evaluate_reward_terms();
        terms
            .iter()
            .find(|(n, _)| n == "progress")
            .expect("progress term")
            .1[0]
    };
    (progress(), progress())
}

/// Upright and facing the target: height 0.5 − g t²/2, velocity (vx, 0, −g t) in base axes,
/// yaw, roll and angle to the target 0, up and heading projections 1; hips at the middle of
/// their range (0), ankles 45° into ranges of 30–100° (±0.571); joint velocities and actions
/// 0.
#[test]
fn a_falling_ant_observes_its_height_velocity_and_heading() {
    let (obs, _) = one_step(0.5);
    let t = DT;
    let ankle = 2.0 * (45.0 - 65.0) / 70.0;
    let mut want = vec![0.5 - 0.5 * G * t * t, 0.5, 0.0, -G * t, 0.0, 0.0, 0.0];
    want.extend([0.0, 0.0, 0.0, 1.0, 1.0]);
    want.extend([0.0, ankle, 0.0, -ankle, 0.0, -ankle, 0.0, ankle]);
    want.extend([0.0; 16]);
    for (k, (got, want)) in obs.iter().zip(&want).enumerate() {
        // Semi-implicit Euler's height is off the analytic one by g t h / 2 = 0.7 mm.
        assert!(
            (got - want).abs() < 1e-3,
            "observation {k}: {got} vs {want}\n{obs:?}"
        );
    }
}

/// Alive (0.5), upright (0.1) and facing the target (0.5) earn 1.1 per second; moving towards
/// it at 1 m/s adds its progress, 1 per second. No torque costs nothing.
#[test]
fn progress_towards_the_target_is_rewarded_at_its_speed() {
    let (_, still) = one_step(0.0);
    let (_, moving) = one_step(1.0);
    assert!((still - 1.1 * DT).abs() < 1e-5, "reward {still}");
    assert!(
        (moving - still - DT).abs() < 1e-5,
        "progress {}",
        moving - still
    );
}

/// Inspecting the terms after a step reads the step's progress, 1 m/s, and leaves the term's
/// state alone: a second inspection reads the same.
#[test]
fn inspecting_the_progress_term_repeats_its_value() {
    let (first, second) = progress_twice();
    assert!((first - 1.0).abs() < 1e-3, "progress {first} m/s");
    assert_eq!(first, second);
}
