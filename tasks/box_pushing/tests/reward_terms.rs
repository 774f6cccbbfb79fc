//! Every reward term of the box-pushing task and the built-in joint terms, evaluated on states
//! prepared by writing the backend state directly, against values computed by hand.

use glam::{Quat, Vec3};
use orbit_core::math::{Pose, quat_wxyz, rotation_distance};
use orbit_core::scene::RootState;
use orbit_managers::{ManagerBasedRlEnv, make};
use orbit_physics_rapier as _;
use orbit_task_box_pushing as _;

mod common;
use common::{SEED0_TARGET, TASK, seed0_target_override};

/// The torque task with the target fixed and every term under test added (at weight 0, so the
/// task's reward is unchanged; `evaluate_reward_terms` reports the unweighted values).
fn env() -> ManagerBasedRlEnv {
    let target = seed0_target_override();
    let overrides = [
        "num_envs=1",
        &target,
        "rewards.speed=(func: \"arm_joint_speed\", weight: 0.0)",
        "rewards.bonus=(func: \"spatial_sparse_bonus\", weight: 0.0)",
        "rewards.pos_limits=(func: \"joint_pos_limits\", params: (joint_names: [\"panda_joint[1-7]\"]), weight: 0.0)",
        "rewards.vel_limits=(func: \"joint_vel_limits\", params: (soft_ratio: 0.5), weight: 0.0)",
        "rewards.vel_l2=(func: \"joint_vel_l2\", weight: 0.0)",
        "rewards.action_rate=(func: \"action_rate_l2\", weight: 0.0)",
    ];
    let overrides: Vec<String> = overrides.iter().map(|s| s.to_string()).collect();
    let mut env = make(TASK, &overrides).unwrap_or_else(|e| panic!("{e}"));
    env.reset().unwrap();
    env
}

fn terms(env: &mut ManagerBasedRlEnv) -> std::collections::BTreeMap<String, f32> {
    env.evaluate_reward_terms()
        .into_iter()
        .map(|(name, v)| (name, v[0]))
        .collect()
}

fn close(name: &str, got: f32, expected: f32, tol: f32) {
    assert!(
        (got - expected).abs() <= tol,
        "{name}: got {got}, expected {expected} (tolerance {tol})"
    );
}

fn target_pose() -> Pose {
    Pose::new(
        Vec3::new(SEED0_TARGET[0], SEED0_TARGET[1], SEED0_TARGET[2]),
        quat_wxyz([
            SEED0_TARGET[3],
            SEED0_TARGET[4],
            SEED0_TARGET[5],
            SEED0_TARGET[6],
        ]),
    )
}

fn place_box(env: &mut ManagerBasedRlEnv, pose: Pose) {
    let state = RootState {
        pose,
        ..Default::default()
    };
    env.scene_mut()
        .backend
        .write_root_state(0, &[0], &[state])
        .unwrap();
}

fn default_arm(env: &ManagerBasedRlEnv) -> Vec<f32> {
    env.scene().desc.articulations[0].default_joint_pos.clone()
}

fn frame(env: &ManagerBasedRlEnv, name: &str) -> Pose {
    let (link, offset) = env.scene().backend.layout().articulations[0]
        .model
        .find_frame(name)
        .unwrap();
    env.scene()
        .backend
        .articulation(0)
        .frame_pose(0, link, &offset)
}

/// Box 5 cm from the target (3-4-5 triangle) and turned 0.2 rad from it: goal distance 0.05,
/// goal rotation 0.2/π, spatial bonus 300 − 1050·0.05 − 150·0.2/π.
#[test]
fn box_goal_terms() {
    let mut env = env();
    let target = target_pose();
    place_box(
        &mut env,
        Pose::new(
            target.pos + Vec3::new(0.03, 0.04, 0.0),
            target.rot * Quat::from_rotation_z(0.2),
        ),
    );
    let t = terms(&mut env);
    let pi = std::f32::consts::PI;
    close("goal_distance", t["goal_distance"], 0.05, 1e-6);
    close("goal_rotation", t["goal_rotation"], 0.2 / pi, 2e-4);
    let bonus = 300.0 - 1050.0 * 0.05 - 150.0 * 0.2 / pi;
    close("bonus", t["bonus"], bonus, 0.05);
    // Beyond 0.1 m the bonus is 0; a half-turn is the largest rotation distance, 1.
    place_box(
        &mut env,
        Pose::new(
            target.pos + Vec3::new(0.0, 0.15, 0.0),
            target.rot * Quat::from_rotation_z(pi),
        ),
    );
    let t = terms(&mut env);
    close("goal_distance", t["goal_distance"], 0.15, 1e-6);
    close("goal_rotation", t["goal_rotation"], 1.0, 1e-3);
    assert_eq!(t["bonus"], 0.0);
}

/// The rod-tip distance is the box origin's distance from the rod tip, floored at 0.05 m.
#[test]
fn rod_tip_distance_is_floored() {
    let mut env = env();
    let tip = frame(&env, "rod_tip").pos;
    place_box(
        &mut env,
        Pose::new(tip + Vec3::new(0.0, -0.3, -0.4), Quat::IDENTITY),
    );
    close("rod_tip_box", terms(&mut env)["rod_tip_box"], 0.5, 1e-5);
    place_box(
        &mut env,
        Pose::new(tip + Vec3::new(0.0, 0.0, -0.02), Quat::IDENTITY),
    );
    close("rod_tip_box", terms(&mut env)["rod_tip_box"], 0.05, 0.0);
}

/// In the default pose the rod points down (no inclination penalty). Turning joint 7 about the
/// rod axis by 1.0 rad turns the rod frame by exactly 1.0 rad about that axis: Fancy Gym's
/// rotation distance to "down" then exceeds π/4 and the term pays it divided by π.
#[test]
fn rod_inclination_counts_rotations_beyond_a_quarter_turn() {
    let mut env = env();
    let down = Quat::from_xyzw(1.0, 0.0, 0.0, 0.0);
    let rod0 = frame(&env, "push_rod").rot;
    let phi0 = rotation_distance(rod0, down);
    assert!(phi0 < 0.1, "default rod is {phi0} rad from down");
    assert_eq!(terms(&mut env)["rod_inclination"], 0.0);
    let mut q = default_arm(&env);
    q[6] += 1.0;
    env.scene_mut()
        .backend
        .write_joint_state(0, &[0], &q, &[0.0; 7])
        .unwrap();
    let rod = frame(&env, "push_rod").rot;
    close("rod turn", rotation_distance(rod, rod0), 1.0, 1e-4);
    let phi = rotation_distance(rod, down);
    assert!(phi > std::f32::consts::FRAC_PI_4 && (phi - 1.0).abs() <= phi0 + 1e-4);
    close(
        "rod_inclination",
        terms(&mut env)["rod_inclination"],
        phi / std::f32::consts::PI,
        1e-6,
    );
}

/// Joint 4 at 0.1 rad above Fancy Gym's upper limit and 0.0171 rad above the URDF's, joint 6
/// 0.05 rad below both lower limits (Fancy Gym's −0.0175 and the URDF's −0.0873 − 0.05 apart),
/// joint 1 at 0.3 rad/s over its 2.175 rad/s limit and joint 5 at 0.2 rad/s over 2.61.
#[test]
fn joint_limit_terms() {
    let mut env = env();
    let mut q = default_arm(&env);
    q[3] = -0.0698 + 0.1;
    q[5] = -0.0873 - 0.05;
    let mut qd = [0.0; 7];
    qd[0] = 2.175 + 0.3;
    qd[4] = -(2.61 + 0.2);
    env.scene_mut()
        .backend
        .write_joint_state(0, &[0], &q, &qd)
        .unwrap();
    let t = terms(&mut env);
    // Fancy Gym: above 0.1, below (−0.0175 − q6) = 0.1198, too fast 0.3 + 0.2.
    close(
        "joint_limits",
        t["joint_limits"],
        0.1 + (0.0873 + 0.05 - 0.0175) + 0.5,
        1e-5,
    );
    // URDF limits: joint 4 upper 0.0873, joint 6 lower −0.0873.
    close(
        "pos_limits",
        t["pos_limits"],
        (0.0302 - 0.0873f32).max(0.0) + 0.05,
        1e-5,
    );
    // soft_ratio 0.5: |q̇| − 0.5 q̇_max = 2.475 − 1.0875 and 2.81 − 1.305, each clamped to 1.
    close("vel_limits", t["vel_limits"], 2.0, 0.0);
    let sq = 2.475f32.powi(2) + 2.81f32.powi(2);
    close("vel_l2", t["vel_l2"], sq, 1e-4);
    close("speed", t["speed"], sq.sqrt(), 1e-5);
}

/// Energy is `Σ u²` of the torque term's `u = 10 clip(a, −1, 1)`; the action rate is
/// `Σ (a − a_prev)²` of the raw actions.
#[test]
fn action_terms() {
    let mut env = env();
    let a1 = [0.1, -0.2, 2.0, 0.0, 0.0, 0.0, 0.5];
    env.step(&a1).unwrap();
    let t = terms(&mut env);
    close("energy", t["energy"], 1.0 + 4.0 + 100.0 + 25.0, 1e-4);
    close(
        "action_rate",
        t["action_rate"],
        0.01 + 0.04 + 4.0 + 0.25,
        1e-6,
    );
    let a2 = [0.1, 0.2, 2.0, 0.0, 0.0, 0.0, -0.5];
    env.step(&a2).unwrap();
    let t = terms(&mut env);
    close("energy", t["energy"], 1.0 + 4.0 + 100.0 + 25.0, 1e-4);
    close("action_rate", t["action_rate"], 0.16 + 1.0, 1e-6);
}
