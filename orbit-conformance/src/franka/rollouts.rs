//! Agreement with MuJoCo's box-pushing rollouts (`data/mujoco_box_pushing_rollouts.json`)
//! under Fancy Gym's torque law.

use serde::Deserialize;

use super::box_pushing_scene_cfg;
use crate::scenes::{build_with, resolve, sim_cfg};

#[derive(Deserialize)]
struct RolloutCase {
    name: String,
    controller: String,
    #[serde(default)]
    desired_pos: Vec<[f32; 7]>,
    q: Vec<[f64; 7]>,
    box_pos: Vec<[f64; 3]>,
    action: Vec<[f32; 7]>,
}

#[derive(Deserialize)]
struct Rollouts {
    initial_arm_q: [f32; 7],
    kp: [f32; 7],
    kd: [f32; 7],
    torque_scale: f32,
    torque_max: [f32; 7],
    cases: Vec<RolloutCase>,
}

/// Agreement of one rollout case with MuJoCo.
#[derive(Clone, Debug)]
pub struct RolloutAgreement {
    /// Case name.
    pub name: String,
    /// RMS joint-position error over all 100 steps and 7 joints (rad).
    pub joint_rms: f64,
    /// Largest joint-position error (rad).
    pub joint_max: f64,
    /// RMS joint-position error over the steps before the reference box first moves (1 mm),
    /// i.e. before the rod pushes it (rad).
    pub joint_rms_before_contact: f64,
    /// Number of steps before the reference box first moves.
    pub steps_before_contact: usize,
    /// Box position error after the last step (m).
    pub box_final: f64,
}

/// Asserts the MuJoCo rollouts' agreement (figures in docs/fidelity.md): every case within
/// 0.005 rad joint RMS while the arm moves freely, before the rod first pushes the box, and the
/// ProMP cases within `promp_tolerance` rad over the whole episode (the open-loop `torque_sine`
/// case diverges through contact and joint-limit impacts, and is only reported).
pub fn franka_tracks_mujoco_rollouts(backend: &str, promp_tolerance: f64) {
    franka_tracks_mujoco_rollouts_with(&sim_cfg(backend), promp_tolerance);
}

/// [`franka_tracks_mujoco_rollouts`] with these simulation settings.
pub fn franka_tracks_mujoco_rollouts_with(sim: &orbit_core::physics::SimCfg, promp_tolerance: f64) {
    for r in franka_mujoco_rollouts_with(sim) {
        assert!(
            r.joint_rms_before_contact <= 0.005,
            "{}: joint RMS before contact {} rad exceeds 0.005 rad",
            r.name,
            r.joint_rms_before_contact
        );
        if r.name.starts_with("promp") {
            assert!(
                r.joint_rms <= promp_tolerance,
                "{}: joint RMS {} rad exceeds {promp_tolerance} rad",
                r.name,
                r.joint_rms
            );
        }
    }
}

/// Replays the MuJoCo reference rollouts (`data/mujoco_box_pushing_rollouts.json`)
/// with Fancy Gym's torque law `τ = clip(10 clip(a, −1, 1) + bias, ±τ_max)`, the action either
/// recorded (`normalized_torque`) or recomputed by the ProMP PD controller from the current state
/// (`promp_pd`), all cases side by side as envs of one backend. Returns the agreement per case.
pub fn franka_mujoco_rollouts(backend: &str) -> Vec<RolloutAgreement> {
    franka_mujoco_rollouts_with(&sim_cfg(backend))
}

/// [`franka_mujoco_rollouts`] with these simulation settings.
pub fn franka_mujoco_rollouts_with(
    settings: &orbit_core::physics::SimCfg,
) -> Vec<RolloutAgreement> {
    let backend = settings.backend.as_str();
    let data: Rollouts =
        serde_json::from_str(include_str!("../../data/mujoco_box_pushing_rollouts.json"))
            .expect("rollout data");
    let scene = resolve(&box_pushing_scene_cfg());
    let n = data.cases.len();
    let dofs = 7;
    let mut sim = build_with(settings, &scene, n, 0.002);
    let ids: Vec<usize> = (0..n).collect();
    sim.write_joint_state(0, &ids, &data.initial_arm_q.repeat(n), &vec![0.0; n * dofs])
        .expect("initial state");
    let steps = data.cases[0].q.len();
    let mut sq_err = vec![0.0f64; n];
    let contact_step: Vec<usize> = data
        .cases
        .iter()
        .map(|c| {
            let b0 = c.box_pos[0];
            c.box_pos
                .iter()
                .position(|b| ((b[0] - b0[0]).powi(2) + (b[1] - b0[1]).powi(2)).sqrt() > 1e-3)
                .unwrap_or(c.box_pos.len())
        })
        .collect();
    let mut sq_err_free = vec![0.0f64; n];
    let mut max_err = vec![0.0f64; n];
    let mut efforts = vec![0.0f32; n * dofs];
    for k in 0..steps {
        let view = sim.articulation(0);
        for (e, case) in data.cases.iter().enumerate() {
            for d in 0..dofs {
                let i = e * dofs + d;
                let a = if case.controller == "promp_pd" {
                    let y = &case.desired_pos;
                    let v = if k + 1 < y.len() {
                        (y[k + 1][d] - y[k][d]) / 0.02
                    } else {
                        (y[k][d] - y[k - 1][d]) / 0.02
                    };
                    data.kp[d] * (y[k][d] - view.joint_pos[i])
                        + data.kd[d] * (v - view.joint_vel[i])
                } else {
                    case.action[k][d]
                };
                let tau = data.torque_scale * a.clamp(-1.0, 1.0) + view.bias_forces[i];
                efforts[i] = tau.clamp(-data.torque_max[d], data.torque_max[d]);
            }
        }
        sim.set_joint_efforts(0, &efforts).expect("efforts");
        for _ in 0..10 {
            sim.step().expect("step");
        }
        let view = sim.articulation(0);
        if std::env::var("ORBIT_DEBUG_ROLLOUT").is_ok() {
            let e = n - 1;
            let err: Vec<String> = (0..dofs)
                .map(|d| {
                    format!(
                        "{:+.4}",
                        f64::from(view.joint_pos[e * dofs + d]) - data.cases[e].q[k][d]
                    )
                })
                .collect();
            eprintln!("step {k}: {}", err.join(" "));
            let qd: Vec<String> = (0..dofs)
                .map(|d| format!("{:+.4}", view.joint_vel[e * dofs + d]))
                .collect();
            eprintln!("   qd {}", qd.join(" "));
        }
        for (e, case) in data.cases.iter().enumerate() {
            for d in 0..dofs {
                let err = f64::from(view.joint_pos[e * dofs + d]) - case.q[k][d];
                sq_err[e] += err * err;
                if k < contact_step[e] {
                    sq_err_free[e] += err * err;
                }
                max_err[e] = max_err[e].max(err.abs());
            }
        }
    }
    let boxes = sim.rigid_object(0);
    data.cases
        .iter()
        .enumerate()
        .map(|(e, case)| {
            let b = case.box_pos[steps - 1];
            let got = boxes.pos[e];
            let box_final = ((f64::from(got.x) - b[0]).powi(2) + (f64::from(got.y) - b[1]).powi(2) + (f64::from(got.z) - b[2]).powi(2)).sqrt();
            let r = RolloutAgreement {
                name: case.name.clone(),
                joint_rms: (sq_err[e] / (steps * dofs) as f64).sqrt(),
                joint_max: max_err[e],
                joint_rms_before_contact: (sq_err_free[e] / (contact_step[e].max(1) * dofs) as f64).sqrt(),
                steps_before_contact: contact_step[e],
                box_final,
            };
            println!(
                "mujoco_rollouts[{backend}] {:<20} joint RMS {:.4} rad, max {:.4} rad, RMS over the {} steps before the rod moves the box {:.4} rad, final box error {:.4} m",
                r.name, r.joint_rms, r.joint_max, r.steps_before_contact, r.joint_rms_before_contact, r.box_final
            );
            r
        })
        .collect()
}
