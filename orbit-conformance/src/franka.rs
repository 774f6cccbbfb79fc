//! Checks on the bundled Franka box-pushing scene: forward kinematics against MuJoCo's, holding
//! a pose under PD + gravity, and tracking MuJoCo rollouts under Fancy Gym's torque law.

use std::collections::BTreeMap;

use glam::Vec3;
use orbit_core::math::{Pose, quat_wxyz, rotation_distance};
use orbit_core::physics::{BodyRef, PhysicsBackend};
use orbit_core::scene::{PerJoint, SceneCfg, SceneDesc};
use serde::Deserialize;

use crate::scenes::{build, build_with, resolve, sim_cfg};

/// The bundled box-pushing scene config (Franka with push rod, table, box).
pub fn box_pushing_scene_cfg() -> SceneCfg {
    orbit_assets::box_pushing_scene_cfg(&[]).unwrap_or_else(|e| panic!("bundled scene: {e}"))
}

#[derive(Deserialize)]
struct BodyPose {
    xpos: [f32; 3],
    xquat_wxyz: [f32; 4],
}

#[derive(Deserialize)]
struct FkVector {
    q: Vec<f32>,
    bodies: BTreeMap<String, BodyPose>,
    rod_tip_site_xpos: [f32; 3],
}

#[derive(Deserialize)]
struct FkFile {
    fk_test_vectors: BTreeMap<String, FkVector>,
}

/// World pose of a named frame of articulation 0 in env `e`, from the backend's link poses.
pub fn frame_pose(sim: &dyn PhysicsBackend, e: usize, frame: &str) -> Pose {
    let layout = &sim.layout().articulations[0];
    let (link, offset) = layout
        .model
        .find_frame(frame)
        .unwrap_or_else(|| panic!("frame `{frame}` not in the model"));
    sim.articulation(0).frame_pose(e, link, &offset)
}

/// After writing the FK test configurations, every body origin is within 1e-4 m and every body
/// orientation within 1e-4 rad of MuJoCo's, and so is the rod-tip site.
pub fn franka_forward_kinematics(backend: &str) {
    let file: FkFile =
        serde_json::from_str(include_str!("../data/franka_fk_vectors.json")).expect("fk data");
    let scene = resolve(&box_pushing_scene_cfg());
    let n = file.fk_test_vectors.len();
    let mut sim = build(backend, &scene, n, 0.002);
    let ids: Vec<usize> = (0..n).collect();
    let q: Vec<f32> = file
        .fk_test_vectors
        .values()
        .flat_map(|v| v.q.clone())
        .collect();
    sim.write_joint_state(0, &ids, &q, &vec![0.0; q.len()])
        .expect("write joint state");
    let (mut worst_pos, mut worst_rot) = (0.0f32, 0.0f32);
    for (e, (name, vector)) in file.fk_test_vectors.iter().enumerate() {
        for (body, expected) in &vector.bodies {
            let got = frame_pose(sim.as_ref(), e, body);
            let dp = (got.pos - Vec3::from(expected.xpos)).length();
            let dr = rotation_distance(got.rot, quat_wxyz(expected.xquat_wxyz));
            worst_pos = worst_pos.max(dp);
            worst_rot = worst_rot.max(dr);
            assert!(dp < 1e-4, "{name}: `{body}` position off by {dp} m");
            assert!(dr < 1e-4, "{name}: `{body}` orientation off by {dr} rad");
        }
        let tip = frame_pose(sim.as_ref(), e, "rod_tip").pos;
        let dp = (tip - Vec3::from(vector.rod_tip_site_xpos)).length();
        worst_pos = worst_pos.max(dp);
        assert!(dp < 1e-4, "{name}: rod tip off by {dp} m");
    }
    println!(
        "franka_forward_kinematics[{backend}]: worst position error {worst_pos:.2e} m, worst orientation error {worst_rot:.2e} rad"
    );
}

/// Default arm configuration of the box-pushing task (Fancy Gym's IK result).
fn q0(scene: &orbit_core::scene::SceneDesc) -> Vec<f32> {
    scene.articulations[0].default_joint_pos.clone()
}

/// Franka under implicit PD (k = 400, d = 40, Isaac Lab's high-PD Franka), box moved aside.
/// With gravity compensation as feed-forward effort it holds the IK pose of the task within
/// 1e-3 rad over 3 s. Without compensation, started at the raised home pose
/// `(0, 0, 0, −1.5, 0, 1.5, 0)` (clear of the table), it settles where the drives balance gravity,
/// `k (q* − q) = g(q)`, to within 1 % of the largest gravity torque.
pub fn franka_holds_pose_under_pd(backend: &str) {
    let mut cfg = box_pushing_scene_cfg();
    // Move the box away from the rod so only the drives and gravity act on the arm.
    cfg.rigid_objects[0].init_state.pos = Vec3::new(0.6, -0.6, -0.01);
    for act in cfg.articulations[0].actuators.values_mut() {
        act.stiffness = PerJoint::All(400.0);
        act.damping = PerJoint::All(40.0);
    }
    let scene = resolve(&cfg);
    let ik_pose = q0(&scene);
    let home = [0.0f32, 0.0, 0.0, -1.5, 0.0, 1.5, 0.0];
    let dofs = ik_pose.len();
    let mut sim = build(backend, &scene, 2, 0.002);
    let targets = [ik_pose.clone(), home.to_vec()].concat();
    sim.write_joint_state(0, &[0, 1], &targets, &vec![0.0; 2 * dofs])
        .expect("initial state");
    sim.set_joint_position_targets(0, &targets)
        .expect("targets");
    let mut efforts = vec![0.0; 2 * dofs];
    for _ in 0..1500 {
        // Env 0: gravity compensation feed-forward; env 1: PD alone.
        efforts[..dofs].copy_from_slice(&sim.articulation(0).bias_forces[..dofs]);
        sim.set_joint_efforts(0, &efforts).expect("efforts");
        sim.step().expect("step");
    }
    let view = sim.articulation(0);
    let err_comp = (0..dofs)
        .map(|d| (view.joint_pos[d] - ik_pose[d]).abs())
        .fold(0.0, f32::max);
    let gravity = &view.bias_forces[dofs..];
    let g_max = gravity.iter().fold(0.0f32, |m, g| m.max(g.abs()));
    let balance = (0..dofs)
        .map(|d| (400.0 * (home[d] - view.joint_pos[dofs + d]) - gravity[d]).abs())
        .fold(0.0, f32::max);
    let vel = view.joint_vel.iter().fold(0.0f32, |m, v| m.max(v.abs()));
    println!(
        "franka_holds_pose[{backend}]: with compensation max |q − q*| = {err_comp:.2e} rad; PD alone: max |k(q*−q) − g(q)| = {balance:.4} N·m (max gravity torque {g_max:.2} N·m), max |q̇| = {vel:.2e}"
    );
    assert!(err_comp < 1e-3, "compensated arm drifted {err_comp} rad");
    assert!(
        balance < 0.01 * g_max,
        "PD does not balance gravity: residual {balance} N·m"
    );
    assert!(vel < 1e-2, "arm still moving: {vel} rad/s");
}

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
        serde_json::from_str(include_str!("../data/mujoco_box_pushing_rollouts.json"))
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

/// Runs the box-pushing scene for 30 env steps with random torques from the per-env RNG and
/// returns each env's final published state (joints, links and box) as raw bits. With
/// `reset_env`, that env's joints and box are written back to their defaults after 15 steps.
fn random_torque_run(
    backend: &str,
    num_envs: usize,
    threads: usize,
    seed: u64,
    reset_env: Option<usize>,
) -> Vec<Vec<u32>> {
    let scene = resolve(&box_pushing_scene_cfg());
    let settings = orbit_core::physics::SimCfg {
        num_threads: threads,
        ..sim_cfg(backend)
    };
    let mut sim = orbit_core::physics::build_backend(&scene, num_envs, &settings).expect("build");
    let dofs = sim.layout().articulations[0].num_dofs();
    let mut rngs: Vec<_> = (0..num_envs as u32)
        .map(|e| orbit_core::rng::EnvRng::new(seed, e, orbit_core::rng::streams::POLICY))
        .collect();
    let mut efforts = vec![0.0f32; num_envs * dofs];
    for step in 0..30 {
        if let Some(e) = reset_env.filter(|_| step == 15) {
            let arm = &scene.articulations[0];
            sim.write_joint_state(0, &[e], &arm.default_joint_pos, &arm.default_joint_vel)
                .expect("joint state");
            let root = scene.rigid_objects[0].default_root_state;
            sim.write_root_state(0, &[e], &[root]).expect("root state");
        }
        let bias = sim.articulation(0).bias_forces;
        for (i, tau) in efforts.iter_mut().enumerate() {
            *tau = bias[i] + 10.0 * rngs[i / dofs].uniform_range(-1.0, 1.0);
        }
        sim.set_joint_efforts(0, &efforts).expect("efforts");
        for _ in 0..10 {
            sim.step().expect("step");
        }
    }
    let arm = sim.articulation(0);
    let boxes = sim.rigid_object(0);
    let links = arm.num_links;
    let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    (0..num_envs)
        .map(|e| {
            let (j, l) = (e * dofs..(e + 1) * dofs, e * links..(e + 1) * links);
            let v3 = |v: &[Vec3]| {
                bits(
                    &v[l.clone()]
                        .iter()
                        .flat_map(|p| p.to_array())
                        .collect::<Vec<_>>(),
                )
            };
            [
                bits(&arm.joint_pos[j.clone()]),
                bits(&arm.joint_vel[j.clone()]),
                bits(&arm.bias_forces[j.clone()]),
                bits(&arm.applied_effort[j]),
                v3(arm.link_pos),
                bits(
                    &arm.link_quat[l.clone()]
                        .iter()
                        .flat_map(|q| q.to_array())
                        .collect::<Vec<_>>(),
                ),
                v3(arm.link_lin_vel),
                v3(arm.link_ang_vel),
                bits(&boxes.pos[e].to_array()),
                bits(&boxes.quat[e].to_array()),
                bits(&boxes.lin_vel[e].to_array()),
                bits(&boxes.ang_vel[e].to_array()),
            ]
            .concat()
        })
        .collect()
}

/// The same seed gives bit-identical states on repeated runs and with 1 or 2 worker threads;
/// another seed gives a different state.
pub fn deterministic_runs(backend: &str) {
    let a = random_torque_run(backend, 4, 1, 7, None);
    let b = random_torque_run(backend, 4, 1, 7, None);
    let c = random_torque_run(backend, 4, 2, 7, None);
    let d = random_torque_run(backend, 4, 1, 8, None);
    assert_eq!(a, b, "two runs with the same seed differ");
    assert_eq!(a, c, "the result depends on the number of worker threads");
    assert_ne!(a, d, "different seeds gave identical states");
    println!(
        "deterministic_runs[{backend}]: {} values bit-identical across runs and thread counts",
        a.concat().len()
    );
}

/// Writing one env's state (a reset) leaves every other env's trajectory bit for bit as it
/// would have been: envs are independent, whatever the backend batches.
pub fn resets_leave_other_envs_untouched(backend: &str) {
    let plain = random_torque_run(backend, 4, 1, 7, None);
    let with_reset = random_torque_run(backend, 4, 1, 7, Some(2));
    for e in [0, 1, 3] {
        assert_eq!(
            plain[e], with_reset[e],
            "env {e} changed when env 2 was reset"
        );
    }
    assert_ne!(plain[2], with_reset[2], "the reset of env 2 had no effect");
    println!(
        "resets_leave_other_envs_untouched[{backend}]: 3 × {} values bit-identical",
        plain[0].len()
    );
}

/// Which of an env's parameters [`randomise`] changes.
#[derive(Clone, Copy, Debug)]
struct Parameters {
    /// The box's mass, × 1.5.
    box_mass: bool,
    /// The hand's mass (the last link with a mass: the hand with the rod), × 1.3.
    hand_mass: bool,
    /// The box's friction, 0.2.
    box_friction: bool,
}

impl Parameters {
    const ALL: Self = Self {
        box_mass: true,
        hand_mass: true,
        box_friction: true,
    };
    const NONE: Self = Self {
        box_mass: false,
        hand_mass: false,
        box_friction: false,
    };

    /// All parameters but one, for each of the three.
    fn all_but_one() -> [Self; 3] {
        [
            Self {
                box_mass: false,
                ..Self::ALL
            },
            Self {
                hand_mass: false,
                ..Self::ALL
            },
            Self {
                box_friction: false,
                ..Self::ALL
            },
        ]
    }
}

/// Sets the parameters `p` of env `e` of the box-pushing scene.
fn randomise(sim: &mut dyn PhysicsBackend, scene: &SceneDesc, e: usize, p: Parameters) {
    let arm = &scene.articulations[0];
    let link = (arm.model.links.iter())
        .rposition(|l| l.inertial.mass > 0.0)
        .expect("a link with mass");
    let box_ = BodyRef::RigidObject(0);
    if p.box_mass {
        let m = scene.rigid_objects[0].body.inertial.mass;
        sim.set_masses(box_, &[e], &[1.5 * m]).expect("box mass");
    }
    if p.hand_mass {
        let m = arm.model.links[link].inertial.mass;
        let hand = BodyRef::Link {
            articulation: 0,
            link,
        };
        sim.set_masses(hand, &[e], &[1.3 * m]).expect("hand mass");
    }
    if p.box_friction {
        sim.set_friction(box_, &[e], &[0.2]).expect("box friction");
    }
}

/// Steps `ks` with each env's bias forces plus `scale · sin(0.7 (7k + i) + phase · e)` as the
/// efforts of joint `i` in env `e` (with `phase` 0, the same in every env).
fn run_with_efforts(
    sim: &mut dyn PhysicsBackend,
    ks: std::ops::Range<usize>,
    scale: f32,
    phase: f32,
) {
    let n = sim.num_envs();
    for k in ks {
        let bias = sim.articulation(0).bias_forces.to_vec();
        let tau: Vec<f32> = (0..n * 7)
            .map(|j| {
                bias[j] + scale * ((k * 7 + j % 7) as f32 * 0.7 + phase * (j / 7) as f32).sin()
            })
            .collect();
        sim.set_joint_efforts(0, &tau).expect("efforts");
        sim.step_n(10).expect("step");
    }
}

/// The bits of env `e`'s joint state and box state.
fn env_bits(sim: &dyn PhysicsBackend, e: usize) -> Vec<u32> {
    let (a, o) = (sim.articulation(0), sim.rigid_object(0));
    let (q, qd) = (
        &a.joint_pos[e * 7..e * 7 + 7],
        &a.joint_vel[e * 7..e * 7 + 7],
    );
    q.iter()
        .chain(qd)
        .chain(&o.pos[e].to_array())
        .chain(&o.quat[e].to_array())
        .chain(&o.lin_vel[e].to_array())
        .chain(&o.ang_vel[e].to_array())
        .map(|v| v.to_bits())
        .collect()
}

/// The bits of env `e`'s state after each of 10 steps with efforts of scale 5.
fn trajectory_bits(sim: &mut dyn PhysicsBackend, e: usize) -> Vec<Vec<u32>> {
    (0..10)
        .map(|k| {
            run_with_efforts(sim, k..k + 1, 5.0, 0.0);
            env_bits(sim, e)
        })
        .collect()
}

/// A reset env forgets its past: after 5 steps in which the box slides over the table (contacts
/// with friction impulses, which the solver warm-starts from), the arm and the box are written
/// back to a state (the default joints, the box settled on the table, at rest); the env then
/// follows the same trajectory, bit for bit, as one that starts from that state. It keeps what
/// is not state: the box's and the hand's masses and the box's friction, set before its history.
pub fn a_reset_env_forgets_its_past(backend: &str) {
    a_reset_env_forgets_its_past_with(&sim_cfg(backend));
}

/// [`a_reset_env_forgets_its_past`] with given simulation settings.
pub fn a_reset_env_forgets_its_past_with(settings: &orbit_core::physics::SimCfg) {
    let scene = resolve(&box_pushing_scene_cfg());
    let backend = &settings.backend;
    let arm = &scene.articulations[0];
    let build = |p: Parameters| {
        let mut sim = orbit_core::physics::build_backend(&scene, 1, settings).expect("build");
        randomise(&mut *sim, &scene, 0, p);
        sim
    };
    let settled = {
        let mut sim = build(Parameters::NONE);
        run_with_efforts(&mut *sim, 0..20, 0.0, 0.0);
        let o = sim.rigid_object(0);
        orbit_core::scene::RootState {
            pose: Pose::new(o.pos[0], o.quat[0]),
            ..Default::default()
        }
    };
    let trajectory = |history: bool| {
        let mut sim = build(Parameters::ALL);
        if history {
            // The box slides over the table: its contacts carry friction impulses when the
            // reset comes.
            let sliding = orbit_core::scene::RootState {
                lin_vel: glam::Vec3::new(0.6, 0.0, 0.0),
                ..settled
            };
            sim.write_root_state(0, &[0], &[sliding])
                .expect("root state");
            run_with_efforts(&mut *sim, 0..5, 0.0, 0.0);
            assert!(
                sim.rigid_object(0).lin_vel[0].x > 0.1,
                "the box still slides"
            );
        }
        sim.write_joint_state(0, &[0], &arm.default_joint_pos, &arm.default_joint_vel)
            .expect("joint state");
        sim.write_root_state(0, &[0], &[settled])
            .expect("root state");
        trajectory_bits(&mut *sim, 0)
    };
    let (fresh, reset) = (trajectory(false), trajectory(true));
    for (k, (f, r)) in fresh.iter().zip(&reset).enumerate() {
        assert_eq!(f, r, "step {k} after the reset differs from a fresh start");
    }
    println!("a_reset_env_forgets_its_past[{backend}]: 10 steps bit-identical");
}

/// A write replaces only what it names. Two envs, env 1 with other masses and another friction
/// (each of which is shown to change its trajectory), take 10 steps with the box sliding and
/// the arm moving; then env 1's box alone is written (sliding back). Env 0 stays as it was, bit
/// for bit, and env 1's arm within 1e-6 (a backend that rebuilds the env's world passes its
/// joint state through the simulator's own update); env 1 then follows, bit for bit, the
/// trajectory of an env built with its parameters and written to the same state without a
/// history.
pub fn a_write_replaces_only_what_it_names(backend: &str) {
    a_write_replaces_only_what_it_names_with(&sim_cfg(backend));
}

/// [`a_write_replaces_only_what_it_names`] with given simulation settings.
pub fn a_write_replaces_only_what_it_names_with(settings: &orbit_core::physics::SimCfg) {
    let scene = resolve(&box_pushing_scene_cfg());
    let backend = &settings.backend;
    let build = |n: usize, e: usize, p: Parameters| {
        let mut sim = orbit_core::physics::build_backend(&scene, n, settings).expect("build");
        randomise(&mut *sim, &scene, e, p);
        sim
    };
    let mut sim = build(2, 1, Parameters::ALL);
    let start = scene.rigid_objects[0].default_root_state;
    let sliding = orbit_core::scene::RootState {
        lin_vel: glam::Vec3::new(0.0, 0.4, 0.0),
        ..start
    };
    sim.write_root_state(0, &[0, 1], &[sliding, sliding])
        .expect("root state");
    run_with_efforts(&mut *sim, 0..10, 2.0, 0.0);
    let before = [env_bits(&*sim, 0), env_bits(&*sim, 1)];
    let (q, qd) = {
        let a = sim.articulation(0);
        (a.joint_pos[7..14].to_vec(), a.joint_vel[7..14].to_vec())
    };
    let o = sim.rigid_object(0);
    let back = orbit_core::scene::RootState {
        pose: Pose::new(o.pos[1], o.quat[1]),
        lin_vel: glam::Vec3::new(0.0, -0.4, 0.0),
        ang_vel: glam::Vec3::ZERO,
    };
    sim.write_root_state(0, &[1], &[back]).expect("root state");
    assert_eq!(env_bits(&*sim, 0), before[0], "env 0 changed");
    let after = env_bits(&*sim, 1);
    for (i, (a, b)) in after[..14].iter().zip(&before[1][..14]).enumerate() {
        let (a, b) = (f32::from_bits(*a), f32::from_bits(*b));
        assert!(
            (a - b).abs() <= 1e-6,
            "joint value {i} of env 1 moved from {b} to {a}"
        );
    }
    let carried = trajectory_bits(&mut *sim, 1);
    let fresh = |p: Parameters| {
        let mut sim = build(1, 0, p);
        sim.write_joint_state(0, &[0], &q, &qd)
            .expect("joint state");
        sim.write_root_state(0, &[0], &[back]).expect("root state");
        trajectory_bits(&mut *sim, 0)
    };
    let reference = fresh(Parameters::ALL);
    for p in Parameters::all_but_one() {
        assert_ne!(fresh(p), reference, "{p:?} changes nothing");
    }
    for (k, (f, c)) in reference.iter().zip(&carried).enumerate() {
        assert_eq!(f, c, "step {k} after the write differs from a fresh start");
    }
    println!("a_write_replaces_only_what_it_names[{backend}]: 10 steps bit-identical");
}

/// Env `e`'s box for the write facts: `start` lifted 2 cm, tilted and spinning fast, with a
/// yaw and velocities that differ per env. A GPU republish (it normalises the quaternion and
/// moves the velocity to the centre of mass and back) does not always reproduce such a state
/// bit for bit, so republishing an env twice shows.
fn spinning_box(start: &orbit_core::scene::RootState, e: usize) -> orbit_core::scene::RootState {
    let k = e as f32;
    orbit_core::scene::RootState {
        pose: Pose::new(
            start.pose.pos + glam::Vec3::new(0.0, 0.0, 0.02),
            glam::Quat::from_euler(glam::EulerRot::XYZ, 0.05, -0.03, 0.1 * k) * start.pose.rot,
        ),
        lin_vel: glam::Vec3::new(0.37, 0.013 * k, -0.21),
        ang_vel: glam::Vec3::new(3.1, -2.3, 5.7 + 0.01 * k),
    }
}

/// Writing several envs in one call equals writing them one at a time: 64 envs take 5 steps
/// with efforts that differ per env, then the arm and the box of envs 0, 21 and 63 are written
/// in one call each, or env by env in a second backend; every env's state is then the same, bit
/// for bit, right after the writes and after 5 more steps. (A backend may move the rows of a
/// few far-apart envs differently from a contiguous span.)
pub fn batched_writes_equal_single_writes(backend: &str) {
    let settings = sim_cfg(backend);
    let scene = resolve(&box_pushing_scene_cfg());
    let arm = &scene.articulations[0];
    let n = 64;
    let ids = [0, 21, 63];
    let q: Vec<f32> = ids
        .iter()
        .flat_map(|&e| {
            arm.default_joint_pos
                .iter()
                .map(move |p| p + 0.01 * e as f32)
        })
        .collect();
    let qd = vec![0.1; ids.len() * 7];
    // Tilted, spinning boxes, whose republish is not exact: a write must republish only its own
    // envs, or the envs written one at a time, republished again by each later write, drift.
    let start = scene.rigid_objects[0].default_root_state;
    let boxes: Vec<_> = ids.iter().map(|&e| spinning_box(&start, e)).collect();
    let states = |batched: bool| {
        let mut sim = orbit_core::physics::build_backend(&scene, n, &settings).expect("build");
        run_with_efforts(&mut *sim, 0..5, 2.0, 1.0);
        if batched {
            sim.write_joint_state(0, &ids, &q, &qd)
                .expect("joint state");
            sim.write_root_state(0, &ids, &boxes).expect("root state");
        } else {
            for (i, &e) in ids.iter().enumerate() {
                let r = i * 7..(i + 1) * 7;
                sim.write_joint_state(0, &[e], &q[r.clone()], &qd[r])
                    .expect("joint state");
                sim.write_root_state(0, &[e], &boxes[i..i + 1])
                    .expect("root state");
            }
        }
        let written: Vec<_> = (0..n).map(|e| env_bits(&*sim, e)).collect();
        run_with_efforts(&mut *sim, 5..10, 2.0, 1.0);
        let later: Vec<_> = (0..n).map(|e| env_bits(&*sim, e)).collect();
        (written, later)
    };
    let (batched, single) = (states(true), states(false));
    for e in 0..n {
        assert_eq!(batched.0[e], single.0[e], "env {e} right after the writes");
        assert_eq!(
            batched.1[e], single.1[e],
            "env {e} 5 steps after the writes"
        );
    }
    println!("batched_writes_equal_single_writes[{backend}]: {n} envs bit-identical");
}

/// After a write, an env step taken as one `step_n(10)` call agrees with ten `step()` calls:
/// a written env drops its warm starts for its first substep only, however the substeps are
/// dispatched. Four envs, the box resting on the table (contacts) and the arm under sinusoidal
/// efforts; env 1's box and env 2's arm are written before the step. Tolerance 1e-6 relative
/// to values above 1, absolute below: a GPU backend rounds the published state at each dispatch.
pub fn substeps_after_a_write_do_not_depend_on_dispatch(backend: &str) {
    let settings = sim_cfg(backend);
    let scene = resolve(&box_pushing_scene_cfg());
    let arm = &scene.articulations[0];
    let n = 4;
    let run = |one_call: bool| {
        let mut sim = orbit_core::physics::build_backend(&scene, n, &settings).expect("build");
        run_with_efforts(&mut *sim, 0..3, 2.0, 1.0);
        let start = scene.rigid_objects[0].default_root_state;
        sim.write_root_state(0, &[1], &[start]).expect("root state");
        let q: Vec<f32> = arm.default_joint_pos.iter().map(|p| p + 0.05).collect();
        sim.write_joint_state(0, &[2], &q, &[0.2; 7])
            .expect("joint state");
        let bias = sim.articulation(0).bias_forces.to_vec();
        let tau: Vec<f32> = (0..n * 7)
            .map(|j| bias[j] + 2.0 * (j as f32 * 0.7).sin())
            .collect();
        sim.set_joint_efforts(0, &tau).expect("efforts");
        if one_call {
            sim.step_n(10).expect("step");
        } else {
            for _ in 0..10 {
                sim.step().expect("step");
            }
        }
        let (a, o) = (sim.articulation(0), sim.rigid_object(0));
        let mut values: Vec<f32> = a.joint_pos.iter().chain(a.joint_vel).copied().collect();
        for e in 0..n {
            values.extend(o.pos[e].to_array());
            values.extend(o.quat[e].to_array());
            values.extend(o.lin_vel[e].to_array());
            values.extend(o.ang_vel[e].to_array());
        }
        values
    };
    let (one, ten) = (run(true), run(false));
    let worst = one
        .iter()
        .zip(&ten)
        .map(|(a, b)| (a - b).abs() / a.abs().max(1.0))
        .fold(0.0f32, f32::max);
    assert!(
        worst <= 1e-6,
        "step_n(10) and ten step() calls differ by up to {worst} after a write"
    );
    println!(
        "substeps_after_a_write_do_not_depend_on_dispatch[{backend}]: worst difference {worst:.2e}"
    );
}

/// A mass change touches only the envs it names. The other envs' boxes are written first
/// (tilted and spinning fast, states that a GPU republish does not always reproduce exactly);
/// then env 5's hand mass changes three times in one backend and not at all in a twin. Env 5's
/// trajectory follows its mass; every other env is bit for bit the twin's, right after the
/// changes and 3 steps later (so a change made on the device but not read back fails too).
pub fn a_mass_change_touches_only_its_envs(backend: &str) {
    let settings = sim_cfg(backend);
    let scene = resolve(&box_pushing_scene_cfg());
    let arm = &scene.articulations[0];
    let link = (arm.model.links.iter())
        .rposition(|l| l.inertial.mass > 0.0)
        .expect("a link with mass");
    let hand = BodyRef::Link {
        articulation: 0,
        link,
    };
    let hand_mass = arm.model.links[link].inertial.mass;
    let n = 16;
    let start = scene.rigid_objects[0].default_root_state;
    let others: Vec<usize> = (0..n).filter(|&e| e != 5).collect();
    let spinning: Vec<_> = others.iter().map(|&e| spinning_box(&start, e)).collect();
    let run = |scales: &[f32]| {
        let mut sim = orbit_core::physics::build_backend(&scene, n, &settings).expect("build");
        run_with_efforts(&mut *sim, 0..3, 2.0, 1.0);
        sim.write_root_state(0, &others, &spinning)
            .expect("root state");
        for &s in scales {
            sim.set_masses(hand, &[5], &[s * hand_mass])
                .expect("hand mass");
        }
        let now: Vec<_> = (0..n).map(|e| env_bits(&*sim, e)).collect();
        run_with_efforts(&mut *sim, 3..6, 2.0, 1.0);
        let later: Vec<_> = (0..n).map(|e| env_bits(&*sim, e)).collect();
        (now, later)
    };
    let (changed, twin) = (run(&[1.2, 1.3, 1.4]), run(&[]));
    assert_ne!(changed.1[5], twin.1[5], "env 5 ignores its hand mass");
    for &e in &others {
        assert_eq!(
            changed.0[e], twin.0[e],
            "env {e} after env 5's mass changes"
        );
        assert_eq!(changed.1[e], twin.1[e], "env {e} 3 steps after them");
    }
    println!(
        "a_mass_change_touches_only_its_envs[{backend}]: {} envs bit-identical",
        others.len()
    );
}
