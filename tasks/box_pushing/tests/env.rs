//! The box-pushing env on the CPU backend: Fancy Gym's reference return, episode timing,
//! partial resets, invalid actions and config errors.

use orbit_managers::{EnvError, ManagerBasedRlEnv, make};
use orbit_physics_rapier as _;
use orbit_task_box_pushing as _;

mod common;
use common::{TASK, seed0_target_override};

fn env(num_envs: usize, extra: &[&str]) -> ManagerBasedRlEnv {
    let mut overrides = vec![format!("num_envs={num_envs}")];
    overrides.extend(extra.iter().map(|s| s.to_string()));
    make(TASK, &overrides).unwrap_or_else(|e| panic!("{e}"))
}

/// The error `make` gives for the box-pushing task with one override, as text.
fn config_error(override_: &str) -> String {
    make(TASK, &[override_.into()])
        .err()
        .expect("the override is rejected")
        .to_string()
}

/// Reset event: the box 15 cm further along +x, launched at 0.5 m/s along +y.
const LAUNCH_BOX: &str = "events.launch=(func: \"reset_root_state_uniform\", params: (asset: \"box\", pos_range: ((0.15, 0.15), (0.0, 0.0), (0.0, 0.0)), lin_vel_range: ((0.0, 0.0), (0.5, 0.5), (0.0, 0.0))), mode: Reset)";

/// Zero action for a whole episode from the default reset and the seed-0 target: Fancy Gym's
/// Dense return is −194.5184 (MuJoCo); we must agree within 1 %. The episode times out at
/// exactly step 100 and the observation returned then belongs to the new episode.
#[test]
fn zero_action_dense_return_matches_fancy_gym() {
    let mut env = env(1, &[&seed0_target_override()]);
    env.reset().unwrap();
    let zero = vec![0.0; env.action_dim()];
    let mut ret = 0.0f64;
    for step in 1..=100 {
        let r = env.step(&zero).unwrap();
        ret += f64::from(r.reward[0]);
        assert_eq!(r.time_outs[0], step == 100, "time-out flag at step {step}");
        assert!(!r.terminated[0]);
    }
    let expected = -194.5184247;
    let rel = (ret - expected).abs() / expected.abs();
    println!("zero-action Dense return {ret:.4} vs Fancy Gym {expected} (rel. error {rel:.2e})");
    assert!(rel < 0.01, "Dense return {ret} vs {expected}");
    assert_eq!(
        env.episode_length()[0],
        0,
        "the env reset after the time-out"
    );
}

/// Resetting some envs leaves the others bit-identical to an untouched run.
#[test]
fn partial_reset_leaves_other_envs_untouched() {
    let mut a = env(3, &[]);
    let mut b = env(3, &[]);
    a.reset().unwrap();
    b.reset().unwrap();
    let act: Vec<f32> = (0..3 * a.action_dim())
        .map(|i| ((i * 7919) % 13) as f32 / 13.0 - 0.5)
        .collect();
    for k in 0..20 {
        a.step(&act).unwrap();
        b.step(&act).unwrap();
        if k == 9 {
            a.reset_idx(&[1]).unwrap();
        }
    }
    let (oa, d) = a.observation("policy").unwrap();
    let (ob, _) = b.observation("policy").unwrap();
    for e in [0, 2] {
        let (ra, rb) = (&oa[e * d..(e + 1) * d], &ob[e * d..(e + 1) * d]);
        assert!(
            ra.iter().zip(rb).all(|(x, y)| x.to_bits() == y.to_bits()),
            "env {e} changed"
        );
    }
    assert_ne!(&oa[d..2 * d], &ob[d..2 * d], "env 1 was reset");
}

/// NaN or infinite actions are rejected before anything reaches the physics.
#[test]
fn non_finite_actions_are_rejected() {
    let mut env = env(2, &[]);
    env.reset().unwrap();
    let before = env.observation("policy").unwrap().0.to_vec();
    let mut act = vec![0.0; 2 * env.action_dim()];
    act[3] = f32::NAN;
    match env.step(&act) {
        Err(EnvError::InvalidAction(m)) => assert!(m.contains("not finite"), "{m}"),
        _ => panic!("a NaN action was accepted"),
    }
    act[3] = f32::INFINITY;
    assert!(env.step(&act).is_err());
    assert!(env.step(&[0.0; 3]).is_err(), "wrong length accepted");
    assert_eq!(env.observation("policy").unwrap().0, before.as_slice());
}

/// Config mistakes name the file and the field.
#[test]
fn config_errors_name_file_and_field() {
    let unknown = config_error("rewards.goal_distance.func=\"box_goal_distanse\"");
    assert!(unknown.contains("rewards.goal_distance.func"), "{unknown}");
    assert!(unknown.contains("box_goal_distanse"), "{unknown}");
    let wrong_type = config_error("rewards.goal_distance.weight=\"heavy\"");
    assert!(
        wrong_type.contains("rewards.goal_distance.weight"),
        "{wrong_type}"
    );
    let bad_regex = config_error("actions.arm.params.joint_names=[\"finger.*\"]");
    assert!(
        bad_regex.contains("actions.arm.params.joint_names"),
        "{bad_regex}"
    );
    assert!(bad_regex.contains("matches no joint"), "{bad_regex}");
    let bad_param = config_error("rewards.rod_tip_box.params=(robbot: \"robot\")");
    assert!(
        bad_param.contains("rewards.rod_tip_box.params"),
        "{bad_param}"
    );
    assert!(bad_param.contains("robbot"), "{bad_param}");
    let bad_command = config_error("rewards.goal_distance.params=(command: \"goal\")");
    assert!(
        bad_command.contains("rewards.goal_distance"),
        "{bad_command}"
    );
    assert!(
        bad_command.contains("no 7-d pose command named `goal`"),
        "{bad_command}"
    );
}

/// Observation layout: joint pos/vel (7 + 7), box pose (3 + 4), target (7), last action (7).
#[test]
fn observation_layout() {
    let mut env = env(1, &[&seed0_target_override()]);
    env.reset().unwrap();
    let (obs, d) = env.observation("policy").unwrap();
    assert_eq!(d, 35);
    assert!(
        (obs[0] - 0.387_068_06).abs() < 1e-6,
        "joint 1 starts at the IK pose"
    );
    assert!(
        (obs[14] - 0.4).abs() < 1e-6 && (obs[15] - 0.3).abs() < 1e-6,
        "box at its default pose"
    );
    assert!((obs[21] - 0.491_088_5).abs() < 1e-6, "target x");
    assert!(
        obs[28..].iter().all(|a| *a == 0.0),
        "last action is zero after reset"
    );
}

/// Isaac Lab's step order: at a time-out the reward is computed on the terminal state, then the
/// env resets, and the returned observation is the first of the new episode (default joint
/// state, zero last action), while the episode's reward sum is logged.
#[test]
fn time_out_step_returns_the_new_episodes_observation() {
    let mut env = env(1, &[]);
    env.reset().unwrap();
    let act: Vec<f32> = (0..env.action_dim())
        .map(|i| if i % 2 == 0 { 0.5 } else { -0.5 })
        .collect();
    for _ in 0..99 {
        env.step(&act).unwrap();
    }
    let moved = env.observation("policy").unwrap().0[..7].to_vec();
    let r = env.step(&act).unwrap();
    assert!(r.time_outs[0]);
    assert!(r.reward[0] < 0.0, "the terminal step still has its reward");
    let log = &r.extras.log;
    assert!(log.contains_key("Episode Reward/goal_distance"), "{log:?}");
    assert_eq!(log["Episode Termination/time_out"], 1.0);
    let (obs, _) = env.observation("policy").unwrap();
    let q0 = [
        0.387_068_06f32,
        0.176_208_42,
        0.249_891_42,
        -2.399_143_8,
        -0.079_869_05,
        2.568_573_7,
        1.479_516_9,
    ];
    for j in 0..7 {
        assert!(
            (obs[j] - q0[j]).abs() < 1e-5,
            "joint {j}: {} is not the reset pose",
            obs[j]
        );
    }
    assert!(
        moved.iter().zip(q0).any(|(m, q)| (m - q).abs() > 1e-2),
        "the arm had moved before the reset"
    );
    assert!(
        obs[28..].iter().all(|a| *a == 0.0),
        "last action is cleared on reset"
    );
}

/// Every registered step-based task builds and runs an episode; the success metric is logged
/// at the end.
#[test]
fn every_registered_task_runs_an_episode() {
    let tasks: Vec<_> = orbit_managers::tasks()
        .into_iter()
        .filter(|t| !t.is_black_box())
        .collect();
    assert!(
        tasks.len() >= 4,
        "{:?}",
        tasks.iter().map(|t| t.id).collect::<Vec<_>>()
    );
    for task in tasks {
        let mut env =
            make(task.id, &["num_envs=2".into()]).unwrap_or_else(|e| panic!("{}: {e}", task.id));
        env.reset().unwrap();
        let zero = vec![0.0; 2 * env.action_dim()];
        let mut log = None;
        for _ in 0..env.max_episode_length() {
            let r = env.step(&zero).unwrap();
            assert!(r.reward.iter().all(|x| x.is_finite()), "{}", task.id);
            log = Some(r.extras.log.clone());
        }
        let log = log.unwrap();
        assert_eq!(
            log.get("Metrics/target/success"),
            Some(&0.0),
            "{}: {log:?}",
            task.id
        );
        let err = log["Metrics/target/position_error"];
        assert!(
            err > 0.3 - 0.02,
            "{}: an untouched box stays ≥ 0.3 m from its target, got {err}",
            task.id
        );
    }
}

/// TemporalSparse pays only the dense shaping terms before the last step and the large final
/// penalty at the last step; with zero action its final step dominates.
#[test]
fn temporal_sparse_pays_at_the_last_step() {
    let mut env = make(
        "BoxPushing-Torque-TemporalSparse-Franka-v0",
        &["num_envs=1".into(), seed0_target_override()],
    )
    .unwrap();
    env.reset().unwrap();
    let zero = vec![0.0; env.action_dim()];
    let mut rewards = Vec::new();
    for _ in 0..100 {
        rewards.push(env.step(&zero).unwrap().reward[0]);
    }
    // Per step: joint limits 0, energy 0, rod term −2 r_tip with MuJoCo's resting rod-tip-to-box
    // distance r_tip = 0.0543 m (rod tip at z 0.0450, box origin at rest at z −0.0092); 3 mm slack.
    let shaping = -2.0 * 0.05425;
    for (k, r) in rewards[..99].iter().enumerate() {
        assert!((r - shaping).abs() < 6e-3, "step {}: {r}", k + 1);
    }
    // Last step: shaping − 350 d − 100 ρ/π − 50 ‖q̇‖ with Fancy Gym's d = 0.5153, ρ = 0.1038.
    let expected = shaping - 350.0 * 0.5153071 - 100.0 * 0.1038462 / std::f32::consts::PI;
    assert!(
        (rewards[99] - expected).abs() < 0.01 * expected.abs(),
        "last step {} vs {expected}",
        rewards[99]
    );
}

/// Differential IK (absolute pose command on the tcp, DLS) drives the tcp to a target 10 cm
/// above and 3 cm beyond its start within 5 mm in 1 s, keeping the commanded orientation (the
/// start's, rod down) within 0.02 rad.
#[test]
fn differential_ik_reaches_a_tcp_target() {
    let arm = "actions.arm=(func: \"differential_ik\", params: (joint_names: [\"panda_joint[1-7]\"], body_name: \"tcp\", command_type: Pose, ik_method: Dls(lambda_val: 0.01), compensate_bias: true))";
    let stiffness = "scene.articulations[\"robot\"].actuators[\"arm\"].stiffness=400.0";
    let damping = "scene.articulations[\"robot\"].actuators[\"arm\"].damping=80.0";
    let mut env = env(1, &[arm, stiffness, damping]);
    env.reset().unwrap();
    let tcp = |env: &ManagerBasedRlEnv| {
        let layout = &env.scene().backend.layout().articulations[0];
        let (link, offset) = layout.model.find_frame("tcp").unwrap();
        env.scene()
            .backend
            .articulation(0)
            .frame_pose(0, link, &offset)
    };
    let start = tcp(&env);
    let target = start.pos + glam::Vec3::new(0.03, 0.0, 0.1);
    assert_eq!(env.action_dim(), 7);
    let q = orbit_core::math::to_wxyz(start.rot);
    let command = [target.x, target.y, target.z, q[0], q[1], q[2], q[3]];
    for _ in 0..50 {
        env.step(&command).unwrap();
    }
    let end = tcp(&env);
    let err = (end.pos - target).length();
    let tilt = orbit_core::math::rotation_distance(end.rot, start.rot);
    println!(
        "differential IK: tcp error {:.2} mm, orientation change {tilt:.4} rad",
        err * 1e3
    );
    assert!(err < 5e-3, "tcp {:?} vs target {target:?}", end.pos);
    assert!(tilt < 0.02, "orientation drifted {tilt} rad");
}

/// `reset_joints_by_offset` draws each env's joints within default ± range (different per env,
/// reproducible per seed); `object_position_in_robot_root_frame` equals the box position for a
/// robot rooted at the env origin.
#[test]
fn joint_offset_reset_and_object_in_robot_frame() {
    let event = "events.jitter=(func: \"reset_joints_by_offset\", params: (joint_names: [\"panda_joint[1-7]\"], position_range: (-0.1, 0.1)), mode: Reset)";
    let obs = "observations.policy.terms.box_in_robot=(func: \"object_position_in_robot_root_frame\", params: (object: \"box\"))";
    let run = |seed: &str| {
        let mut env = env(4, &[event, obs, seed]);
        env.reset().unwrap();
        env.observation("policy").unwrap().0.to_vec()
    };
    let (a, b, c) = (run("seed=3"), run("seed=3"), run("seed=4"));
    assert_eq!(a, b, "same seed, same draws");
    assert_ne!(a, c, "another seed, other draws");
    let d = a.len() / 4;
    let q0 = [
        0.387_068_06f32,
        0.176_208_42,
        0.249_891_42,
        -2.399_143_8,
        -0.079_869_05,
        2.568_573_7,
        1.479_516_9,
    ];
    for e in 0..4 {
        for j in 0..7 {
            let dq = a[e * d + j] - q0[j];
            assert!(dq.abs() <= 0.1 + 1e-6, "env {e} joint {j}: offset {dq}");
        }
        let box_pos = &a[e * d + 14..e * d + 17];
        let in_robot = &a[e * d + 35..e * d + 38];
        assert_eq!(box_pos, in_robot, "robot root at the env origin");
    }
    assert_ne!(a[0], a[d], "envs draw different offsets");
}

/// Observation history (length 3) returns the last three joint-position observations oldest
/// first; after a reset all three slots hold the new episode's first value.
#[test]
fn observation_history_shifts_and_refills_on_reset() {
    let hist = "observations.policy.terms.q_hist=(func: \"joint_pos\", history_length: 3)";
    let mut env = env(1, &[hist]);
    env.reset().unwrap();
    let d = env.observation("policy").unwrap().1;
    assert_eq!(d, 35 + 21);
    let current = |env: &ManagerBasedRlEnv| env.observation("policy").unwrap().0[..7].to_vec();
    let slots = |env: &ManagerBasedRlEnv, k: usize| {
        env.observation("policy").unwrap().0[35 + 7 * k..35 + 7 * (k + 1)].to_vec()
    };
    let q_reset = current(&env);
    for k in 0..3 {
        assert_eq!(slots(&env, k), q_reset, "slot {k} after reset");
    }
    let act = vec![0.5f32; env.action_dim()];
    let mut seen = vec![q_reset.clone()];
    for _ in 0..4 {
        env.step(&act).unwrap();
        seen.push(current(&env));
    }
    let m = seen.len();
    for k in 0..3 {
        assert_eq!(
            slots(&env, k),
            seen[m - 3 + k],
            "slot {k} holds step {}",
            m - 3 + k
        );
    }
    assert_ne!(seen[m - 1], seen[m - 2], "the arm moved");
    env.reset_idx(&[0]).unwrap();
    env.step(&vec![0.0; env.action_dim()]).unwrap();
    let after = current(&env);
    for k in 0..3 {
        assert_eq!(slots(&env, k), after, "slot {k} refilled after the reset");
    }
}

/// `modify_reward_weight` switches a reward term's weight once the common step counter passes
/// `num_steps` (it runs when envs reset) and logs the weight; a weight-0 term can be enabled.
#[test]
fn curriculum_changes_a_reward_weight() {
    let cur = "curriculum.energy_up=(func: \"modify_reward_weight\", params: (term_name: \"energy\", weight: -5.0, num_steps: 3))";
    let zero = "rewards.energy.weight=0.0";
    let mut env = env(1, &[cur, zero, &seed0_target_override()]);
    env.reset().unwrap();
    let act = vec![0.5f32; env.action_dim()];
    let mut rewards = Vec::new();
    for k in 0..6 {
        rewards.push(env.step(&act).unwrap().reward[0]);
        if k == 1 || k == 4 {
            env.reset_idx(&[0]).unwrap();
            let w = env
                .step(&vec![0.0; env.action_dim()])
                .unwrap()
                .extras
                .log
                .get("Curriculum/energy_up")
                .copied();
            assert_eq!(
                w,
                Some(if k == 1 { 0.0 } else { -5.0 }),
                "weight logged after step {k}"
            );
        }
    }
    // With weight −5 the energy term adds −5 · Σu² · dt = −5 · 7 · 25 · 0.02 = −17.5 per step.
    let gap = rewards[5] - rewards[1];
    assert!(
        gap < -17.0 && gap > -18.5,
        "energy weight not applied: {gap}"
    );
}

/// Friction randomisation reaches the physics: `reset_root_state_uniform` moves the box 15 cm
/// away from the rod and launches it at 0.5 m/s along +y; with its default plate friction 0.3 it
/// stops after v²/(2 μ g) = 42.5 mm, with friction drawn from (0, 0) it keeps sliding at 0.5 m/s.
#[test]
fn friction_randomisation_changes_sliding() {
    let slippery = "events.ice=(func: \"randomize_rigid_body_material\", params: (asset: \"box\", friction_range: (0.0, 0.0)), mode: Startup)";
    let slide = |extra: &[&str]| {
        let mut args = vec![LAUNCH_BOX];
        args.extend_from_slice(extra);
        let mut env = env(1, &args);
        env.reset().unwrap();
        let y0 = env.scene().backend.rigid_object(0).pos[0].y;
        let zero = vec![0.0; env.action_dim()];
        for _ in 0..10 {
            env.step(&zero).unwrap();
        }
        env.scene().backend.rigid_object(0).pos[0].y - y0
    };
    let with_friction = slide(&[]);
    let without = slide(&[slippery]);
    let stop = 0.5f32 * 0.5 / (2.0 * 0.3 * 9.81);
    println!(
        "box slides {:.4} m with friction (ideal {stop:.4}), {:.4} m frictionless in 0.2 s",
        with_friction, without
    );
    assert!(
        (with_friction - stop).abs() < 0.1 * stop,
        "slid {with_friction} m, expected {stop} m"
    );
    assert!(
        (without - 0.1).abs() < 0.005,
        "frictionless box slid {without} m in 0.2 s"
    );
}

/// A `critic` group of privileged terms: `frame_pos` puts the tcp where the reset's IK placed
/// it (15 cm above the box's default position, within the IK's 3.2 mm), and `root_lin_vel` /
/// `root_ang_vel` read a box launched at 0.5 m/s along +y: after 0.1 s of sliding on plate
/// friction 0.3 it moves at 0.5 − μ g t = 0.206 m/s without turning. A frame the robot lacks
/// is an error naming the field.
#[test]
fn privileged_critic_terms_read_frames_and_box_velocity() {
    let critic = "observations.critic=(terms: {\"tcp\": (func: \"frame_pos\", params: (frame: \"tcp\")), \"box_lin_vel\": (func: \"root_lin_vel\", params: (asset: \"box\")), \"box_ang_vel\": (func: \"root_ang_vel\", params: (asset: \"box\"))})";
    let mut plain = env(1, &[critic]);
    plain.reset().unwrap();
    let (obs, d) = plain.observation("critic").unwrap();
    assert_eq!(d, 9);
    let tcp = glam::Vec3::from_slice(&obs[..3]);
    let above_box = glam::Vec3::new(0.4, 0.3, -0.01 + 0.15);
    assert!((tcp - above_box).length() < 3.2e-3, "tcp at {tcp}");

    let mut env = env(1, &[LAUNCH_BOX, critic]);
    env.reset().unwrap();
    let zero = vec![0.0; env.action_dim()];
    for _ in 0..5 {
        env.step(&zero).unwrap();
    }
    let (obs, _) = env.observation("critic").unwrap();
    let (lin, ang) = (&obs[3..6], &obs[6..9]);
    let expected = 0.5 - 0.3 * 9.81 * 0.1;
    println!("box velocity after 0.1 s: {lin:?} (ideal {expected:.4} along y), spin {ang:?}");
    assert!(
        (lin[1] - expected).abs() < 0.02,
        "v_y {} vs {expected}",
        lin[1]
    );
    assert!(lin[0].abs() < 0.01 && lin[2].abs() < 0.01, "{lin:?}");
    assert!(ang.iter().all(|w| w.abs() < 0.05), "the box turns: {ang:?}");
    let bad_frame = config_error(
        "observations.critic=(terms: {\"tip\": (func: \"frame_pos\", params: (frame: \"rod_tipp\"))})",
    );
    assert!(
        bad_frame.contains("observations.critic.terms.tip.params.frame")
            && bad_frame.contains("rod_tipp"),
        "{bad_frame}"
    );
}

/// Fancy Gym's offline IK for the default box pose reproduces its q₀ (MuJoCo 2.3.3): the same 86
/// accepted iterations and q₀ to within 1e-5 rad (measured 2.4e-7, f32 resolution), the tcp
/// within √1e-5 = 3.2 mm of its target with the rod pointing down.
#[test]
fn offline_ik_reproduces_fancy_gyms_initial_pose() {
    let env = env(1, &[]);
    let desc = &env.scene().desc.articulations[0];
    let tcp = desc.model.find_frame("tcp").unwrap();
    let p = orbit_task_box_pushing::ArmIkParams::default();
    let mut ik = orbit_task_box_pushing::OfflineIk::new(
        orbit_core::kinematics::ArticulationKinematics::new(&desc.model),
        desc.root_pose,
        tcp,
        p.q_min,
        p.q_max,
    );
    let target = glam::Vec3::new(0.4, 0.3, -0.01 + 0.15);
    let down = glam::Quat::from_xyzw(1.0, 0.0, 0.0, 0.0);
    let sol = ik.solve(target, down, p.q_start);
    let q0 = [
        0.387_068_06f32,
        0.176_208_42,
        0.249_891_42,
        -2.399_143_8,
        -0.079_869_05,
        2.568_573_7,
        1.479_516_9,
    ];
    let dq = sol
        .q
        .iter()
        .zip(q0)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0f32, f32::max);
    let mut kin = orbit_core::kinematics::ArticulationKinematics::new(&desc.model);
    let pose = kin.forward(&desc.root_pose, &sol.q)[tcp.0].mul_pose(&tcp.1);
    let err = (pose.pos - target).length();
    println!(
        "offline IK: {} iterations, error {:.2e}, max |q − q₀| {dq:.2e} rad, tcp error {:.2} mm",
        sol.iterations,
        sol.error,
        err * 1e3
    );
    assert!(sol.error < 1e-5, "IK did not converge: {sol:?}");
    assert!(err < 3.2e-3, "tcp {:?} vs {target:?}", pose.pos);
    assert!(orbit_core::math::rotation_distance(pose.rot, down) < 0.01);
    assert_eq!(sol.iterations, 86, "Fancy Gym accepts 86 iterations");
    assert!(dq < 1e-5, "q {:?} vs Fancy Gym {q0:?}", sol.q);
}

/// The random-init variant places each env's box at its own random pose and the arm by IK with
/// the tcp 15 cm above it (within the IK's 3.2 mm convergence radius).
#[test]
fn random_init_places_the_arm_above_each_box() {
    let mut env = make(
        "BoxPushing-Torque-RandomInit-Franka-v0",
        &["num_envs=4".into(), "seed=5".into()],
    )
    .unwrap();
    env.reset().unwrap();
    let (link, offset) = env.scene().backend.layout().articulations[0]
        .model
        .find_frame("tcp")
        .unwrap();
    let boxes = env.scene().backend.rigid_object(0).pos.to_vec();
    for (e, b) in boxes.iter().enumerate() {
        assert!(
            (0.3 - 1e-4..=0.6 + 1e-4).contains(&b.x) && (-0.45 - 1e-4..=0.45 + 1e-4).contains(&b.y),
            "box {e} at {b:?}"
        );
        let tcp = env
            .scene()
            .backend
            .articulation(0)
            .frame_pose(e, link, &offset)
            .pos;
        let err = (tcp - (*b + glam::Vec3::new(0.0, 0.0, 0.15))).length();
        assert!(err < 3.2e-3, "env {e}: tcp {tcp:?} vs box {b:?}");
    }
    assert_ne!(boxes[0], boxes[1], "envs draw their own box poses");
}

/// `randomize_rigid_body_mass` doubling the last arm link (link 7 with the hand and rod merged
/// into it) changes the static bias forces (gravity torques) by the extra weight's moment
/// about each joint axis: `Δb_j = −a_j · ((c − p_j) × Δm g)`, with `c` the link's centre of mass
/// and `p_j`, `a_j` joint j's position and axis. An env without the event keeps the default.
#[test]
fn mass_randomisation_changes_gravity_torques() {
    let event = "events.heavy_hand=(func: \"randomize_rigid_body_mass\", params: (asset: \"robot\", body_names: [\"panda_link7\"], mass_distribution_params: (2.0, 2.0), operation: Scale), mode: Startup)";
    let bias = |env: &ManagerBasedRlEnv| env.scene().backend.articulation(0).bias_forces.to_vec();
    let mut plain = env(1, &[]);
    plain.reset().unwrap();
    let mut heavy = env(1, &[event]);
    heavy.reset().unwrap();
    let model = &heavy.scene().desc.articulations[0].model;
    let link = model.link_index("panda_link7").unwrap();
    let inertial = model.links[link].inertial;
    let view = heavy.scene().backend.articulation(0);
    let com = view.link_pos[link] + view.link_quat[link] * inertial.com;
    let weight = inertial.mass * glam::Vec3::new(0.0, 0.0, -9.81);
    let (b0, b1) = (bias(&plain), bias(&heavy));
    for (j, &dof_link) in model.dof_links().iter().enumerate() {
        let axis = view.link_quat[dof_link] * model.links[dof_link].joint.as_ref().unwrap().axis;
        let expected = -axis.dot((com - view.link_pos[dof_link]).cross(weight));
        let got = b1[j] - b0[j];
        assert!(
            (got - expected).abs() < 1e-3 + 1e-3 * expected.abs(),
            "joint {}: Δbias {got} vs {expected} N m",
            j + 1
        );
    }
    // The moment is not trivially zero everywhere: the hand's weight loads joints 2 and 4.
    assert!((b1[1] - b0[1]).abs() > 0.1 && (b1[3] - b0[3]).abs() > 0.1);

    // A range that could make a mass negative is refused, naming the field.
    let bad = "events.light=(func: \"randomize_rigid_body_mass\", params: (asset: \"box\", mass_distribution_params: (-5.0, 0.0), operation: Add), mode: Reset)";
    let err = config_error(bad);
    assert!(err.contains("events.light") && err.contains("> 0"), "{err}");
}

/// Terms run over envs on every core, each env from its own rows and random stream: with
/// enough envs for several parallel tasks, observations (with noise and history) and rewards
/// are the same bits on one thread and on three.
#[test]
fn envs_in_parallel_give_the_same_bits_on_any_number_of_threads() {
    let n = 2 * orbit_core::parallel::MIN_ENVS_PER_TASK + 5;
    let noisy = "observations.policy.terms.q_hist=(func: \"joint_pos\", history_length: 2, noise: Some(Gaussian(mean: 0.0, std: 0.01)))";
    // A noisy term without history after the history term: drawn in a second pass over envs.
    let noisy_after = "observations.policy.terms.zz_qd=(func: \"joint_vel\", noise: Some(Uniform(n_min: -0.1, n_max: 0.1)))";
    let run = |threads: usize| {
        orbit_core::parallel::on_threads(threads, || {
            let mut env = env(n, &[noisy, noisy_after, "sim.num_threads=1"]);
            env.reset().unwrap();
            let act: Vec<f32> = (0..n * env.action_dim())
                .map(|i| ((i % 13) as f32 - 6.0) * 0.05)
                .collect();
            let reward = env.step(&act).unwrap().reward.to_vec();
            (reward, env.observation("policy").unwrap().0.to_vec())
        })
    };
    let (r1, o1) = run(1);
    let (r3, o3) = run(3);
    assert_eq!(r1, r3);
    assert_eq!(o1, o3);
    let d = o1.len() / n;
    assert_ne!(o1[..d], o1[d..2 * d], "envs draw different noise");
}

/// The step-based tasks' policy observation: Fancy Gym's 28 values and the last action (7 joint
/// targets, or a 6-d tcp pose change), then the rod tip, the box's linear and angular velocity
/// and `box_goal_error`. At reset the rod points down from the IK pose, so its tip
/// (hand + 0.2 m) sits 9.5 cm below the tcp (hand + 0.105 m), over the box's default position;
/// 5 mm allows the IK's 3.2 mm and its orientation error along the rod. The box rests, and its
/// position error is the target's position minus its own, to the bit (the same f32 values).
#[test]
fn step_based_policy_observes_rod_tip_box_velocity_and_goal_error() {
    for task in [
        "BoxPushing-JointPos-Franka-v0",
        "BoxPushing-TaskSpace-Franka-v0",
    ] {
        let mut env = make(task, &["num_envs=1".into()]).unwrap_or_else(|e| panic!("{e}"));
        env.reset().unwrap();
        let (obs, d) = env.observation("policy").unwrap();
        let extra = 28 + env.action_dim();
        assert_eq!(d, extra + 18, "{task}");
        let tip = glam::Vec3::from_slice(&obs[extra..extra + 3]);
        let expected = glam::Vec3::new(0.4, 0.3, -0.01 + 0.15 - 0.095);
        println!("{task}: rod tip at {tip}");
        assert!((tip - expected).length() < 5e-3, "{task}: rod tip at {tip}");
        assert!(
            obs[extra + 3..extra + 9].iter().all(|v| v.abs() < 1e-6),
            "{task}: {obs:?}"
        );
        let (box_pos, target) = (&obs[14..17], &obs[21..24]);
        for i in 0..3 {
            assert_eq!(
                obs[extra + 9 + i],
                target[i] - box_pos[i],
                "{task}: {obs:?}"
            );
        }
    }
}

/// `box_goal_error` against the pose observations beside it, for boxes and targets at random
/// yaws (both draw their yaw from the whole turn, so the quaternions' signs flip between envs):
/// the first three values are `p_target − p_box`, the next six the columns `(cos Δ, sin Δ, 0)`
/// and `(−sin Δ, cos Δ, 0)` of the yaw `Δ = ψ_target − ψ_box` that takes the box onto the
/// target (both rest flat, so the rotation is a pure yaw). Tolerance 1e-5: f32 rounding.
#[test]
fn box_goal_error_is_the_target_seen_from_the_box() {
    let yaw = |q: &[f32]| {
        let (w, x, y, z) = (q[0], q[1], q[2], q[3]);
        (2.0 * (w * z + x * y)).atan2(1.0 - 2.0 * (y * y + z * z))
    };
    let mut env = env(
        16,
        &[
            "events.random_box=(func: \"reset_root_state_uniform\", params: (asset: \"box\", yaw_range: (0.0, 6.283185307)), mode: Reset)",
            "observations.policy.terms.goal_error=(func: \"box_goal_error\")",
        ],
    );
    env.reset().unwrap();
    let (obs, d) = env.observation("policy").unwrap();
    assert_eq!(d, 28 + env.action_dim() + 9);
    let mut flipped = 0;
    for row in obs.chunks(d) {
        let (box_pos, box_quat, target, error) =
            (&row[14..17], &row[17..21], &row[21..28], &row[d - 9..]);
        flipped += usize::from(box_quat[0] * target[3] < 0.0);
        let delta = yaw(&target[3..]) - yaw(box_quat);
        let (s, c) = delta.sin_cos();
        let expected = [
            target[0] - box_pos[0],
            target[1] - box_pos[1],
            target[2] - box_pos[2],
            c,
            s,
            0.0,
            -s,
            c,
            0.0,
        ];
        for (got, want) in error.iter().zip(expected) {
            assert!((got - want).abs() < 1e-5, "{error:?} against {expected:?}");
        }
    }
    assert!(flipped > 0, "no env had quaternions of opposite signs");
}

/// `box_goal_error` names what it needs: a 7-d pose command.
#[test]
fn box_goal_error_needs_a_pose_command() {
    let err = config_error(
        "observations.policy.terms.goal_error=(func: \"box_goal_error\", params: (command: \"goal\"))",
    );
    assert!(
        err.contains(
            "observations.policy.terms.goal_error: params.command: no 7-d pose command named `goal`"
        ) && err.contains("target"),
        "{err}"
    );
}
