//! The Humanoid task's observations and rewards on its first step, released upright from
//! Isaac Lab's start pose (joint offsets off) with zero torques: every joint rests at its
//! drive's target, and the robot falls freely for 1/60 s (its feet start 5 cm above the
//! ground), so every quantity has a closed form.

use orbit_managers::make;
use orbit_physics_rapier as _;
use orbit_task_humanoid::TASK_ID;

const DT: f32 = 1.0 / 60.0;
const G: f32 = 9.81;

/// The observation row and reward after one zero-torque step from the start pose moving at
/// `vx` m/s along x.
fn one_step(vx: f32) -> (Vec<f32>, f32) {
    let o = [
        "num_envs=1".to_string(),
        "sim.backend=\"rapier\"".to_string(),
        "events.reset_robot_joints.params.position_range=(0.0, 0.0)".to_string(),
        "events.reset_robot_joints.params.velocity_range=(0.0, 0.0)".to_string(),
        format!("events.reset_base.params.lin_vel_range=(({vx}, {vx}), (0.0, 0.0), (0.0, 0.0))"),
    ];
    let mut env = make(TASK_ID, &o).unwrap_or_else(|e| panic!("{e}"));
    env.reset().unwrap();
    let reward = env.step(&[0.0; 21]).unwrap().reward[0];
    let (obs, dim) = env.observation("policy").expect("policy observations");
    assert_eq!(dim, 75, "Isaac Lab's 87 values less the 12 foot forces");
    (obs.to_vec(), reward)
}

/// Upright and facing the target: height 1.34 − g t²/2, velocity (vx, 0, −g t) in base axes,
/// yaw, roll and angle to the target 0, up and heading projections 1; every joint at 0,
/// normalised by its range (`2 (0 − mid) / (hi − lo)`, ranges in degrees in MuJoCo's order);
/// joint velocities and actions 0.
#[test]
fn a_falling_humanoid_observes_its_height_velocity_and_heading() {
    let (obs, _) = one_step(0.5);
    let t = DT;
    let ranges: [(f32, f32); 21] = [
        (-45.0, 45.0),
        (-75.0, 30.0),
        (-35.0, 35.0),
        (-45.0, 15.0),
        (-60.0, 35.0),
        (-120.0, 45.0),
        (-160.0, 2.0),
        (-50.0, 50.0),
        (-50.0, 50.0),
        (-45.0, 15.0),
        (-60.0, 35.0),
        (-120.0, 45.0),
        (-160.0, 2.0),
        (-50.0, 50.0),
        (-50.0, 50.0),
        (-90.0, 70.0),
        (-90.0, 70.0),
        (-90.0, 50.0),
        (-90.0, 70.0),
        (-90.0, 70.0),
        (-90.0, 50.0),
    ];
    let mut want = vec![1.34 - 0.5 * G * t * t, 0.5, 0.0, -G * t, 0.0, 0.0, 0.0];
    want.extend([0.0, 0.0, 0.0, 1.0, 1.0]);
    want.extend(ranges.iter().map(|(lo, hi)| -(lo + hi) / (hi - lo)));
    want.extend([0.0; 42]);
    for (k, (got, want)) in obs.iter().zip(&want).enumerate() {
        // Semi-implicit Euler's height is off the analytic one by g t h / 2 = 0.7 mm.
        assert!(
            (got - want).abs() < 1e-3,
            "observation {k}: {got} vs {want}\n{obs:?}"
        );
    }
}

/// Alive (2.0), upright (0.1) and facing the target (0.5) earn 2.6 per second; moving towards
/// it at 1 m/s adds its progress, 1 per second. No torque costs nothing.
#[test]
fn progress_towards_the_target_is_rewarded_at_its_speed() {
    let (_, still) = one_step(0.0);
    let (_, moving) = one_step(1.0);
    assert!((still - 2.6 * DT).abs() < 1e-5, "reward {still}");
    assert!(
        (moving - still - DT).abs() < 1e-5,
        "progress {}",
        moving - still
    );
}
