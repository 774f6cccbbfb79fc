//! The black-box wrapper on box pushing (CPU backend): one wrapper step is a whole episode
//! whose return is the sum of the step rewards under Fancy Gym's PD law, the context is the
//! target pose, joint-position control inverts the action term exactly, replanning runs four
//! segments that continue each other, and unusable setups are errors.

use orbit_envs::{BlackBoxEnv, VecEnv, VecEnvError};
use orbit_managers::{make, task};
use orbit_mp::{ProMp, ProMpCfg};
use orbit_physics_rapier as _;
use orbit_task_box_pushing as _;

/// The black-box task `id` with `num_envs` envs on the CPU backend.
fn bb_env(id: &str, num_envs: usize, bb_overrides: &[&str]) -> Result<BlackBoxEnv, VecEnvError> {
    let def = task(id).expect("registered");
    let env = make(id, &[format!("num_envs={num_envs}"), "seed=5".into()])?;
    let user: Vec<String> = bb_overrides.iter().map(|s| s.to_string()).collect();
    BlackBoxEnv::load(env, &def.black_box.expect("a black-box task"), &user)
}

/// Deterministic parameters in [-scale, scale].
fn params(n: usize, scale: f32) -> Vec<f32> {
    (0..n)
        .map(|i| scale * (((i * 7919 + 13) % 1000) as f32 / 500.0 - 1.0))
        .collect()
}

const KP: [f32; 7] = [1.2, 1.2, 1.2, 1.2, 0.5, 0.3, 0.1];
const KD: [f32; 7] = [0.1, 0.1, 0.1, 0.1, 0.06, 0.05, 0.03];

/// One ProMP step runs the whole 100-step episode: its reward equals the sum of the rewards
/// of the same episode replayed on a twin env with Fancy Gym's PD law written out here, the
/// episode ends without a bootstrap, and the next context is the new episode's target pose.
#[test]
fn promp_step_is_a_whole_episode_with_summed_reward() {
    let n = 3;
    let mut bb = bb_env("BoxPushing-ProMP-Franka-v0", n, &[]).unwrap();
    assert_eq!(
        (bb.num_actions(), bb.num_obs(), bb.max_episode_length()),
        (35, 7, 1)
    );
    // The context is the target command (observation 21..28).
    let target = bb.env().commands().command("target").unwrap().0.to_vec();
    assert_eq!(bb.observations(), &target[..]);
    let theta = params(n * 35, 1.0);
    let step = bb.step(&theta).unwrap();
    let (rewards, dones, time_outs) = (
        step.rewards.to_vec(),
        step.dones.to_vec(),
        step.time_outs.to_vec(),
    );
    assert!(
        step.log.contains_key("Metrics/target/success"),
        "{:?}",
        step.log
    );
    assert!(dones.iter().all(|&d| d) && time_outs.iter().all(|&t| !t));
    assert!(bb.env().episode_length().iter().all(|&l| l == 0));
    let next_target = bb.env().commands().command("target").unwrap().0.to_vec();
    assert_eq!(bb.observations(), &next_target[..]);

    // The twin: the same env and seed, the trajectory from the reset pose, PD by hand.
    let mut twin = make(
        "BoxPushing-Torque-Franka-v0",
        &[format!("num_envs={n}"), "seed=5".into()],
    )
    .unwrap();
    twin.reset().unwrap();
    let joint_state = |env: &orbit_managers::ManagerBasedRlEnv| {
        let view = env.scene().backend.articulation(0);
        let nd = view.joint_pos.len() / n;
        let pick = |x: &[f32]| -> Vec<f32> {
            (0..n)
                .flat_map(|e| x[e * nd..e * nd + 7].to_vec())
                .collect()
        };
        (pick(view.joint_pos), pick(view.joint_vel))
    };
    let promp = ProMp::new(ProMpCfg {
        num_dof: 7,
        num_basis: 5,
        num_basis_zero_start: 1,
        num_basis_zero_goal: 0,
        basis_bandwidth_factor: 2.0,
        tau: 2.0,
        delay: 0.0,
        weights_scale: 0.3,
        dt: 0.02,
        num_steps: 100,
    })
    .unwrap();
    let (q_start, _) = joint_state(&twin);
    let (mut pos, mut vel) = (vec![0.0; n * 700], vec![0.0; n * 700]);
    promp
        .trajectories(&theta, &q_start, &mut pos, &mut vel)
        .unwrap();
    let mut sums = vec![0.0f32; n];
    for k in 0..100 {
        let (q, qd) = joint_state(&twin);
        let mut action = vec![0.0; n * 7];
        for e in 0..n {
            for d in 0..7 {
                let i = (e * 100 + k) * 7 + d;
                let u = KP[d] * (pos[i] - q[e * 7 + d]) + KD[d] * (vel[i] - qd[e * 7 + d]);
                action[e * 7 + d] = u.clamp(-1.0, 1.0);
            }
        }
        let r = twin.step(&action).unwrap();
        sums.iter_mut().zip(r.reward).for_each(|(s, &x)| *s += x);
    }
    for e in 0..n {
        let tol = 1e-5 * sums[e].abs().max(1.0);
        assert!(
            (rewards[e] - sums[e]).abs() <= tol,
            "env {e}: wrapper return {}, replayed {}",
            rewards[e],
            sums[e]
        );
    }
}

/// Joint-position control maps the plan exactly onto the drives' targets: after the episode,
/// the `arm` term's last targets are the plan's last desired positions.
#[test]
fn joint_position_control_targets_the_plan() {
    let n = 2;
    let mut bb = bb_env("BoxPushing-ProMP-JointPos-Franka-v0", n, &[]).unwrap();
    bb.step(&params(n * 35, 0.5)).unwrap();
    let targets = bb.env().actions().processed("arm").unwrap();
    let desired = bb.desired_positions();
    for e in 0..n {
        for d in 0..7 {
            let want = desired[(e * 100 + 99) * 7 + d];
            let got = targets[e * 7 + d];
            assert!(
                (got - want).abs() < 1e-5,
                "env {e} joint {d}: {got} vs {want}"
            );
        }
    }
}

/// Replanning: four segments of 25 steps, only the last ends the episode; the context is the
/// 28 Fancy Gym observations plus the progress; with the same parameters and the same (absolute)
/// goal, each plan continues the previous one (it starts from that plan's desired state).
#[test]
fn replanning_segments_continue_each_other() {
    let n = 2;
    let absolute_goal = ["trajectory[0].relative_goal=false"];
    let mut bb = bb_env("BoxPushing-ProDMP-Replan-Franka-v0", n, &absolute_goal).unwrap();
    assert_eq!(
        (bb.num_actions(), bb.num_obs(), bb.max_episode_length()),
        (35, 29, 4)
    );
    let theta = params(n * 35, 1.0);
    let mut previous: Option<Vec<f32>> = None;
    for segment in 1..=4u32 {
        let step = bb.step(&theta).unwrap();
        let done = step.dones.to_vec();
        assert!(
            done.iter().all(|&d| d == (segment == 4)),
            "segment {segment}"
        );
        let progress = if segment == 4 {
            0.0
        } else {
            0.25 * segment as f32
        };
        for e in 0..n {
            assert_eq!(bb.observations()[e * 29 + 28], progress);
        }
        let plan = bb.desired_positions().to_vec();
        if let Some(prev) = previous {
            // This plan's samples 0..25 are the previous plan's 25..50.
            for e in 0..n {
                for k in 0..25 {
                    for d in 0..7 {
                        let a = plan[(e * 100 + k) * 7 + d];
                        let b = prev[(e * 100 + k + 25) * 7 + d];
                        assert!(
                            (a - b).abs() < 1e-4,
                            "segment {segment} sample {k}: {a} vs {b}"
                        );
                    }
                }
            }
        }
        previous = Some(plan);
    }
}

/// Setups the wrapper cannot run are errors that say what to change; a NaN parameter steps
/// nothing.
#[test]
fn unusable_setups_are_errors() {
    #[track_caller]
    fn err(r: Result<BlackBoxEnv, VecEnvError>) -> String {
        match r {
            Ok(_) => panic!("expected an error"),
            Err(e) => e.to_string(),
        }
    }
    let e = err(bb_env(
        "BoxPushing-ProMP-Franka-v0",
        1,
        &["replanning=Some((interval: 25, max_plans: 4))"],
    ));
    assert!(e.contains("replanning") && e.contains("ProDmp"), "{e}");
    let e = err(bb_env(
        "BoxPushing-ProMP-Franka-v0",
        1,
        &["controller.p_gains=[1.0]"],
    ));
    assert!(e.contains("p_gains") && e.contains("7 finite gains"), "{e}");
    let e = err(bb_env(
        "BoxPushing-ProMP-Franka-v0",
        1,
        &["controller=JointPosition"],
    ));
    assert!(e.contains("joint_position"), "{e}");
    let e = err(bb_env(
        "BoxPushing-ProMP-Franka-v0",
        1,
        &["context=Some([(21, 40)])"],
    ));
    assert!(e.contains("context"), "{e}");
    let env = make("BoxPushing-TaskSpace-Franka-v0", &["num_envs=1".into()]).unwrap();
    let def = task("BoxPushing-ProMP-Franka-v0").unwrap();
    let e = err(BlackBoxEnv::load(env, &def.black_box.unwrap(), &[]));
    assert!(e.contains("does not drive joints"), "{e}");

    let mut bb = bb_env("BoxPushing-ProMP-Franka-v0", 2, &[]).unwrap();
    let mut theta = vec![0.0; 70];
    theta[40] = f32::NAN;
    let e = bb.step(&theta).err().expect("an error").to_string();
    assert!(e.contains("params") && e.contains("env 1"), "{e}");
    assert!(bb.env().episode_length().iter().all(|&l| l == 0));
    assert!(bb.randomize_episode_lengths(0).is_err());
}
