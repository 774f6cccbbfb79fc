//! The reach task's command and reward terms on known states.

use glam::Vec3;
use orbit_core::math::{quat_wxyz, rotation_distance};
use orbit_managers::{ManagerBasedRlEnv, make};
use orbit_physics_rapier as _;
use orbit_task_reach::TASK_ID;

fn env(overrides: &[&str]) -> ManagerBasedRlEnv {
    let o: Vec<String> = overrides.iter().map(|s| s.to_string()).collect();
    let mut env = make(TASK_ID, &o).unwrap_or_else(|e| panic!("{e}"));
    env.reset().unwrap();
    env
}

/// Sampled commands lie in the configured box and point the rod down (roll π): the command
/// rotation maps +z to −z whatever the yaw.
#[test]
fn pose_commands_lie_in_their_ranges_and_point_down() {
    let env = env(&["num_envs=64"]);
    let (cmd, dim) = env.commands().command("ee_pose").unwrap();
    assert_eq!(dim, 7);
    for c in cmd.chunks(7) {
        assert!(
            (0.35..=0.65).contains(&c[0])
                && (-0.2..=0.2).contains(&c[1])
                && (0.15..=0.5).contains(&c[2]),
            "{c:?}"
        );
        let q = quat_wxyz([c[3], c[4], c[5], c[6]]);
        assert!((q.length() - 1.0).abs() < 1e-5);
        assert!((q * Vec3::Z - Vec3::NEG_Z).length() < 1e-5, "{c:?}");
    }
}

/// The three tracking terms agree with the tcp pose and the command computed by hand:
/// d = ‖p_tcp − p_cmd‖, 1 − tanh(d / 0.1), and the rotation angle between them.
#[test]
fn tracking_terms_match_the_tcp_pose() {
    let mut env = env(&["num_envs=4"]);
    let terms = env.evaluate_reward_terms();
    let value = |name: &str| terms.iter().find(|(n, _)| n == name).unwrap().1.clone();
    let (d, fine, rot) = (
        value("end_effector_position_tracking"),
        value("end_effector_position_tracking_fine_grained"),
        value("end_effector_orientation_tracking"),
    );
    let scene = env.scene();
    let robot = scene.articulation("test", "robot").unwrap();
    let (link, offset) = scene.frame("test", robot, "tcp").unwrap();
    let a = scene.backend.articulation(robot);
    let (cmd, _) = env.commands().command("ee_pose").unwrap();
    for e in 0..4 {
        let tcp = a.frame_pose(e, link, &offset);
        let c = &cmd[e * 7..(e + 1) * 7];
        // The robot's base is the env origin, unrotated: base frame = env frame.
        let expected = (tcp.pos - Vec3::new(c[0], c[1], c[2])).length();
        assert!((d[e] - expected).abs() < 1e-5, "{} vs {expected}", d[e]);
        assert!((fine[e] - (1.0 - (expected / 0.1).tanh())).abs() < 1e-5);
        let angle = rotation_distance(tcp.rot, quat_wxyz([c[3], c[4], c[5], c[6]]));
        assert!((rot[e] - angle).abs() < 1e-5);
    }
}

/// Episodes last 12 s at 30 Hz: 360 steps.
#[test]
fn episodes_last_360_steps() {
    let env = env(&["num_envs=1"]);
    assert_eq!(env.max_episode_length(), 360);
}
